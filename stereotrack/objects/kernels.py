"""Compiled loops of the object stage: weighted EM and the ISODATA rules, blob look-ups and disc fits.

See ``stereotrack/kernels.py`` for how kernels are compiled, cached and warmed up.
"""

from __future__ import annotations

import math

import numpy as np

from ..kernels import _inverse_logdet, _sqdist, kernel, project_points

_LOG2PI = math.log(2 * math.pi)


@kernel
def log_gauss(X, means, covs, pis):
    """log(pi_k N(x_i | mean_k, cov_k)) for every point and component: N x K."""
    n, k = X.shape[0], means.shape[0]
    out = np.empty((n, k))
    for c in range(k):
        P, logdet = _inverse_logdet(covs[c])
        const = -0.5 * (logdet + 3 * _LOG2PI) + math.log(max(pis[c], 1e-300))
        m0, m1, m2 = means[c, 0], means[c, 1], means[c, 2]
        for i in range(n):
            d0, d1, d2 = X[i, 0] - m0, X[i, 1] - m1, X[i, 2] - m2
            maha = (
                P[0, 0] * d0 * d0
                + P[1, 1] * d1 * d1
                + P[2, 2] * d2 * d2
                + 2.0 * (P[0, 1] * d0 * d1 + P[0, 2] * d0 * d2 + P[1, 2] * d1 * d2)
            )
            out[i, c] = const - 0.5 * maha
    return out


@kernel
def weighted_moments(X, rw):
    """Mass, mean and covariance of every component from point-by-component weights ``rw`` (N x K).

    A component without mass gets the origin as mean and a zero covariance."""
    n, k = X.shape[0], rw.shape[1]
    mass = np.zeros(k)
    means = np.zeros((k, 3))
    covs = np.zeros((k, 3, 3))
    for i in range(n):
        for c in range(k):
            r = rw[i, c]
            mass[c] += r
            means[c, 0] += r * X[i, 0]
            means[c, 1] += r * X[i, 1]
            means[c, 2] += r * X[i, 2]
    for c in range(k):
        if mass[c] > 1e-300:
            for a in range(3):
                means[c, a] /= mass[c]
    for i in range(n):
        for c in range(k):
            r = rw[i, c]
            if r == 0.0:
                continue
            d0, d1, d2 = X[i, 0] - means[c, 0], X[i, 1] - means[c, 1], X[i, 2] - means[c, 2]
            covs[c, 0, 0] += r * d0 * d0
            covs[c, 0, 1] += r * d0 * d1
            covs[c, 0, 2] += r * d0 * d2
            covs[c, 1, 1] += r * d1 * d1
            covs[c, 1, 2] += r * d1 * d2
            covs[c, 2, 2] += r * d2 * d2
    for c in range(k):
        s = 1.0 / max(mass[c], 1e-300)
        covs[c, 0, 0] *= s
        covs[c, 0, 1] *= s
        covs[c, 0, 2] *= s
        covs[c, 1, 1] *= s
        covs[c, 1, 2] *= s
        covs[c, 2, 2] *= s
        covs[c, 1, 0] = covs[c, 0, 1]
        covs[c, 2, 0] = covs[c, 0, 2]
        covs[c, 2, 1] = covs[c, 1, 2]
    return mass, means, covs


