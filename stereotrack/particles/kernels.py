"""Compiled loops of the particle stage: window counts, likelihood, occlusion, exclusion, resampling, ray crossings.

See ``stereotrack/kernels.py`` for how kernels are compiled, cached and warmed up.
"""

from __future__ import annotations

import math

import numpy as np
from numba import prange

from ..kernels import _sqdist, kernel, project_points


@kernel
def crossing_points(o1, d1, r1, k1, n1, use1, o2, d2, r2, k2, n2, use2, R1, t1, f1, R2, t2, f2, radius, d_min, d_max, slack):
    """Midpoints of the closest approach of every pair of rays, one from each of two cameras, that
    (nearly) meet: closer than ``radius``, between ``d_min`` and ``d_max`` along both rays, and with
    both blobs (radii ``r1``, ``r2`` in pixels) within ``slack`` times the size a ball of that radius
    has there (camera rotation R, translation t, focal length f), and larger still by up to ``k1``,
    ``k2`` (per blob, the log of how much a ball's image may be stretched there: off the camera's axis),
    or smaller still by up to ``n1``, ``n2`` (per blob, the log of how much narrower than its ball it may read).
    Blobs not in ``use1``/``use2`` are skipped. Rays: origins and unit directions, A x 3 and B x 3.
    Returns K x 3."""
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
            # the midpoint in scalars: an array made per pair that passed the depths cost more than the arithmetic
            p1, p2 = o1[a, 0] + s * d1[a, 0], o2[b, 0] + t * d2[b, 0]
            px, gap = 0.5 * (p1 + p2), (p1 - p2) ** 2
            p1, p2 = o1[a, 1] + s * d1[a, 1], o2[b, 1] + t * d2[b, 1]
            py, gap = 0.5 * (p1 + p2), gap + (p1 - p2) ** 2
            p1, p2 = o1[a, 2] + s * d1[a, 2], o2[b, 2] + t * d2[b, 2]
            pz, gap = 0.5 * (p1 + p2), gap + (p1 - p2) ** 2
            if not math.sqrt(gap) < radius:
                continue
            z1 = R1[2, 0] * px + R1[2, 1] * py + R1[2, 2] * pz + t1[2]
            z2 = R2[2, 0] * px + R2[2, 1] * py + R2[2, 2] * pz + t2[2]
            size1 = math.log(max(r1[a], 0.5) / (f1 * radius / max(z1, 1e-6)))
            size2 = math.log(max(r2[b], 0.5) / (f2 * radius / max(z2, 1e-6)))
            if -log_slack - n1[a] < size1 < k1[a] + log_slack and -log_slack - n2[b] < size2 < k2[b] + log_slack:
                out[n, 0], out[n, 1], out[n, 2] = px, py, pz
                n += 1
    return out[:n].copy()


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
def hidden_by_balls(eye, positions, centres, radii, own_radius=0.0):
    """Points whose line of sight from ``eye`` passes through a ball in front of them (N bool); with
    ``own_radius``, balls of that radius centred on the points that a ball in front of them overlaps
    in this view. A point inside a ball is not hidden by that ball."""
    n = positions.shape[0]
    hidden = np.zeros(n, np.bool_)
    for i in range(n):
        p0, p1, p2 = positions[i, 0] - eye[0], positions[i, 1] - eye[1], positions[i, 2] - eye[2]
        dist = max(math.sqrt(p0 * p0 + p1 * p1 + p2 * p2), 1e-12)
        for b in range(centres.shape[0]):
            v0, v1, v2 = centres[b, 0] - eye[0], centres[b, 1] - eye[1], centres[b, 2] - eye[2]
            along = (p0 * v0 + p1 * v1 + p2 * v2) / dist
            perp2 = v0 * v0 + v1 * v1 + v2 * v2 - along * along
            reach = radii[b] + own_radius * along / dist  # the point's ball, scaled to the occluder's depth
            if perp2 < reach * reach and along > 0.0 and along < dist - radii[b]:
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


@kernel(inline="always")
def _rect_count(integral, x_lo, x_hi, y_lo, y_hi):
    """(set pixels, pixels) of the pixels whose centres lie in [x_lo, x_hi] x [y_lo, y_hi], clipped to the image."""
    h, w = integral.shape[0] - 1, integral.shape[1] - 1
    x0 = min(max(int(math.ceil(x_lo)), 0), w)
    x1 = min(max(int(math.floor(x_hi)) + 1, 0), w)
    y0 = min(max(int(math.ceil(y_lo)), 0), h)
    y1 = min(max(int(math.floor(y_hi)) + 1, 0), h)
    if x1 <= x0 or y1 <= y0:
        return 0.0, 0.0
    return float(integral[y1, x1] - integral[y0, x1] - integral[y1, x0] + integral[y0, x0]), float((x1 - x0) * (y1 - y0))


