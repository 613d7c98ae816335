"""Compiled loops of the evidence stage: connected-component boxes and blob moments (``blobs.py``).

See ``stereotrack/kernels.py`` for how kernels are compiled, cached and warmed up.
"""

from __future__ import annotations

import numpy as np

from ..kernels import kernel

# A colour model's bins (colour_model.py): this many hue and saturation steps each. Constants here, so the
# compiled code divides by shifts, not by a division per pixel.
HUE_STEP, SAT_STEP = 4, 8


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
def picked_and_halved(image, scale):
    """Every ``scale``-th pixel of a BGR image in each direction (gather.every_nth: pixel j is the image's pixel
    scale j) and that image on the background's grid (motion.halved: each 2 x 2 block's mean, rounded half up, as
    OpenCV's INTER_AREA halves uint8; an odd last row or column left out), in one pass over the image: each halved
    row is made from the two picked rows just written. A frame 1280 wide costs a third less than OpenCV's
    nearest-neighbour pick and then its area halving (the tracker's evidence grid, pipeline/tracker.py)."""
    h, w = image.shape[0] // scale, image.shape[1] // scale
    small = np.empty((h, w, 3), np.uint8)
    hh, hw = h // 2, w // 2
    half = np.empty((hh, hw, 3), np.uint8)
    for y in range(h):
        src, row = image[scale * y], small[y]
        for x in range(w):
            row[x, 0] = src[scale * x, 0]
            row[x, 1] = src[scale * x, 1]
            row[x, 2] = src[scale * x, 2]
        if y % 2 == 1 and y // 2 < hh:
            above, out = small[y - 1], half[y // 2]
            for x in range(hw):
                for c in range(3):
                    total = (
                        np.int32(above[2 * x, c]) + np.int32(above[2 * x + 1, c]) + np.int32(row[2 * x, c]) + np.int32(row[2 * x + 1, c])
                    )
                    out[x, c] = np.uint8((total + 2) >> 2)
    return small, half


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
def evidence_maps(in_range, rows_in_range, hsv, table, foreground, fg_rows, fg_cols, motion_range, soft, mask, moving, behind, things):
    """The maps a target's range mask (0/1) in one camera gives, written into zeroed arrays, pixels out of
    range left 0:

    - with a colour ``table`` (p(ball | colour) x 255 per hue-saturation bin; empty: no colour model) the
      ``soft`` map, p inside the range, and ``mask`` = soft > 127 (what OpenCV's back-projection, a masked
      AND and a threshold give, in one pass that reads only pixels in range);
    - with a ``foreground`` map (empty: no motion; pixel (x, y) reads foreground[fg_rows[y], fg_cols[x]],
      nearest-neighbour from the background's smaller grid) the ``moving`` map, range AND foreground; with a
      ``motion_range`` (HSV bounds h0, s0, v0, h1, s1, v1 and 1 where the hue wraps around red, as
      colour.target_mask reads a range; empty: the range) the pixels of ``hsv`` in it instead of the range, read
      only where the foreground is set (a whole-image mask of it cost more than the rest of this pass); with the table and the background
      in HSV (``behind``, on the foreground's grid; empty: none), a pixel in range moves only where it is at
      least as likely the ball's colour as what the background held there (where a ball was and a wall of its
      hue is now, the wall moved in no sense); with ``things`` too (per bin as the table, 1: a colour of a thing
      of the room, a hand's; empty: none), a pixel of such a colour out of the mask (p <= 127) moves only where
      what it replaced was of the table's colours (p above 0: a ball before a wall of its hue), not where it came
      before a colour out of them (a skin-coloured hand before a wall).
    Rows ``rows_in_range`` marks 0 are passed over: the caller marks the rows with a pixel in range and, with a
    motion range, those with a foreground cell (most rows hold neither: the range is a few balls).
    Returns how many moving pixels are out of the range (with a motion range: its paler pixels)."""
    h, w = in_range.shape
    pale = 0
    use_table = table.shape[0] > 0
    use_fg = foreground.shape[0] > 0
    use_behind = use_table and use_fg and behind.shape[0] > 0
    own_motion_range = motion_range.shape[0] > 0
    use_things = use_behind and things.shape[0] > 0
    for y in range(h):
        if not rows_in_range[y]:
            continue
        fy = fg_rows[y] if use_fg else 0
        for x in range(w):
            inside = in_range[y, x]
            p = 0
            if inside and use_table:
                p = table[hsv[y, x, 0] // HUE_STEP, hsv[y, x, 1] // SAT_STEP]
                soft[y, x] = p
                mask[y, x] = 1 if p > 127 else 0
            if use_fg and (own_motion_range or inside):
                fx = fg_cols[x]
                moves = foreground[fy, fx] != 0
                if moves and own_motion_range:
                    moves = _in_bounds(hsv[y, x, 0], hsv[y, x, 1], hsv[y, x, 2], motion_range)
                if moves and use_behind and inside:
                    was = table[behind[fy, fx, 0] // HUE_STEP, behind[fy, fx, 1] // SAT_STEP]
                    thing = use_things and things[hsv[y, x, 0] // HUE_STEP, hsv[y, x, 1] // SAT_STEP] != 0
                    moves = p >= was and (p > 127 or was > 0 or not thing)
                moving[y, x] = 1 if moves else 0
                if moves and not inside:
                    pale += 1
    return pale


@kernel(inline="always")
def _in_bounds(h, s, v, bounds):
    """Is the HSV pixel (h, s, v) inside ``bounds`` (h0, s0, v0, h1, s1, v1, wraps)? cv2.inRange's test, the hue
    either side of red when the range wraps (colour.target_mask)."""
    if s < bounds[1] or s > bounds[4] or v < bounds[2] or v > bounds[5]:
        return False
    if bounds[6]:
        return h >= bounds[0] or h <= bounds[3]
    return h >= bounds[0] and h <= bounds[3]


@kernel
def hs_histograms(hsv, step, in_range, discs, foreground, off_ball):
    """Hue-saturation histograms (counts, float32) of every ``step``-th pixel in each direction: the pixels
    inside ``discs`` (a mask on that subsampled grid; empty: none) that are in range (the ball's colours), the
    pixels outside the discs (the background's), and, with a ``foreground`` (0/1 on any grid the image's size
    divides, read as colour_model.ColourModel.learn reads it: row y * fh // h, column x * fw // w; empty: none,
    the third histogram is all zeros), the pixels that move outside ``off_ball`` (a mask on the subsampled grid;
    empty: none). What cv2.calcHist gives on the subsampled copies, in one pass: the moving pixels' histogram
    was a strided copy of the HSV, a fancy-indexed copy of the foreground and calcHist (a third of learning)."""
    h, w = hsv.shape[0], hsv.shape[1]
    ball = np.zeros((180 // HUE_STEP, 256 // SAT_STEP), np.float32)
    rest = np.zeros((180 // HUE_STEP, 256 // SAT_STEP), np.float32)
    moved = np.zeros((180 // HUE_STEP, 256 // SAT_STEP), np.float32)
    use_discs = discs.shape[0] > 0
    use_fg = foreground.shape[0] > 0
    use_off = off_ball.shape[0] > 0
    fh, fw = foreground.shape[0], foreground.shape[1]
    for j in range(0, (h + step - 1) // step):
        y = j * step
        fy = min(y * fh // h, fh - 1)
        for i in range(0, (w + step - 1) // step):
            x = i * step
            hb = hsv[y, x, 0] // HUE_STEP
            sb = hsv[y, x, 1] // SAT_STEP
            if use_discs and discs[j, i]:
                if in_range[y, x]:
                    ball[hb, sb] += 1.0
            else:
                rest[hb, sb] += 1.0
            if use_fg and foreground[fy, min(x * fw // w, fw - 1)] and not (use_off and off_ball[j, i]):
                moved[hb, sb] += 1.0
    return ball, rest, moved


@kernel
def frame_gain(image, background, step, scale):
    """Per channel (float32 x 3), what ``image`` must be multiplied by to match ``background`` (its 1 / ``scale``
    grid, float32) where the room did not change: the median of background / image over every ``step``-th
    background cell in each direction (the image's pixel at scale x that cell's corner), among the cells neither
    dark (<= 20) nor saturated (>= 250), with more than 100 of them; 1 where it is within 0.005 of 1. What
    np.median gives on those samples (float32: an even count's median is the mean of its two middle values)."""
    rows = (background.shape[0] + step - 1) // step
    cols = (background.shape[1] + step - 1) // step
    ratios = np.empty(rows * cols, np.float32)
    gain = np.ones(3, np.float32)
    for c in range(3):
        n = 0
        for j in range(rows):
            for i in range(cols):
                now = np.float32(image[scale * step * j, scale * step * i, c])
                then = background[step * j, step * i, c]
                if now > 20 and now < 250 and then > 20:
                    ratios[n] = then / now
                    n += 1
        if n > 100:
            half = n // 2
            upper = np.partition(ratios[:n], half)  # the middle value in place, the larger ones after it
            low = upper[half]
            if n % 2 == 0:
                low = upper[0]
                for k in range(1, half):  # the largest of the lower half
                    low = max(low, upper[k])
            gain[c] = upper[half] if n % 2 else (low + upper[half]) / np.float32(2.0)
        if abs(gain[c] - np.float32(1.0)) < np.float32(0.005):
            gain[c] = np.float32(1.0)
    return gain


@kernel
def background_step(small, background, previous, calm, learn, gain, rate, threshold, moving, behind, absorb_frames, faint_threshold, faint):
    """One frame of the background model (motion.py), in one pass over the frame at the background's size
    (``small``, H x W x 3 uint8: cv2.resize's INTER_AREA average of each 2 x 2 block of the image): each cell
    scaled by the frame's ``gain`` per channel (the lighting's drift undone, rounded half up) is compared with its
    ``background`` cell (float32): ``moving`` = 1 where |dB| + |dG| + |dR| (against the background rounded to grey
    levels) exceeds ``threshold``. ``calm`` counts the frames in a row (at most 255) each cell has differed from
    the ``previous`` frame's (uint8, updated here) by at most ``threshold``. ``behind`` (uint8) gets the
    background as it was, rounded (what cv2.convertScaleAbs gives); ``faint`` (empty: none) = 1 where the change
    exceeds ``faint_threshold`` instead, 2 where the change from the ``previous`` frame does too (a fast ball's pale
    streak is mostly somewhere new each frame, a ghost never: gather.py). Then the cell learns, b += rate (cell - b),
    where ``learn`` is set. Returns how many moving cells have been calm for ``absorb_frames`` frames or more.
    Each row runs channel by channel over its 3 W values first (a loop the compiler vectorises: no branch in it;
    a gain of 1 and a learn factor of 0 or 1 give exactly what skipping them would), then cell by cell (no branch
    either: the marks and counts are products of 0/1 tests)."""
    h, w = background.shape[0], background.shape[1]
    n = 3 * w
    a = np.float32(rate)
    gains = np.empty(n, np.float32)
    for k in range(n):
        gains[k] = gain[k % 3]
    learning = np.empty(n, np.float32)
    change = np.empty(n, np.int32)
    step = np.empty(n, np.int32)
    calm_moving = 0
    use_faint = faint.shape[0] > 0
    no_marks = np.empty(0, np.uint8)
    for j in range(h):
        blocks, cells, before, was = small[j].reshape(n), background[j].reshape(n), previous[j].reshape(n), behind[j].reshape(n)
        for i in range(w):
            f = np.float32(1.0) if learn[j, i] else np.float32(0.0)
            learning[3 * i], learning[3 * i + 1], learning[3 * i + 2] = f, f, f
        for k in range(n):
            block = min(np.int32(np.float32(blocks[k]) * gains[k] + np.float32(0.5)), np.int32(255))
            cell = cells[k]
            change[k] = abs(block - np.int32(cell + np.float32(0.5)))  # the background is >= 0: + 0.5 rounds it
            step[k] = abs(block - np.int32(before[k]))
            before[k] = np.uint8(block)
            was[k] = np.uint8(min(np.rint(cell), np.float32(255.0)))  # rounded half to even, as OpenCV rounds
            cells[k] = cell + a * (np.float32(block) - cell) * learning[k]
        count, out = calm[j], moving[j]
        marks = faint[j] if use_faint else no_marks
        for i in range(w):  # no branch but the loop-invariant one: a third faster than choosing per cell
            total = change[3 * i] + change[3 * i + 1] + change[3 * i + 2]
            stepped = step[3 * i] + step[3 * i + 1] + step[3 * i + 2]
            moves = np.uint8(total > threshold)
            out[i] = moves
            if use_faint:  # 2 where it changed from the frame before too: a ghost (the wall where the background holds a ball) is calm
                marks[i] = np.uint8(total > faint_threshold) * (np.uint8(1) + np.uint8(stepped > faint_threshold))
            calm_now = np.uint8(min(np.int32(count[i]) + 1, 255)) * np.uint8(stepped <= threshold)
            count[i] = calm_now
            calm_moving += moves & np.uint8(calm_now >= absorb_frames)
    return calm_moving


@kernel
def absorb_still_patches(moving, calm, learn, background, previous, absorb_frames):
    """Learn at once the 8-connected patches of ``moving`` none of whose cells has changed for ``absorb_frames``
    frames (``calm``): where ``learn`` is set, the cell's ``background`` becomes the ``previous`` frame's and it
    stops moving. Only patches holding a calm cell are visited (a flood fill from each): what labelling every
    patch (cv2.connectedComponents) and keeping the still ones gives."""
    h, w = moving.shape
    seen = np.zeros((h, w), np.uint8)
    stack = np.empty((h * w, 2), np.int64)
    patch = np.empty((h * w, 2), np.int64)
    for y0 in range(h):
        for x0 in range(w):
            if not moving[y0, x0] or seen[y0, x0] or calm[y0, x0] < absorb_frames:
                continue
            seen[y0, x0] = 1
            stack[0, 0], stack[0, 1] = y0, x0
            top, size, still = 1, 0, True
            while top > 0:
                top -= 1
                y, x = stack[top, 0], stack[top, 1]
                patch[size, 0], patch[size, 1] = y, x
                size += 1
                if calm[y, x] < absorb_frames:
                    still = False
                for ny in range(max(y - 1, 0), min(y + 2, h)):
                    for nx in range(max(x - 1, 0), min(x + 2, w)):
                        if moving[ny, nx] and not seen[ny, nx]:
                            seen[ny, nx] = 1
                            stack[top, 0], stack[top, 1] = ny, nx
                            top += 1
            if still:
                for k in range(size):
                    y, x = patch[k, 0], patch[k, 1]
                    if learn[y, x]:
                        for c in range(3):
                            background[y, x, c] = np.float32(previous[y, x, c])
                        moving[y, x] = 0


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
def _runs(index, n):
    """Per cell 0..n-1, the run [from, to) of positions whose (rising) ``index`` is that cell (empty: to <= from)."""
    start = np.full(n, index.shape[0], np.int64)
    stop = np.zeros(n, np.int64)
    for i in range(index.shape[0]):
        c = index[i]
        start[c] = min(start[c], i)
        stop[c] = max(stop[c], i + 1)
    return start, stop