@kernel
def weighted_em(X, w, means, covs, iterations, reg):
    """EM for a 3-D Gaussian mixture where point i counts with weight w_i.

    Starts from ``means``/``covs`` with equal mixing weights; ``reg`` is added
    to every covariance's diagonal. Returns (means, covs, pis, resp N x K).
    """
    n, k = X.shape[0], means.shape[0]
    centre = np.zeros((1, 3))  # centred coordinates keep the moments well conditioned
    for i in range(n):
        for a in range(3):
            centre[0, a] += X[i, a] / n
    Xc = X - centre
    mu = means - centre
    cv = covs.copy()
    pis = np.full(k, 1.0 / k)
    resp = np.zeros((n, k))
    for _ in range(iterations):
        logp = log_gauss(Xc, mu, cv, pis)
        for i in range(n):
            top = logp[i, 0]
            for c in range(1, k):
                top = max(top, logp[i, c])
            s = 0.0
            for c in range(k):
                e = math.exp(logp[i, c] - top) if logp[i, c] - top > -700.0 else 0.0
                resp[i, c] = e
                s += e
            for c in range(k):
                resp[i, c] /= s
        rw = resp * w.reshape((-1, 1))
        nk, mu, cv = weighted_moments(Xc, rw)
        total = 0.0
        for c in range(k):
            cv[c, 0, 0] += reg
            cv[c, 1, 1] += reg
            cv[c, 2, 2] += reg
            total += nk[c]
        pis = nk / max(total, 1e-300)
    return mu + centre, cv, pis, resp


@kernel
def hard_labels(X, means, covs, pis):
    """Most likely component of every point (N)."""
    logp = log_gauss(X, means, covs, pis)
    n, k = logp.shape
    labels = np.zeros(n, np.int64)
    for i in range(n):
        best = logp[i, 0]
        for c in range(1, k):
            if logp[i, c] > best:
                best = logp[i, c]
                labels[i] = c
    return labels


@kernel
def keep_heavy(resp, w, min_mass, min_count):
    """Hard-assign every point to its most responsible component and drop the components that end up
    lighter than ``min_mass`` or with fewer than ``min_count`` points. Returns (kept: K bool, the kept
    components' masses, labels renumbered to the kept components; -1 for points of dropped ones)."""
    n, k = resp.shape
    labels = np.empty(n, np.int64)
    mass = np.zeros(k)
    count = np.zeros(k, np.int64)
    for i in range(n):
        best = 0
        for c in range(1, k):
            if resp[i, c] > resp[i, best]:
                best = c
        labels[i] = best
        mass[best] += w[i]
        count[best] += 1
    kept = (mass >= min_mass) & (count >= min_count)
    index = np.cumsum(kept) - 1
    for i in range(n):
        labels[i] = index[labels[i]] if kept[labels[i]] else -1
    return kept, mass[kept], labels


@kernel
def label_moments(X, w, labels, k):
    """Weight, weighted mean and covariance and point count of each of ``k`` labelled groups of points
    (label -1: in none)."""
    rw = np.zeros((X.shape[0], k))
    count = np.zeros(k, np.int64)
    for i in range(X.shape[0]):
        if labels[i] >= 0:
            rw[i, labels[i]] = w[i]
            count[labels[i]] += 1
    mass, means, covs = weighted_moments(X, rw)
    return mass, means, covs, count


@kernel
def _claim_mean(X, w, claim):
    """Weight and weighted mean of the claimed points."""
    mass = 0.0
    mean = np.zeros(3)
    for i in range(X.shape[0]):
        if claim[i]:
            mass += w[i]
            for a in range(3):
                mean[a] += w[i] * X[i, a]
    return mass, mean / max(mass, 1e-300)