@kernel(inline="always")
def _box_count(integral, cx, cy, half):
    """(set pixels, pixels) of the square of pixels whose centres lie within ``half`` of (cx, cy), clipped to the image."""
    return _rect_count(integral, cx - half, cx + half, cy - half, cy + half)


@kernel(inline="always")
def _four(integral, u, v, dx, dy, half):
    """Share set of four small squares at (u +- dx, v +- dy) (corners) or, with dy = 0, at (u +- dx, v) and (u, v +- dx) (sides)."""
    c_sum, a_sum = 0.0, 0.0
    for k in range(4):
        if dy == 0.0:
            ox = dx if k == 0 else (-dx if k == 1 else 0.0)
            oy = 0.0 if k < 2 else (dx if k == 2 else -dx)
        else:
            ox = dx if k % 2 == 0 else -dx
            oy = dy if k < 2 else -dy
        c, a = _box_count(integral, u + ox, v + oy, half)
        c_sum += c
        a_sum += a
    return c_sum / a_sum if a_sum > 0.0 else 0.0


HALF_SHOWN = 0.8  # what a ball showing only a full half of its disc scores, against a whole one


@kernel(inline="always")
def _centre_surround(integral, u, v, r, inner, mid, outer, scale, bound, halves):
    """How much a disc of apparent radius ``r`` at (u, v) is what this map shows there. Four looks, each a
    share of set pixels: the disc's core (should be full), its four sides just inside its edge (full: a
    patch smaller than the disc leaves them empty), the four corners of its bounding square (empty: a
    square or a wider patch fills them), and the ring around it, on its second-emptiest side of four
    (empty: a wall fills every side, its straight edge three, a neighbouring ball or box only one). The score
    is core x sides x (1 - corners) x (1 - ring). With ``halves`` (the moving map: scenery does not move), a ball
    may be half hidden (fingers over a ball in a hand, a prop's edge in front of it): a half of the core that is
    full, with the side square in that half full, counts HALF_SHOWN as much as a whole disc, if what surrounds it
    is clear (the straight edge of a moving thing fills half the core, half the corners and half the ring). Not
    in the colour map: the stripes of a curtain of the ball's colour are half discs side by side.
    Every factor is at most 1, so a core whose best look is at or under ``bound`` (what the caller already has)
    is returned as it is: the other looks could not raise it."""
    hc = max(inner * r, 0.5)
    c_in, a_in = _box_count(integral, u, v, hc)
    if a_in == 0.0:
        return 0.0
    a_in *= scale  # a pixel is worth up to ``scale`` (a probability map x 255), else 1
    core = c_in / a_in
    if max(core, HALF_SHOWN * min(1.0, 2.0 * core) if halves else 0.0) <= bound:  # a half holds at most twice the whole's share
        return core
    a, b = mid * r, outer * r
    ring, second = 1.0, 1.0  # the emptiest strip and the next
    seen = 0
    for k in range(4):  # the strips left, right, above and below the disc, each as long as the ring is wide
        if k == 0:
            c, n = _rect_count(integral, u - b, u - a, v - b, v + b)
        elif k == 1:
            c, n = _rect_count(integral, u + a, u + b, v - b, v + b)
        elif k == 2:
            c, n = _rect_count(integral, u - b, u + b, v - b, v - a)
        else:
            c, n = _rect_count(integral, u - b, u + b, v + a, v + b)
        if n > 0.0:
            share = c / (n * scale)
            ring, second = min(ring, share), min(second, max(ring, share))  # (no branch: the order of shares is random)
            seen += 1
    if seen == 0:  # no strip inside the image: judge by the core alone
        ring = 0.0
    elif seen > 1:  # two sides must be clear: a ball beside one object clears three, the edge of a wall one
        ring = second
    half = max(0.12 * r, 0.5)  # sides and corners: squares of 0.24 r, centred 0.85 r out: inside the disc, or outside it
    sides = _four(integral, u, v, 0.85 * r, 0.0, half) / scale
    corners = _four(integral, u, v, 0.85 * r, 0.85 * r, half) / scale
    whole = core * sides
    shown = 0.0
    for k in range(2 if halves else 0):  # the halves above and below the centre, each with its side square
        sy = -1.0 if k == 0 else 1.0
        c, n = _rect_count(integral, u - hc, u + hc, min(v, v + sy * hc), max(v, v + sy * hc))
        cs, ns = _box_count(integral, u, v + sy * 0.85 * r, half)
        if n > 0.0 and ns > 0.0:
            shown = max(shown, HALF_SHOWN * (c / (n * scale)) * (cs / (ns * scale)))
    # A half disc must stand clear: the straight edge of a wall or a box fills half the core too, with half the
    # corners and half the ring, which count twice against it.
    clear = (1.0 - corners) * (1.0 - ring)
    return max(whole * clear, shown * clear * clear)


