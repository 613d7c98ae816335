"""Compiled loops of the evidence stage's blobs and streaks: components and moments, faint cells, streak pre-tests.

For ``blobs.py`` (connected components and their moments) and ``gather.py`` (the faint pass's pale cells and pixels,
the streak checks' pre-test); the maps' loops are in ``kernels.py``. See ``stereotrack/kernels.py`` for how kernels are compiled, cached and warmed up.
"""

from __future__ import annotations

import numpy as np

from ..kernels import kernel
from .kernels import _in_bounds


@kernel
def subsampled(mask, scale, rows):
    """mask[::scale, ::scale] as a new contiguous array (a plain loop: twice as fast as numpy's strided copy), a
    label image of its size (int32) zeroed outside the box (x0, y0, x1, y1, end exclusive) of its set pixels, and
    that box, its start rounded down to even (all zeros: empty, the label image all zero): the caller labels inside
    the box (blobs._components). Rows of the mask that ``rows`` (one per mask row; empty: every row) marks 0 are
    empty: they are not read."""
    h, w = mask.shape
    out = np.empty(((h + scale - 1) // scale, (w + scale - 1) // scale), mask.dtype)
    x0, y0, x1, y1 = out.shape[1], out.shape[0], 0, 0
    every = rows.shape[0] == 0
    for y in range(out.shape[0]):
        row, o = mask[scale * y], out[y]
        if not every and not rows[scale * y]:
            o[:] = 0
            continue
        first, last = -1, -1
        for x in range(out.shape[1]):
            o[x] = row[scale * x]
            if o[x]:
                last = x
                if first < 0:
                    first = x
        if last >= 0:
            x0, x1 = min(x0, first), max(x1, last + 1)
            y0, y1 = min(y0, y), y + 1
    labels = np.empty(out.shape, np.int32)
    if x1 == 0:
        labels[:] = 0
        return out, labels, 0, 0, 0, 0
    x0, y0 = x0 - x0 % 2, y0 - y0 % 2
    labels[:y0] = 0
    labels[y1:] = 0
    for y in range(y0, y1):  # the box itself is the labeller's to write
        labels[y, :x0] = 0
        labels[y, x1:] = 0
    return out, labels, x0, y0, x1, y1


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
    centroid (x, y), the bounding box of the set pixels (width, height) in the full mask, and their
    central second moments (xx, yy, xy), inside the box grown by one subsampled cell (the
    subsampling's slack). An empty box gets its own centre and size 0."""
    h, w = mask.shape
    m = boxes.shape[0]
    count = np.zeros(m)
    centre = np.empty((m, 2))
    size = np.zeros((m, 2))
    second = np.zeros((m, 3))
    for b in range(m):
        x0, y0 = max(boxes[b, 0] * scale - scale, 0), max(boxes[b, 1] * scale - scale, 0)
        x1, y1 = min(boxes[b, 2] * scale + scale, w), min(boxes[b, 3] * scale + scale, h)
        sx = 0.0
        sy = 0.0
        sxx = 0.0
        syy = 0.0
        sxy = 0.0
        lo_x, lo_y, hi_x, hi_y = x1, y1, x0 - 1, y0 - 1
        for y in range(y0, y1):
            for x in range(x0, x1):
                if mask[y, x]:
                    count[b] += 1.0
                    dx, dy = float(x - x0), float(y - y0)  # about the box corner: no loss of precision
                    sx += dx
                    sy += dy
                    sxx += dx * dx
                    syy += dy * dy
                    sxy += dx * dy
                    lo_x, hi_x = min(lo_x, x), max(hi_x, x)
                    lo_y, hi_y = min(lo_y, y), max(hi_y, y)
        if count[b] > 0:
            n = count[b]
            mx, my = sx / n, sy / n
            centre[b, 0] = x0 + mx
            centre[b, 1] = y0 + my
            size[b, 0] = hi_x - lo_x + 1
            size[b, 1] = hi_y - lo_y + 1
            second[b, 0] = sxx / n - mx * mx
            second[b, 1] = syy / n - my * my
            second[b, 2] = sxy / n - mx * my
        else:
            centre[b, 0] = 0.5 * (x0 + x1)
            centre[b, 1] = 0.5 * (y0 + y1)
    return count, centre, size, second


@kernel
def component_measures(mask, labels, n, x0, y0, scale, min_area, width, height, elongation, fill):
    """Everything blobs._components measures of the components 1..n-1 of ``labels`` (a label image of the box at
    (``x0``, ``y0``) of a ``scale``-times subsampled copy of the 0/1 ``mask``), in one call: which are blobs (their
    subsampled area x scale^2 at least ``min_area``), label -> blob index (-1: background or a speck), and per blob
    its box (label cells, end exclusive) and, measured on ``mask`` (mask_moments): pixel count, centroid, the size
    of its set pixels, central second moments, the semi-axes of the filled ellipse with those moments (major first; a
    filled ellipse of semi-axes a, b has variances a^2 / 4 and b^2 / 4 along them) and half its larger side. What
    component_boxes, mask_moments and the numpy arithmetic between them gave, without a dozen small array calls per
    blob finder (three a frame per camera and target). Last, per blob, whether it could be a streak: shaped like one
    (blobs.streaks with ``elongation`` and ``fill`` = STREAK_FILL x pi, in its order of operations) and its box away from
    the edges of the ``width`` x ``height`` label grid (blobs._components tells the uneven ones apart)."""
    area, box = component_boxes(labels, n)
    label_blob = np.full(n, -1, np.int64)
    m = 0
    for c in range(n - 1):
        if area[c] * scale * scale >= min_area:
            label_blob[c + 1] = m
            m += 1
    boxes = np.empty((m, 4), np.int64)
    for c in range(n - 1):
        b = label_blob[c + 1]
        if b >= 0:
            boxes[b, 0], boxes[b, 1], boxes[b, 2], boxes[b, 3] = box[c, 0] + x0, box[c, 1] + y0, box[c, 2] + x0, box[c, 3] + y0
    count, centre, size, second = mask_moments(mask, boxes, scale)
    axes = np.empty((m, 2))
    radii = np.empty(m)
    for b in range(m):
        mean = 0.5 * (second[b, 0] + second[b, 1])
        d = second[b, 0] - second[b, 1]
        spread = np.sqrt(0.25 * (d * d) + second[b, 2] * second[b, 2])
        axes[b, 0] = 2.0 * np.sqrt(max(mean + spread, 0.0))
        axes[b, 1] = 2.0 * np.sqrt(max(mean - spread, 0.0))
        radii[b] = 0.5 * max(size[b, 0], size[b, 1])
    swept = np.zeros(m, np.bool_)
    for b in range(m):
        inside = boxes[b, 0] > 0 and boxes[b, 1] > 0 and boxes[b, 2] < width and boxes[b, 3] < height
        semi_minor = axes[b, 1] if axes[b, 1] > 0.5 else 0.5
        swept[b] = inside and axes[b, 0] >= elongation * semi_minor and count[b] >= fill * axes[b, 0] * semi_minor
    return label_blob, boxes, count, centre, size, second, axes, radii, swept


@kernel
def uneven(mask, centres, major, axes, along, across):
    """Per blob: wider in some places than others along its major axis (blobs._uneven, which says why): at each of the
    places ``along`` (offsets in semi-major axes) the mask's pixels counted at the places ``across`` it (in semi-minor
    axes), rounded half to even and cut to the mask as numpy's rint, astype and clip give; the narrowest count under 70 %
    of the widest and 3 pixels narrower (counts in pixels: samples 0.2 semi-minor axes apart). The arithmetic of the
    numpy expression it replaces, in its order, one blob at a time (no M x 7 x 13 temporaries)."""
    h, w = mask.shape
    out = np.zeros(centres.shape[0], np.bool_)
    for m in range(centres.shape[0]):
        ux, uy, a0, a1 = major[m, 0], major[m, 1], axes[m, 0], axes[m, 1]
        cx, cy = centres[m, 0], centres[m, 1]
        step = 0.2 * a1
        narrowest, widest = np.inf, -np.inf
        for i in range(along.shape[0]):
            al = along[i] * a0
            count = 0
            for j in range(across.shape[0]):
                ac = across[j] * a1
                x = min(max(np.int64(np.rint(cx + ux * al - uy * ac)), 0), w - 1)
                y = min(max(np.int64(np.rint(cy + uy * al + ux * ac)), 0), h - 1)
                count += mask[y, x] > 0
            width = count * step
            narrowest, widest = min(narrowest, width), max(widest, width)
        out[m] = narrowest < 0.7 * widest and widest - narrowest > 3.0
    return out


UNMIX_MAX = 10  # a streak's pixel may show the ball for as little as 1 / UNMIX_MAX of the exposure


@kernel
def pale_cells(faint, image, behind, streak, target, others, out):
    """Per cell of the background's grid (``image``, this frame there, and ``behind``, the background, both BGR
    uint8): ``out`` = ``faint``'s mark (1, or 2 where the cell changed from the frame before) where it is set and
    the cell could be a fast ball's streak: its colour in the ``streak`` bounds (colour.streak_range) where the
    background's is not (motion_blur tune seed 15: a faint blob where the frame before's streak was, which the
    background had learnt in part, passed), or the background plus 2 to UNMIX_MAX times its change in the
    ``target`` bounds. A pixel the ball swept over sees it a share a of the exposure and the room the rest,
    pixel = background + a (ball - background): on a wall of the complementary colour (a yellow ball on lavender)
    the mix is grey, but the change still points from the wall to the ball (fast_ball tune seed 17).
    A cell whose change, 1 to UNMIX_MAX times over the background, lands in one of the ``others`` bounds (K x 7: the
    other targets' ranges) is that target's edge, not a streak (an orange ball's rim over a wall, pale and reddish,
    passes a pink ball's streak range)."""
    h, w = faint.shape
    for y in range(h):
        marks, row = faint[y], out[y]
        any_mark = 0
        for x in range(w):  # no branch: vectorised (most rows hold no faint cell)
            any_mark |= marks[x]
            row[x] = 0
        if not any_mark:
            continue
        for x in range(w):
            mark = marks[x]
            if not mark:
                continue
            b, g, r = np.float32(image[y, x, 0]), np.float32(image[y, x, 1]), np.float32(image[y, x, 2])
            b0, g0, r0 = np.float32(behind[y, x, 0]), np.float32(behind[y, x, 1]), np.float32(behind[y, x, 2])
            hh, ss, vv = _hsv(b, g, r)
            hit = 0
            if _in_bounds(hh, ss, vv, streak):  # of a streak's colour, over a background that is not (that says nothing)
                h0, s0, v0 = _hsv(b0, g0, r0)
                hit = 0 if _in_bounds(h0, s0, v0, streak) else mark
            if not hit:
                for k in range(2, UNMIX_MAX + 1):
                    cb, cg, cr = b0 + k * (b - b0), g0 + k * (g - g0), r0 + k * (r - r0)
                    if min(cb, cg, cr) < -0.5 or max(cb, cg, cr) > 255.5:
                        break
                    hh, ss, vv = _hsv(cb, cg, cr)
                    if _in_bounds(hh, ss, vv, target):
                        hit = mark
                        break
            if hit and others.shape[0]:
                for k in range(1, UNMIX_MAX + 1):
                    cb, cg, cr = b0 + k * (b - b0), g0 + k * (g - g0), r0 + k * (r - r0)
                    if min(cb, cg, cr) < -0.5 or max(cb, cg, cr) > 255.5:
                        break
                    hh, ss, vv = _hsv(cb, cg, cr)
                    for o in range(others.shape[0]):
                        if _in_bounds(hh, ss, vv, others[o]):
                            hit = 0
                    if not hit:
                        break
            out[y, x] = hit


@kernel(inline="always")
def _hsv(b, g, r):
    """OpenCV's 8-bit BGR -> HSV of one pixel (channels as float32 0..255): H 0..179, S and V 0..255."""
    v = max(b, g, r)
    diff = v - min(b, g, r)
    s = np.int64(np.rint(255.0 * diff / v)) if v > 0 else np.int64(0)
    if diff <= 0:
        return np.int64(0), s, np.int64(np.rint(v))
    if v == r:
        hue = 60.0 * (g - b) / diff
    elif v == g:
        hue = 120.0 + 60.0 * (b - r) / diff
    else:
        hue = 240.0 + 60.0 * (r - g) / diff
    if hue < 0:
        hue += 360.0
    return np.int64(np.rint(hue / 2.0)) % 180, s, np.int64(np.rint(v))


@kernel
def faint_pixels(cells, cell_rows, cell_cols, in_range, moving, pale, rows):
    """The pixels of the marked ``cells`` (pale_cells' ``out``, on the background's grid; pixel (x, y) reads
    cells[cell_rows[y], cell_cols[x]], what cv2.resize's INTER_NEAREST picks) set in ``pale`` (uint8 0/1, the caller's
    copy of the ``moving`` map) and their rows in ``rows`` (gather.py's rows that may hold a pixel); returns how many of
    them are neither in range (``in_range``) nor moving: the new pale pixels. Only the marked cells' pixels are read
    (a few balls' worth), where an upscaled copy of the cells, a threshold, two bitwise passes and a row reduction
    read every pixel."""
    row_from, row_to = _runs(cell_rows, cells.shape[0])  # the maps rise: the pixels reading a cell are one run a side
    col_from, col_to = _runs(cell_cols, cells.shape[1])
    new = 0
    for cy in range(cells.shape[0]):
        marks = cells[cy]
        any_mark = 0
        for cx in range(cells.shape[1]):  # no branch: the compiler vectorises it (most rows hold no mark)
            any_mark |= marks[cx]
        if not any_mark:
            continue
        for cx in range(cells.shape[1]):
            if not marks[cx]:
                continue
            for y in range(row_from[cy], row_to[cy]):
                rows[y] = 1
                for x in range(col_from[cx], col_to[cx]):
                    if not in_range[y, x] and not moving[y, x]:
                        new += 1
                    pale[y, x] = 1
    return new


@kernel
def streak_candidates(mask, mask_w, rows, in_range, range_w, before, before_w, cells, cell_rows, cell_cols, scale, min_area, least, shares):
    """Whether some component of the 0/1 ``mask`` (8-connected on its ``scale``-times subsampled copy, as blobs._components
    labels it; ``rows`` as find_blobs reads them) passes every test of gather._kept_streaks but the shape's: a blob off the
    label grid's edges, over half its pixels out of ``in_range``, ``least`` at least, and with ``before`` (the faint pass's
    moving map; empty: none) at most ``shares[0]`` there or in range, ``shares[1]`` at least in ``cells`` marked 2. Only
    components with a pixel out of both are walked, found 8 at a time in the maps' words (gather.words). False: no need to label."""
    h, w = mask.shape
    hs, ws, faint = (h + scale - 1) // scale, (w + scale - 1) // scale, before.shape[0] > 0
    known_share, fresh_share = shares
    seen = np.zeros((hs, ws), np.uint8)
    stack_y, stack_x = np.empty(hs * ws, np.int32), np.empty(hs * ws, np.int32)
    for cy in range(hs):
        y, y_end = scale * cy, min(scale * cy + scale, h)
        if rows.shape[0] and not rows[y]:
            continue
        if w % 8 == 0 and not _any_seed(mask_w, range_w, before_w, y, y_end, faint):
            continue  # (most rows: a third of the time its word by word look took)
        for x_from in range(0, w, 8):  # most runs of 8 pixels hold none out of both: skipped (a short last one is read)
            k, word = x_from // 8, np.uint64(1) if x_from + 8 > w else np.uint64(0)
            for yy in range(y, y_end):
                if x_from + 8 <= w:
                    word |= mask_w[yy, k] & ~range_w[yy, k] & (~before_w[yy, k] if faint else ~np.uint64(0))
            if not word:
                continue
            for x in range(x_from, min(x_from + 8, w)):
                cx, seed = x // scale, False
                for yy in range(y, y_end):
                    seed |= mask[yy, x] > 0 and not in_range[yy, x] and not (faint and before[yy, x] > 0)
                if not seed or not mask[y, scale * cx] or seen[cy, cx]:
                    continue
                seen[cy, cx], stack_y[0], stack_x[0], top = 1, cy, cx, 1
                cells_in = count = paler = known = fresh = 0
                bx0, by0, bx1, by1 = ws, hs, 0, 0
                while top:
                    top -= 1
                    ky, kx = stack_y[top], stack_x[top]
                    cells_in += 1
                    bx0, by0, bx1, by1 = min(bx0, kx), min(by0, ky), max(bx1, kx + 1), max(by1, ky + 1)
                    for yy in range(scale * ky, min(scale * ky + scale, h)):
                        for xx in range(scale * kx, min(scale * kx + scale, w)):
                            if mask[yy, xx]:
                                out = not in_range[yy, xx]
                                count, paler = count + 1, paler + out
                                if faint:
                                    known += (not out) or before[yy, xx] > 0
                                    fresh += cells.shape[0] > 0 and cells[cell_rows[yy], cell_cols[xx]] == 2
                    for ny in range(max(ky - 1, 0), min(ky + 2, hs)):
                        for nx in range(max(kx - 1, 0), min(kx + 2, ws)):
                            if (not rows.shape[0] or rows[scale * ny]) and mask[scale * ny, scale * nx] and not seen[ny, nx]:
                                seen[ny, nx] = 1
                                stack_y[top], stack_x[top], top = ny, nx, top + 1
                if cells_in * scale * scale < min_area or bx0 == 0 or by0 == 0 or bx1 >= ws or by1 >= hs:
                    continue  # a speck, or at the edge
                fresh_enough = not cells.shape[0] or fresh >= fresh_share * count
                if paler / max(count, 1) > 0.5 and paler >= least and (not faint or (known <= known_share * count and fresh_enough)):
                    return True
    return False


@kernel(inline="always")
def _any_seed(mask_w, range_w, before_w, y, y_end, faint):
    """Does any word of rows y .. y_end - 1 hold a pixel of the mask out of the range (and, ``faint``, out of
    ``before``)? One loop without branches over the rows' words, which the compiler vectorises."""
    found = np.uint64(0)
    for yy in range(y, y_end):
        if faint:
            for k in range(mask_w.shape[1]):
                found |= mask_w[yy, k] & ~range_w[yy, k] & ~before_w[yy, k]
        else:
            for k in range(mask_w.shape[1]):
                found |= mask_w[yy, k] & ~range_w[yy, k]
    return found != 0


@kernel(inline="always")
def _runs(index, n):
    """Per cell 0..n-1, the run [from, to) of positions whose (rising) ``index`` is that cell (empty: to <= from)."""
    start = np.full(n, index.shape[0], np.int64)
    stop = np.zeros(n, np.int64)
    for i in range(index.shape[0]):
        c = index[i]
        start[c] = min(start[c], i)
        stop[c] = max(stop[c], i + 1)
    return start, stop