@kernel
def greedy_seeds(X, w, prev_means, radius, min_mass, max_objects, uv, ok, f_over_z):
    """Starting means for EM: last frame's objects that still have mass nearby, then new modes.

    A previous mean becomes a seed when the points within ``2 R`` of it weigh
    at least ``min_mass`` (their weighted mean is the seed). Then, while fewer
    than ``max_objects``, the heaviest unclaimed point claims the unclaimed
    points that are the same ball as it: within ``2 R`` in 3D, or inside its
    apparent disc (``R f / Z`` pixels) in every camera, as a ball's cloud is
    long along the viewing direction and short across it; the claim becomes a
    seed when it weighs enough. ``uv`` (C x N x 2), ``ok`` (C x N) and
    ``f_over_z`` (C x N) are every point's projection per camera.
    """
    n = X.shape[0]
    r2 = (2.0 * radius) ** 2
    free = np.ones(n, np.bool_)
    seeds = np.empty((prev_means.shape[0] + max_objects, 3))
    count = 0
    near = np.empty(n, np.bool_)
    for m in range(prev_means.shape[0]):
        for i in range(n):
            near[i] = _sqdist(X, i, prev_means, m) < r2
        mass, mean = _claim_mean(X, w, near)
        if mass >= min_mass:
            seeds[count] = mean
            count += 1
            free &= ~near
    while count < max_objects:
        best = -1
        for i in range(n):
            if free[i] and (best < 0 or w[i] > w[best]):
                best = i
        if best < 0:
            break
        for i in range(n):
            same = free[i] and _sqdist(X, i, X, best) < r2
            if free[i] and not same:
                same = True
                for c in range(uv.shape[0]):
                    d2 = (uv[c, i, 0] - uv[c, best, 0]) ** 2 + (uv[c, i, 1] - uv[c, best, 1]) ** 2
                    if not (ok[c, i] and d2 < (radius * f_over_z[c, best]) ** 2):
                        same = False
                        break
            near[i] = same
        free &= ~near
        mass, mean = _claim_mean(X, w, near)
        if mass >= min_mass:
            seeds[count] = mean
            count += 1
    return seeds[:count].copy()


@kernel
def projected_spreads(uv, ok, f_over_z, w, labels, k, radius):
    """Per cluster: the largest ratio (projected standard deviation along its principal axis /
    apparent ball radius) over cameras, and that camera's index. Points per camera: pixels ``uv``
    (C x N x 2), in front ``ok`` (C x N), focal length over depth ``f_over_z`` (C x N); weights ``w``,
    cluster ``labels`` (-1: none). Clusters seen by fewer than 3 points in a camera get 0 there."""
    best = np.zeros(k)
    which = np.zeros(k, np.int64)
    for c in range(uv.shape[0]):
        s = np.zeros((k, 7))  # weight, u, v, uu, vv, uv, f/z sums; and a count
        count = np.zeros(k, np.int64)
        for i in range(uv.shape[1]):
            lab = labels[i]
            if lab < 0 or not ok[c, i]:
                continue
            u, v, ww = uv[c, i, 0], uv[c, i, 1], w[i]
            s[lab, 0] += ww
            s[lab, 1] += ww * u
            s[lab, 2] += ww * v
            s[lab, 3] += ww * u * u
            s[lab, 4] += ww * v * v
            s[lab, 5] += ww * u * v
            s[lab, 6] += ww * f_over_z[c, i]
            count[lab] += 1
        for q in range(k):
            if count[q] < 3:
                continue
            s0 = max(s[q, 0], 1e-300)
            cu, cv = s[q, 1] / s0, s[q, 2] / s0
            suu, svv, suv = s[q, 3] / s0 - cu * cu, s[q, 4] / s0 - cv * cv, s[q, 5] / s0 - cu * cv
            lam = 0.5 * (suu + svv) + math.sqrt(max(0.25 * (suu - svv) ** 2 + suv * suv, 0.0))
            r_px = radius * s[q, 6] / s0  # the cluster's apparent ball radius, pixels
            ratio = math.sqrt(max(lam, 0.0)) / max(r_px, 1e-9)
            if ratio > best[q]:
                best[q], which[q] = ratio, c
    return best, which