@kernel(inline="always")
def _squares(integral, u, v, ax, ay, bx, by, half, n_steps, scale):
    """Share set of ``n_steps`` small squares (half-side ``half``) evenly from (u + a) to (u + b), ends included."""
    c_sum, a_sum = 0.0, 0.0
    for k in range(n_steps):
        w = k / (n_steps - 1) if n_steps > 1 else 0.5
        c, a = _box_count(integral, u + ax + w * (bx - ax), v + ay + w * (by - ay), half)
        c_sum += c
        a_sum += a
    return c_sum / (a_sum * scale) if a_sum > 0.0 else 0.0


@kernel(inline="always")
def _capsule(integral, u, v, r, length, ex, ey, core, scale):
    """How much a ball of apparent radius ``r`` swept ``length`` pixels either way along the unit vector (ex, ey) during
    the exposure (a capsule centred on (u, v), the ball's mean position) is what this map shows: ``core`` (the share set
    inside the disc's core square, which the caller has) x the sides of the capsule, across it (at its middle and
    halfway to its ends: no waist) and inside its round ends, full x the corners beyond its ends empty x the ring
    around it, on its second-emptiest side of four (across it on
    either side, beyond either end), empty. The disc's test (``_centre_surround``) is this with no length."""
    nx, ny = -ey, ex  # across the streak
    half = max(0.12 * r, 0.5)
    d, e = 0.85 * r, length + 0.5 * r  # the ends' squares well inside the round ends: the length comes from the area, to a pixel or two
    ends = 0.5 * (
        _squares(integral, u, v, e * ex, e * ey, e * ex, e * ey, half, 1, scale)
        + _squares(integral, u, v, -e * ex, -e * ey, -e * ex, -e * ey, half, 1, scale)
    )
    # Its straight sides, at its middle and halfway to either end, each full: two balls side by side (a blob as long
    # and as filled) have a waist at their middle, where these are empty.
    sides = 1.0
    for k in range(3):
        w = 0.5 * (k - 1) * length
        share = 0.5 * (
            _squares(integral, u, v, d * nx + w * ex, d * ny + w * ey, d * nx + w * ex, d * ny + w * ey, half, 1, scale)
            + _squares(integral, u, v, -d * nx + w * ex, -d * ny + w * ey, -d * nx + w * ex, -d * ny + w * ey, half, 1, scale)
        )
        sides = min(sides, share)
    sides *= ends
    e = length + 0.85 * r  # the corners beyond the round ends, 1.2 r from their centres
    corners = 0.25 * (
        _squares(integral, u, v, e * ex + d * nx, e * ey + d * ny, e * ex + d * nx, e * ey + d * ny, half, 1, scale)
        + _squares(integral, u, v, e * ex - d * nx, e * ey - d * ny, e * ex - d * nx, e * ey - d * ny, half, 1, scale)
        + _squares(integral, u, v, -e * ex + d * nx, -e * ey + d * ny, -e * ex + d * nx, -e * ey + d * ny, half, 1, scale)
        + _squares(integral, u, v, -e * ex - d * nx, -e * ey - d * ny, -e * ex - d * nx, -e * ey - d * ny, half, 1, scale)
    )
    ring_half = max(0.3 * r, 0.5)  # squares 0.6 r wide, centred 1.5 r out: the ring of the disc's test, sampled
    g, far = 1.5 * r, length + 1.5 * r
    steps = 3 + int(2.0 * length / max(2.0 * ring_half, 1.0))  # squares along the streak's sides, about touching
    ring, second = 1.0, 1.0
    for k in range(4):
        if k == 0:
            share = _squares(
                integral,
                u,
                v,
                g * nx - length * ex,
                g * ny - length * ey,
                g * nx + length * ex,
                g * ny + length * ey,
                ring_half,
                steps,
                scale,
            )
        elif k == 1:
            share = _squares(
                integral,
                u,
                v,
                -g * nx - length * ex,
                -g * ny - length * ey,
                -g * nx + length * ex,
                -g * ny + length * ey,
                ring_half,
                steps,
                scale,
            )
        elif k == 2:
            share = _squares(
                integral, u, v, far * ex - g * nx, far * ey - g * ny, far * ex + g * nx, far * ey + g * ny, ring_half, 3, scale
            )
        else:
            share = _squares(
                integral, u, v, -far * ex - g * nx, -far * ey - g * ny, -far * ex + g * nx, -far * ey + g * ny, ring_half, 3, scale
            )
        if share < ring:
            ring, second = share, ring
        elif share < second:
            second = share
    return core * sides * (1.0 - corners) * (1.0 - second)


