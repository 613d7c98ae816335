"""Compiled inner loops (numba) for the per-particle and per-point arithmetic of one tracker step.

The step works on a few thousand particles and a few hundred EM points per
frame; as numpy expressions that is hundreds of small array calls whose fixed
cost is most of the time (BENCHMARKS.md). Each kernel here is one plain loop
compiled once (``cache=True`` keeps the machine code next to this file, so
only the first run on a machine pays the compile: see ``warm_up``). Callers
keep their numpy-facing signatures; the kernels take plain float64 arrays.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

_LOG2PI = math.log(2 * math.pi)


def kernel(fn=None, **options):
    """``numba.njit`` as every kernel here uses it: cached on disk, releasing the GIL, and dividing
    like numpy (x / 0 is inf or nan, not an exception)."""
    options = {"cache": True, "nogil": True, "error_model": "numpy", **options}
    return njit(**options) if fn is None else njit(**options)(fn)


# Inside the kernels, arithmetic on rows (points[i] - c) would allocate a small array per
# iteration: distances and sums are spelled out on scalars instead.


# --------------------------------------------------------------------------- Cameras


@kernel(inline="always")
def _sqdist(A, i, B, j):
    """Squared distance between row i of A and row j of B (3-D)."""
    return (A[i, 0] - B[j, 0]) ** 2 + (A[i, 1] - B[j, 1]) ** 2 + (A[i, 2] - B[j, 2]) ** 2


@kernel
def _inverse_logdet(c):
    """Inverse (3 x 3) and log-determinant of one symmetric positive-definite 3 x 3 matrix."""
    a, b, cc, d, e, f = c[0, 0], c[0, 1], c[0, 2], c[1, 1], c[1, 2], c[2, 2]
    A = d * f - e * e
    B = cc * e - b * f
    C = b * e - cc * d
    D = a * f - cc * cc
    E = b * cc - a * e
    F = a * d - b * b
    det = a * A + b * B + cc * C
    inv = np.empty((3, 3))
    inv[0, 0], inv[0, 1], inv[0, 2] = A / det, B / det, C / det
    inv[1, 0], inv[1, 1], inv[1, 2] = B / det, D / det, E / det
    inv[2, 0], inv[2, 1], inv[2, 2] = C / det, E / det, F / det
    return inv, math.log(det)


@kernel
def project_points(points, R, t, K, k, tilt):
    """World points (N x 3) -> distorted pixels (N x 2), in-front flags and depths (camera z), with
    OpenCV's model: 12 coefficients ``k`` (k1 k2 p1 p2 k3 k4 k5 k6 s1 s2 s3 s4, zero-padded) and
    the tilted-sensor matrix ``tilt`` (identity unless 14 coefficients). Points behind the camera
    get NaN pixels."""
    n = points.shape[0]
    uv = np.empty((n, 2))
    front = np.empty(n, np.bool_)
    depth = np.empty(n)
    k1, k2, p1, p2, k3, k4, k5, k6, s1, s2, s3, s4 = k[0], k[1], k[2], k[3], k[4], k[5], k[6], k[7], k[8], k[9], k[10], k[11]
    for i in range(n):
        X, Y, Z = points[i, 0], points[i, 1], points[i, 2]
        xc = R[0, 0] * X + R[0, 1] * Y + R[0, 2] * Z + t[0]
        yc = R[1, 0] * X + R[1, 1] * Y + R[1, 2] * Z + t[1]
        zc = R[2, 0] * X + R[2, 1] * Y + R[2, 2] * Z + t[2]
        depth[i] = zc
        if not zc > 1e-9:
            uv[i, 0] = np.nan
            uv[i, 1] = np.nan
            front[i] = False
            continue
        x = xc / zc
        y = yc / zc
        r2 = x * x + y * y
        r4 = r2 * r2
        r6 = r4 * r2
        radial = (1.0 + k1 * r2 + k2 * r4 + k3 * r6) / (1.0 + k4 * r2 + k5 * r4 + k6 * r6)
        xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x) + s1 * r2 + s2 * r4
        yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y + s3 * r2 + s4 * r4
        tx = tilt[0, 0] * xd + tilt[0, 1] * yd + tilt[0, 2]
        ty = tilt[1, 0] * xd + tilt[1, 1] * yd + tilt[1, 2]
        tz = tilt[2, 0] * xd + tilt[2, 1] * yd + tilt[2, 2]
        inv = 1.0 / tz if tz != 0.0 else 1.0
        xd, yd = tx * inv, ty * inv
        uv[i, 0] = K[0, 0] * xd + K[0, 1] * yd + K[0, 2]
        uv[i, 1] = K[1, 1] * yd + K[1, 2]
        front[i] = True
    return uv, front, depth


@kernel
def unproject_pinhole(px, K):
    """Pixels (N x 2) of a camera without distortion -> normalised coordinates (N x 2)."""
    out = np.empty((px.shape[0], 2))
    for i in range(px.shape[0]):
        out[i, 1] = (px[i, 1] - K[1, 2]) / K[1, 1]
        out[i, 0] = (px[i, 0] - K[0, 2] - K[0, 1] * out[i, 1]) / K[0, 0]
    return out


@kernel
def rays_from_normalised(xn, R, t):
    """Normalised coordinates (N x 2) -> world rays of a camera (x_cam = R X + t): origins (its centre,
    N x 3) and unit directions (N x 3)."""
    n = xn.shape[0]
    origins = np.empty((n, 3))
    dirs = np.empty((n, 3))
    for a in range(3):  # centre = -R' t
        c = -(R[0, a] * t[0] + R[1, a] * t[1] + R[2, a] * t[2])
        for i in range(n):
            origins[i, a] = c
    for i in range(n):
        x, y = xn[i, 0], xn[i, 1]
        d0 = R[0, 0] * x + R[1, 0] * y + R[2, 0]
        d1 = R[0, 1] * x + R[1, 1] * y + R[2, 1]
        d2 = R[0, 2] * x + R[1, 2] * y + R[2, 2]
        norm = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        dirs[i, 0], dirs[i, 1], dirs[i, 2] = d0 / norm, d1 / norm, d2 / norm
    return origins, dirs


@kernel
def triangulate_dlt(xn, P):
    """Linear (DLT) triangulation of M points seen by C cameras: normalised undistorted coordinates
    ``xn`` (C x M x 2) and normalised projection matrices [R | t] ``P`` (C x 3 x 4) -> M x 3.

    Each camera gives two linear equations in the point (x P3 - P1, y P3 - P2);
    the least-squares point solves their 3 x 3 normal equations (for rays that
    meet, exactly the homogeneous SVD solution; a 4 x 4 SVD per point costs
    far more than the geometry needs).
    """
    c, m = xn.shape[0], xn.shape[1]
    out = np.empty((m, 3))
    for i in range(m):
        AtA = np.zeros((3, 3))
        Atb = np.zeros(3)
        for j in range(c):
            for row in range(2):
                a0 = xn[j, i, row] * P[j, 2, 0] - P[j, row, 0]
                a1 = xn[j, i, row] * P[j, 2, 1] - P[j, row, 1]
                a2 = xn[j, i, row] * P[j, 2, 2] - P[j, row, 2]
                rhs = -(xn[j, i, row] * P[j, 2, 3] - P[j, row, 3])
                AtA[0, 0] += a0 * a0
                AtA[0, 1] += a0 * a1
                AtA[0, 2] += a0 * a2
                AtA[1, 1] += a1 * a1
                AtA[1, 2] += a1 * a2
                AtA[2, 2] += a2 * a2
                Atb[0] += a0 * rhs
                Atb[1] += a1 * rhs
                Atb[2] += a2 * rhs
        AtA[1, 0], AtA[2, 0], AtA[2, 1] = AtA[0, 1], AtA[0, 2], AtA[1, 2]
        inv, _ = _inverse_logdet(AtA)
        for a in range(3):
            out[i, a] = inv[a, 0] * Atb[0] + inv[a, 1] * Atb[1] + inv[a, 2] * Atb[2]
    return out


# --------------------------------------------------------------------------- Blobs (abduction.py)


@kernel
def component_boxes(labels, n):
    """Pixel count and bounding box (x0, y0, x1, y1, end exclusive) of components 1..n-1 of a label image."""
    area = np.zeros(n, np.int64)
    box = np.empty((n, 4), np.int64)
    box[:, 0] = labels.shape[1]
    box[:, 1] = labels.shape[0]
    box[:, 2] = 0
    box[:, 3] = 0
    for y in range(labels.shape[0]):
        for x in range(labels.shape[1]):
            c = labels[y, x]
            if c == 0:
                continue
            area[c] += 1
            box[c, 0] = min(box[c, 0], x)
            box[c, 1] = min(box[c, 1], y)
            box[c, 2] = max(box[c, 2], x + 1)
            box[c, 3] = max(box[c, 3], y + 1)
    return area[1:], box[1:]


@kernel
def mask_moments(mask, boxes, scale):
    """Per box (x0, y0, x1, y1) of a ``scale``-times subsampled copy of a 0/1 mask: pixel count,
    centroid (x, y) and the bounding box of the set pixels (width, height) in the full mask, inside
    the box grown by one subsampled cell (the subsampling's slack). An empty box gets its own centre
    and size 0."""
    h, w = mask.shape
    m = boxes.shape[0]
    count = np.zeros(m)
    centre = np.empty((m, 2))
    size = np.zeros((m, 2))
    for b in range(m):
        x0, y0 = max(boxes[b, 0] * scale - scale, 0), max(boxes[b, 1] * scale - scale, 0)
        x1, y1 = min(boxes[b, 2] * scale + scale, w), min(boxes[b, 3] * scale + scale, h)
        sx = 0.0
        sy = 0.0
        lo_x, lo_y, hi_x, hi_y = x1, y1, x0 - 1, y0 - 1
        for y in range(y0, y1):
            for x in range(x0, x1):
                if mask[y, x]:
                    count[b] += 1.0
                    sx += x
                    sy += y
                    lo_x, hi_x = min(lo_x, x), max(hi_x, x)
                    lo_y, hi_y = min(lo_y, y), max(hi_y, y)
        if count[b] > 0:
            centre[b, 0] = sx / count[b]
            centre[b, 1] = sy / count[b]
            size[b, 0] = hi_x - lo_x + 1
            size[b, 1] = hi_y - lo_y + 1
        else:
            centre[b, 0] = 0.5 * (x0 + x1)
            centre[b, 1] = 0.5 * (y0 + y1)
    return count, centre, size


@kernel
def crossing_points(o1, d1, r1, use1, o2, d2, r2, use2, R1, t1, f1, R2, t2, f2, radius, d_min, d_max, slack):
    """Midpoints of the closest approach of every pair of rays, one from each of two cameras, that
    (nearly) meet: closer than ``radius``, between ``d_min`` and ``d_max`` along both rays, and with
    both blobs (radii ``r1``, ``r2`` in pixels) within ``slack`` times the size a ball of that radius
    has there (camera rotation R, translation t, focal length f). Blobs not in ``use1``/``use2`` are
    skipped. Rays: origins and unit directions, A x 3 and B x 3. Returns K x 3."""
    out = np.empty((o1.shape[0] * o2.shape[0], 3))
    n = 0
    log_slack = math.log(slack)
    for a in range(o1.shape[0]):
        if not use1[a]:
            continue
        for b in range(o2.shape[0]):
            if not use2[b]:
                continue
            w0, w1, w2 = o1[a, 0] - o2[b, 0], o1[a, 1] - o2[b, 1], o1[a, 2] - o2[b, 2]
            cos = d1[a, 0] * d2[b, 0] + d1[a, 1] * d2[b, 1] + d1[a, 2] * d2[b, 2]
            dd = w0 * d1[a, 0] + w1 * d1[a, 1] + w2 * d1[a, 2]
            e = w0 * d2[b, 0] + w1 * d2[b, 1] + w2 * d2[b, 2]
            den = max(1.0 - cos * cos, 1e-9)
            s = (cos * e - dd) / den
            t = (e - cos * dd) / den
            if not (s > d_min and s < d_max and t > d_min and t < d_max):
                continue
            p = np.empty(3)
            gap = 0.0
            for i in range(3):
                p1 = o1[a, i] + s * d1[a, i]
                p2 = o2[b, i] + t * d2[b, i]
                p[i] = 0.5 * (p1 + p2)
                gap += (p1 - p2) ** 2
            if not math.sqrt(gap) < radius:
                continue
            z1 = R1[2, 0] * p[0] + R1[2, 1] * p[1] + R1[2, 2] * p[2] + t1[2]
            z2 = R2[2, 0] * p[0] + R2[2, 1] * p[1] + R2[2, 2] * p[2] + t2[2]
            size1 = abs(math.log(max(r1[a], 0.5) / (f1 * radius / max(z1, 1e-6))))
            size2 = abs(math.log(max(r2[b], 0.5) / (f2 * radius / max(z2, 1e-6))))
            if size1 < log_slack and size2 < log_slack:
                out[n] = p
                n += 1
    return out[:n].copy()


# --------------------------------------------------------------------------- Particles (likelihood.py, population.py, pipeline.py)


@kernel
def systematic_resample(weights, n, u0):
    """Systematic resampling: ``n`` indices drawn with probabilities ``weights`` (summing to 1), at
    the points (u0 + i) / n of the weights' cumulative sum (u0 uniform in [0, 1))."""
    m = weights.shape[0]
    out = np.empty(n, np.int64)
    cdf = np.cumsum(weights)
    cdf[m - 1] = 1.0
    j = 0
    for i in range(n):
        u = (u0 + i) / n
        while j < m - 1 and cdf[j] <= u:
            j += 1
        out[i] = j
    return out


@kernel
def window_counts(integral, uv, valid, window):
    """Mask pixels in the W x W window centred on each pixel position (N x 2), from the mask's
    summed-area table ((H+1) x (W+1)). Windows past the image edge count their inside part;
    positions outside the image, NaN or not ``valid`` count 0."""
    h, w = integral.shape[0] - 1, integral.shape[1] - 1
    half = window // 2
    out = np.zeros(uv.shape[0], np.int64)
    for i in range(uv.shape[0]):
        u, v = uv[i, 0], uv[i, 1]
        if not (valid[i] and u > -1.0 and v > -1.0 and u < w + 1.0 and v < h + 1.0):
            continue  # also NaN
        cx, cy = int(np.rint(u)), int(np.rint(v))
        if cx < 0 or cx >= w or cy < 0 or cy >= h:
            continue
        x0, x1 = max(cx - half, 0), min(cx + half + 1, w)
        y0, y1 = max(cy - half, 0), min(cy + half + 1, h)
        out[i] = integral[y1, x1] - integral[y0, x1] - integral[y1, x0] + integral[y0, x0]
    return out


@kernel
def hidden_by_balls(eye, positions, centres, radii):
    """Points whose line of sight from ``eye`` passes through a ball in front of them (N bool).
    A point inside a ball is not hidden by that ball."""
    n = positions.shape[0]
    hidden = np.zeros(n, np.bool_)
    for i in range(n):
        p0, p1, p2 = positions[i, 0] - eye[0], positions[i, 1] - eye[1], positions[i, 2] - eye[2]
        dist = max(math.sqrt(p0 * p0 + p1 * p1 + p2 * p2), 1e-12)
        for b in range(centres.shape[0]):
            v0, v1, v2 = centres[b, 0] - eye[0], centres[b, 1] - eye[1], centres[b, 2] - eye[2]
            along = (p0 * v0 + p1 * v1 + p2 * v2) / dist
            perp2 = v0 * v0 + v1 * v1 + v2 * v2 - along * along
            if perp2 < radii[b] * radii[b] and along > 0.0 and along < dist - radii[b]:
                hidden[i] = True
                break
    return hidden


@kernel
def camera_likelihood(out, positions, R, t, K, k, tilt, integral, window, eye, occ_centres, occ_radii):
    """Multiply ``out`` (N) by one camera's eq. 14 factor max(1, r) / W^2 for every particle; a
    particle hidden from this camera (``eye``) by an occluding ball counts 1 there."""
    uv, front, _ = project_points(positions, R, t, K, k, tilt)
    r = window_counts(integral, uv, front, window)
    hidden = hidden_by_balls(eye, positions, occ_centres, occ_radii)
    area = float(window * window)
    for i in range(positions.shape[0]):
        if not hidden[i]:
            out[i] *= max(1, r[i]) / area


@kernel
def intruders(points, owners, centres, radii, ball_ids):
    """Per point: it follows a ball (owner id >= 0) but lies inside another ball (N bool)."""
    out = np.zeros(points.shape[0], np.bool_)
    for i in range(points.shape[0]):
        if owners[i] < 0:
            continue
        for b in range(centres.shape[0]):
            if ball_ids[b] != owners[i] and _sqdist(points, i, centres, b) < radii[b] * radii[b]:
                out[i] = True
                break
    return out


@kernel
def nearest_within(points, centres, limit):
    """Per point: the index of the nearest centre if it is closer than ``limit`` (metres), else -1."""
    out = np.full(points.shape[0], -1, np.int64)
    for i in range(points.shape[0]):
        best = limit * limit
        for c in range(centres.shape[0]):
            d2 = _sqdist(points, i, centres, c)
            if d2 < best:
                best = d2
                out[i] = c
    return out


# --------------------------------------------------------------------------- Clustering (clustering.py)


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


# --------------------------------------------------------------------------- Explain-away (explain.py, discs.py)


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


# --------------------------------------------------------------------------- Tracks (tracks.py)


@kernel
def association_costs(positions, covs, z, R):
    """Every (track, object) pair's squared Mahalanobis distance d2 and its negative log-likelihood
    cost d2 + log det S, S = P_track + R_object (positions T x 3 with covariances T x 3 x 3, objects
    M x 3 with R M x 3 x 3). Returns (d2, cost), both T x M."""
    T, M = positions.shape[0], z.shape[0]
    d2 = np.empty((T, M))
    cost = np.empty((T, M))
    for a in range(T):
        for b in range(M):
            inv, logdet = _inverse_logdet(covs[a] + R[b])
            y0, y1, y2 = z[b, 0] - positions[a, 0], z[b, 1] - positions[a, 1], z[b, 2] - positions[a, 2]
            m = (
                inv[0, 0] * y0 * y0
                + inv[1, 1] * y1 * y1
                + inv[2, 2] * y2 * y2
                + 2.0 * (inv[0, 1] * y0 * y1 + inv[0, 2] * y0 * y2 + inv[1, 2] * y1 * y2)
            )
            d2[a, b] = m
            cost[a, b] = m + logdet
    return d2, cost


@kernel
def kalman_predict(x, P, F, Q, b):
    """One Kalman prediction: (F x + b, F P F' + Q) for a 6-state."""
    n = x.shape[0]
    x2 = b.copy()
    FP = np.zeros((n, n))
    for i in range(n):
        for k in range(n):
            if F[i, k] != 0.0:
                x2[i] += F[i, k] * x[k]
                for j in range(n):
                    FP[i, j] += F[i, k] * P[k, j]
    P2 = Q.copy()
    for i in range(n):
        for j in range(n):
            acc = 0.0
            for k in range(n):
                acc += FP[i, k] * F[j, k]
            P2[i, j] += acc
    return x2, P2


@kernel
def kalman_correct(x, P, z, R):
    """One Kalman update with a position measurement z (covariance R) of the state's first 3 entries
    (H = [I 0]); the covariance in Joseph form, which stays symmetric positive definite."""
    n = x.shape[0]
    Sinv, _ = _inverse_logdet(P[:3, :3] + R)
    K = np.zeros((n, 3))  # P H' S^-1
    for i in range(n):
        for a in range(3):
            for c in range(3):
                K[i, a] += P[i, c] * Sinv[c, a]
    x2 = x.copy()
    for i in range(n):
        for a in range(3):
            x2[i] += K[i, a] * (z[a] - x[a])
    A = np.eye(n)  # I - K H
    for i in range(n):
        for a in range(3):
            A[i, a] -= K[i, a]
    KR = np.zeros((n, 3))
    for i in range(n):
        for a in range(3):
            for c in range(3):
                KR[i, a] += K[i, c] * R[c, a]
    AP = np.zeros((n, n))
    for i in range(n):
        for k in range(n):
            for j in range(n):
                AP[i, j] += A[i, k] * P[k, j]
    P2 = np.zeros((n, n))
    for i in range(n):
        for j in range(n):
            acc = 0.0
            for k in range(n):
                acc += AP[i, k] * A[j, k]
            for a in range(3):
                acc += KR[i, a] * K[j, a]
            P2[i, j] = acc
    return x2, P2


# --------------------------------------------------------------------------- warm-up


def warm_up() -> None:
    """Compile (or load from the cache) every kernel, so the first frame is not the slow one."""
    X = np.array([[0.0, 0.0, 1.0], [0.01, 0.0, 1.0], [0.0, 0.01, 1.1]])
    camera_arrays = (np.eye(3), np.zeros(3), np.eye(3), np.zeros(12), np.eye(3))
    covs = np.repeat(np.eye(3)[None] * 1e-3, 2, axis=0)
    means, covs, pis, _ = weighted_em(X, np.ones(3), X[:2].copy(), covs, 1, 1e-6)
    hard_labels(X, means, covs, pis)
    weighted_moments(X, np.ones((3, 2)))
    keep_heavy(np.ones((3, 2)), np.ones(3), 0.1, 1)
    label_moments(X, np.ones(3), np.zeros(3, np.int64), 1)
    uv, ok, _ = project_points(X, *camera_arrays)
    rays_from_normalised(unproject_pinhole(uv, np.eye(3)), np.eye(3), np.zeros(3))
    window_counts(np.zeros((5, 5), np.int32), uv, ok, 3)
    hidden_by_balls(np.zeros(3), X, X[:1].copy(), np.ones(1))
    systematic_resample(np.full(3, 1 / 3), 5, 0.5)
    camera_likelihood(np.ones(3), X, *camera_arrays, np.zeros((5, 5), np.int32), 3, np.zeros(3), X[:1].copy(), np.ones(1))
    nearest_within(X, X[:1].copy(), 1.0)
    yes = np.ones(3, np.bool_)
    crossing_points(
        X, X, np.ones(3), yes, X, X, np.ones(3), yes, np.eye(3), np.zeros(3), 1.0, np.eye(3), np.zeros(3), 1.0, 0.02, 0.1, 5.0, 1.6
    )
    x6, P6 = kalman_predict(np.zeros(6), np.eye(6), np.eye(6), np.eye(6), np.zeros(6))
    kalman_correct(x6, P6, np.zeros(3), np.eye(3))
    association_costs(X, np.repeat(np.eye(3)[None], 3, axis=0), X, np.repeat(np.eye(3)[None], 3, axis=0))
    P = np.zeros((2, 3, 4))
    P[:, :, :3] = np.eye(3)
    P[1, 0, 3] = -0.1
    triangulate_dlt(np.zeros((2, 1, 2)), P)
    intruders(X, np.zeros(3, np.int64), X[:1].copy(), np.ones(1), np.ones(1, np.int64))
    greedy_seeds(X, np.ones(3), X[:1].copy(), 0.02, 0.01, 12, uv[None].copy(), ok[None].copy(), np.ones((1, 3)))
    projected_spreads(uv[None].copy(), ok[None].copy(), np.ones((1, 3)), np.ones(3), np.zeros(3, np.int64), 1, 0.02)
    eye = np.eye(3)[None].copy()
    merge_one_ball_clusters(X, np.ones(3), np.zeros(3, np.int64), 0.02, eye, np.zeros((1, 3)), eye, np.zeros((1, 12)), eye)
    labels = np.zeros((4, 4), np.int32)
    labels[1:3, 1:3] = 1
    component_boxes(labels, 2)
    mask_moments((labels > 0).astype(np.uint8), np.array([[0, 0, 2, 2]], np.int64), 2)
    uv = np.ascontiguousarray(X[:, :2])
    blob_at(uv, np.ones(3, np.bool_), np.ones(3), 4, 4, labels, np.array([-1, 0]), 1, True, uv[:1], np.ones(1))
    blob_signature(X, *camera_arrays, 0.02, 4, 4, labels, np.array([-1, 0]), 1, True, uv[:1].copy(), np.ones(1))
    disc_union_mismatch(labels, np.array([-1, 0]), 0, np.array([1, 1, 3, 3], np.int64), 2, uv, np.ones(3), uv[:1], np.ones(1))
    posterior_depth(np.array([1.0, np.inf]), np.array([1.0, 2.0]), 1.5, 0.1, 10.0)
    ball_union_mismatch(X, X[:1].copy(), 0.02, *camera_arrays, labels, np.array([-1, 0]), 0, np.array([1, 1, 3, 3], np.int64), 2)