@kernel
def merge_one_ball_clusters(means, mass, labels, radius, Rs, ts, Ks, ks, tilts):
    """Merge every pair of clusters that is one ball, the closest pair first, until none is left.

    A pair is one ball when closer than R, or closer than 2R (touching balls
    are 2R apart) while no camera sees them more than half a ball apart (one
    ball's particle cloud is long along the viewing direction). A merged
    cluster's mean is the mass-weighted mean of the two. Cameras are given
    stacked (R, t, K, 12 coefficients, tilt per camera, as ``project_points``
    takes them). Returns (kept: K bool, the means and masses of the kept
    clusters, labels renumbered to them; -1 stays -1).
    """
    k = means.shape[0]
    means = means.copy()
    mass = mass.copy()
    alive = np.ones(k, np.bool_)
    into = np.arange(k)
    cams = Rs.shape[0]
    while True:
        uv = np.empty((cams, k, 2))
        ok = np.empty((cams, k), np.bool_)
        r_px = np.empty((cams, k))
        for c in range(cams):
            uv_c, ok_c, z = project_points(means, Rs[c], ts[c], Ks[c], ks[c], tilts[c])
            uv[c] = uv_c
            ok[c] = ok_c
            f = 0.5 * (Ks[c, 0, 0] + Ks[c, 1, 1])
            for i in range(k):
                r_px[c, i] = f * radius / max(z[i], 1e-6)
        best_i, best_j, best_d = -1, -1, np.inf
        for i in range(k):
            if not alive[i]:
                continue
            for j in range(i + 1, k):
                if not alive[j]:
                    continue
                d3 = math.sqrt(_sqdist(means, i, means, j))
                if d3 >= 2 * radius or d3 >= best_d:
                    continue
                sep = 0.0  # largest separation over cameras, in apparent ball radii
                for c in range(cams):
                    if ok[c, i] and ok[c, j]:
                        d_px = math.sqrt((uv[c, i, 0] - uv[c, j, 0]) ** 2 + (uv[c, i, 1] - uv[c, j, 1]) ** 2)
                        sep = max(sep, d_px / min(r_px[c, i], r_px[c, j]))
                    else:
                        sep = np.inf
                if d3 < radius or sep < 0.5:
                    best_i, best_j, best_d = i, j, d3
        if best_i < 0:
            break
        i, j = best_i, best_j
        total = mass[i] + mass[j]
        for a in range(3):
            means[i, a] = (mass[i] * means[i, a] + mass[j] * means[j, a]) / total
        mass[i] = total
        alive[j] = False
        for m in range(k):
            if into[m] == j:
                into[m] = i
    index = np.cumsum(alive) - 1
    out_labels = labels.copy()
    for p in range(labels.shape[0]):
        if labels[p] >= 0:
            out_labels[p] = index[into[labels[p]]]
    return alive, means[alive], mass[alive], out_labels


@kernel
def blob_at(uv, ok, r_px, width, height, labels, label_blob, scale, use_labels, centres, radii):
    """Per projected point (pixels ``uv``, in front ``ok``, apparent radius ``r_px``): the blob whose
    label it falls on, else the nearest blob whose disc (radius ``max(r_px, 3)`` px more) reaches it,
    else -1. Without labels (``use_labels`` False) only the nearest-blob rule applies."""
    out = np.full(uv.shape[0], -1, np.int64)
    for i in range(uv.shape[0]):
        if not ok[i]:
            continue
        u, v = uv[i, 0], uv[i, 1]
        if use_labels and u >= 0 and u < width and v >= 0 and v < height:
            x = min(int(u / scale), labels.shape[1] - 1)
            y = min(int(v / scale), labels.shape[0] - 1)
            out[i] = label_blob[labels[y, x]]
        if out[i] >= 0:
            continue
        best, best_d = -1, np.inf
        for b in range(centres.shape[0]):
            d = math.sqrt((u - centres[b, 0]) ** 2 + (v - centres[b, 1]) ** 2)
            if d < best_d:
                best, best_d = b, d
        if best >= 0 and best_d <= max(r_px[i], 3.0) + radii[best]:
            out[i] = best
    return out


@kernel
def blob_signature(positions, R, t, K, k, tilt, radius, width, height, labels, label_blob, scale, use_labels, centres, radii):
    """Per ball position, in one camera (its projection arrays, image size): the blob it sees
    (``blob_at``; -1: none, or behind the camera) and log(blob radius / the radius a ball of
    ``radius`` has there), NaN where it sees none."""
    uv, front, z = project_points(positions, R, t, K, k, tilt)
    f = 0.5 * (K[0, 0] + K[1, 1])
    r_px = np.empty(positions.shape[0])
    for i in range(positions.shape[0]):
        r_px[i] = f * radius / (z[i] if front[i] else 1.0)
    ids = blob_at(uv, front, r_px, width, height, labels, label_blob, scale, use_labels, centres, radii)
    log_ratio = np.full(positions.shape[0], np.nan)
    for i in range(positions.shape[0]):
        if ids[i] >= 0:
            log_ratio[i] = math.log(max(radii[ids[i]], 0.5) / r_px[i])
    return ids, log_ratio