@kernel(parallel=True)
def ball_shape_likelihood(
    out,
    positions,
    R,
    t,
    K,
    k,
    tilt,
    colour,
    colour_scale,
    moving,
    use_moving,
    radius,
    inner,
    mid,
    outer,
    floor,
    eye,
    occ_centres,
    occ_radii,
    labels,
    label_blob,
    label_scale,
    streak,
    still_width,
    streak_major,
    streak_area,
):
    """Multiply ``out`` (N) by one camera's ball-shape factor for every particle: at the particle's depth the
    ball spans r = f R / z pixels; its core should be full of evidence and the ring around it empty, in the
    colour map (its pixels worth up to ``colour_scale``) or (``use_moving``) the moving-colour map (summed-area
    tables), floored at ``floor``. On a streak of the mask (``streak``: a ball swept along it), also the capsule
    it would sweep, in the moving map where there is one; on a still one about the ball's width (``still_width``, half
    widths: a rod, gather.still_streaks) the colour's centre-surround does not count. Outside
    the image or behind the camera: the floor; hidden from this camera (``eye``) by an occluding ball: 1; partly hidden: the core's fill alone."""
    uv, front, z = project_points(positions, R, t, K, k, tilt)
    hidden = hidden_by_balls(eye, positions, occ_centres, occ_radii)
    cut = hidden_by_balls(eye, positions, occ_centres, occ_radii, radius)  # a disc a nearer ball cuts is no test of shape
    f = 0.5 * (K[0, 0] + K[1, 1])
    h, w = colour.shape[0] - 1, colour.shape[1] - 1
    for i in prange(positions.shape[0]):  # each particle on its own: split over the cores, the same products
        if hidden[i]:
            continue
        u, v = uv[i, 0], uv[i, 1]
        if not (front[i] and u >= 0.0 and v >= 0.0 and u < w and v < h):  # also NaN
            out[i] *= floor
            continue
        r = f * radius / max(z[i], 1e-6)
        if cut[i]:  # only the core's fill: evidence is there, whatever the shape the nearer ball leaves
            c, a = _box_count(colour, u, v, max(inner * r, 0.5))
            out[i] *= max(c / (a * colour_scale) if a > 0.0 else 0.0, floor)
            continue
        b = -1  # the blob of the mask under the particle, where it is a streak
        if streak.shape[0]:
            b = label_blob[labels[min(int(v) // label_scale, labels.shape[0] - 1), min(int(u) // label_scale, labels.shape[1] - 1)]]
        on_streak = b >= 0 and streak[b]
        if on_streak and 0.5 * r <= still_width[b] <= 2.0 * r:  # a rod's end fills a ball's core, most of its ring empty
            best = floor  # (a ball's blob cut into slivers by the colour model has thin still streaks on it: not those)
        else:
            best = max(_centre_surround(colour, u, v, r, inner, mid, outer, colour_scale, floor, False), floor)
        if use_moving:
            best = max(best, _centre_surround(moving, u, v, r, inner, mid, outer, 1.0, best, True))
        if on_streak:  # also a ball swept along the streak
            length = (streak_area[b] - math.pi * r * r) / (4.0 * r)  # a capsule's area is pi r^2 + 4 r length
            if length > 0.25 * r:
                swept, scale = (moving, 1.0) if use_moving else (colour, colour_scale)  # a streak moves: on the moving map if any
                c, a = _box_count(swept, u, v, max(inner * r, 0.5))
                core = c / (a * scale) if a > 0.0 else 0.0
                if core > best:
                    best = max(best, _capsule(swept, u, v, r, length, streak_major[b, 0], streak_major[b, 1], core, scale))
        out[i] *= best


@kernel
def lifted_weights(weights, likelihoods, owners, anchors, min_likelihood, min_particles, track_floor):
    """population.Population._floored_weights' lift, before it normalises: each confirmed track's particles (``owners``
    equal to one of the sorted ``anchors``) multiplied by max(mass, track_floor / K) / mass, where the track holds
    ``min_particles`` or more particles of ``min_likelihood`` (K tracks; mass: their weight, summed in particle order as
    np.bincount sums it); the other particles as they are. One pass where numpy took a dozen calls."""
    n, k = weights.shape[0], anchors.shape[0]
    group = np.full(n, -1, np.int64)
    mass = np.zeros(k)
    alive = np.zeros(k)
    for i in range(n):
        g = np.searchsorted(anchors, owners[i])
        if g < k and anchors[g] == owners[i]:
            group[i] = g
            mass[g] += weights[i]
            alive[g] += 1.0 if likelihoods[i] >= min_likelihood else 0.0
    least = track_floor / k
    lift = np.ones(k)
    for g in range(k):
        if alive[g] >= min_particles and mass[g] > 0:
            lift[g] = max(mass[g], least) / max(mass[g], 1e-300)
    out = weights.copy()
    for i in range(n):
        if group[i] >= 0:
            out[i] = weights[i] * lift[group[i]]
    return out