@kernel
def _cells_around_discs(uv, r, scale, off, x0, y0, x1, y1):
    """The window of label cells (x0, y0, x1, y1) grown to hold every disc (centre uv, radius r, pixels)."""
    for i in range(uv.shape[0]):
        x0 = min(x0, int(math.floor((uv[i, 0] - r[i] - off) / scale)))
        y0 = min(y0, int(math.floor((uv[i, 1] - r[i] - off) / scale)))
        x1 = max(x1, int(math.ceil((uv[i, 0] + r[i] - off) / scale)) + 1)
        y1 = max(y1, int(math.ceil((uv[i, 1] + r[i] - off) / scale)) + 1)
    return x0, y0, x1, y1


@kernel
def disc_union_mismatch(labels, label_blob, blob, box, scale, cand_uv, cand_r, other_uv, other_r):
    """Per candidate disc: the label cells where (candidate disc | other discs) differs from blob ``blob``.

    Discs are in pixels (centre, radius); a label cell (x, y) stands for the
    pixel at its centre, (x * scale + off, y * scale + off). Cells are counted
    over a window holding the blob's box (x0, y0, x1, y1 in cells) and every
    disc, clipped to the label image: outside it nothing can differ.
    """
    off = 0.5 * (scale - 1)
    h, w = labels.shape
    x0, y0, x1, y1 = box[0], box[1], box[2], box[3]
    x0, y0, x1, y1 = _cells_around_discs(cand_uv, cand_r, scale, off, x0, y0, x1, y1)
    x0, y0, x1, y1 = _cells_around_discs(other_uv, other_r, scale, off, x0, y0, x1, y1)
    x0, y0, x1, y1 = max(x0, 0), max(y0, 0), min(x1, w), min(y1, h)
    ww, hh = max(x1 - x0, 0), max(y1 - y0, 0)
    in_blob = np.zeros((hh, ww), np.bool_)
    covered = np.zeros((hh, ww), np.bool_)  # by the other balls' discs
    for y in range(hh):
        gy = (y0 + y) * scale + off
        for x in range(ww):
            gx = (x0 + x) * scale + off
            in_blob[y, x] = label_blob[labels[y0 + y, x0 + x]] == blob
            for k in range(other_uv.shape[0]):
                if (gx - other_uv[k, 0]) ** 2 + (gy - other_uv[k, 1]) ** 2 <= other_r[k] ** 2:
                    covered[y, x] = True
                    break
    out = np.zeros(cand_uv.shape[0])
    for t in range(cand_uv.shape[0]):
        u, v, r2 = cand_uv[t, 0], cand_uv[t, 1], cand_r[t] ** 2
        count = 0
        for y in range(hh):
            gy = (y0 + y) * scale + off
            for x in range(ww):
                gx = (x0 + x) * scale + off
                ball = covered[y, x] or (gx - u) ** 2 + (gy - v) ** 2 <= r2
                if ball != in_blob[y, x]:
                    count += 1
        out[t] = count * scale * scale
    return out


@kernel
def ball_union_mismatch(candidates, others, radius, R, t, K, k, tilt, labels, label_blob, blob, box, scale):
    """``disc_union_mismatch`` for balls given in the world: candidate positions (T x 3) of the ball
    being placed and the other balls (K x 3) sharing the blob, seen by one camera (its projection
    arrays). Candidates behind the camera get +inf; other balls behind it are left out."""
    f = 0.5 * (K[0, 0] + K[1, 1])
    uv_c, front_c, z_c = project_points(candidates, R, t, K, k, tilt)
    uv_o, front_o, z_o = project_points(others, R, t, K, k, tilt)
    seen_c, seen_o = np.flatnonzero(front_c), np.flatnonzero(front_o)
    out = np.full(candidates.shape[0], np.inf)
    if seen_c.size == 0:
        return out
    cand_uv, other_uv = uv_c[seen_c], uv_o[seen_o]
    cand_r, other_r = f * radius / z_c[seen_c], f * radius / z_o[seen_o]
    out[seen_c] = disc_union_mismatch(labels, label_blob, blob, box, scale, cand_uv, cand_r, other_uv, other_r)
    return out


@kernel
def posterior_depth(mismatch, depths, prior, prior_sigma, scale):
    """Mean and standard deviation of the depth under exp(-mismatch / scale) times a Gaussian prior
    (see ``discs.depth_on_ray``); NaN when no depth has a finite mismatch."""
    low = np.inf
    for i in range(mismatch.shape[0]):
        low = min(low, mismatch[i])
    if not np.isfinite(low):
        return np.nan, np.nan
    logw = np.full(mismatch.shape[0], -np.inf)
    top = -np.inf
    for i in range(mismatch.shape[0]):
        if np.isfinite(mismatch[i]):
            logw[i] = -(mismatch[i] - low) / scale - 0.5 * ((depths[i] - prior) / max(prior_sigma, 1e-6)) ** 2
            top = max(top, logw[i])
    total, first = 0.0, 0.0
    w = np.exp(logw - top)
    for i in range(w.shape[0]):
        total += w[i]
        first += w[i] * depths[i]
    mean = first / total
    second = 0.0
    for i in range(w.shape[0]):
        second += w[i] * (depths[i] - mean) ** 2
    return mean, math.sqrt(second / total)


@kernel
def partial_disc_counts(candidates, radius, R, t, K, k, tilt, seen, maybe, ring):
    """Per candidate ball position (T x 3), in one camera whose view of the ball is partial, four pixel counts
    (T x 4): of ``seen`` (H x W, the ball's evidence there) in the ring just outside the ball's disc, out to
    ``ring`` radii (a ball's own pixels all lie inside its disc, wherever the rest of it is hidden); inside the
    disc, those neither ``seen`` nor ``maybe`` (what may be the ball behind something of its colour) sets (open
    background where the ball should show, or whatever hides it); inside the disc, those ``seen`` sets; and of
    these, those in the rim just inside the outline (up to 2 pixels in: where the visible part's curved edge
    lies when the disc is the ball's). The disc's last pixel inside the outline is not counted empty, and the
    first outside not as ring (its edge blurs); pixels outside the image count for nothing. +inf behind the camera."""
    uv, front, z = project_points(candidates, R, t, K, k, tilt)
    f = 0.5 * (K[0, 0] + K[1, 1])
    h, w = seen.shape
    out = np.full((candidates.shape[0], 4), np.inf)
    for i in range(candidates.shape[0]):
        if not front[i]:
            continue
        u, v = uv[i, 0], uv[i, 1]
        r = f * radius / z[i]
        outer = ring * r
        disc2, inside2, edge2, outer2, rim2 = r * r, max(r - 1.0, 0.0) ** 2, (r + 1.0) ** 2, outer * outer, max(r - 2.0, 0.0) ** 2
        x0, x1 = max(int(math.floor(u - outer)), 0), min(int(math.ceil(u + outer)) + 1, w)
        y0, y1 = max(int(math.floor(v - outer)), 0), min(int(math.ceil(v + outer)) + 1, h)
        around, empty, hits, rim = 0.0, 0.0, 0.0, 0.0
        for y in range(y0, y1):
            dy = y - v
            for x in range(x0, x1):
                dx = x - u
                d2 = dx * dx + dy * dy
                if d2 <= disc2:
                    if seen[y, x] != 0:
                        hits += 1.0
                        if d2 >= rim2:
                            rim += 1.0
                    elif maybe[y, x] == 0 and d2 <= inside2:
                        empty += 1.0
                elif edge2 <= d2 <= outer2 and seen[y, x] != 0:
                    around += 1.0
        out[i, 0], out[i, 1], out[i, 2], out[i, 3] = around, empty, hits, rim
    return out
