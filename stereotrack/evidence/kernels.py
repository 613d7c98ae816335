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
def evidence_maps(
    in_range, rows_in_range, hsv, table, foreground, fg_rows, fg_cols, motion_range, soft, mask, moving, sure, sure_level, behind
):
    """The maps a target's range mask (0/1) in one camera gives, written into zeroed arrays, pixels out of
    range left 0:

    - with a colour ``table`` (p(ball | colour) x 255 per hue-saturation bin; empty: no colour model) the
      ``soft`` map, p inside the range, and ``mask`` = soft > 127 (what OpenCV's back-projection, a masked
      AND and a threshold give, in one pass that reads only pixels in range), and (``sure`` not empty)
      ``sure`` = soft > ``sure_level``;
    - with a ``foreground`` map (empty: no motion; pixel (x, y) reads foreground[fg_rows[y], fg_cols[x]],
      nearest-neighbour from the background's smaller grid) the ``moving`` map, range AND foreground; with a
      ``motion_range`` (0/1; empty: the range) that map instead of the range; with the table and the background
      in HSV (``behind``, on the foreground's grid; empty: none), a pixel in range moves only where it is at
      least as likely the ball's colour as what the background held there (where a ball was and a wall of its
      hue is now, the wall moved in no sense).
    Rows with no pixel in either (``rows_in_range`` 0; most rows: the range is a few balls) are passed over."""
    h, w = in_range.shape
    use_table = table.shape[0] > 0
    use_fg = foreground.shape[0] > 0
    use_sure = sure.shape[0] > 0
    use_behind = use_table and use_fg and behind.shape[0] > 0
    own_motion_range = motion_range.shape[0] > 0
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
                if use_sure:
                    sure[y, x] = 1 if p > sure_level else 0
            if use_fg and (motion_range[y, x] if own_motion_range else inside):
                fx = fg_cols[x]
                moves = foreground[fy, fx] != 0
                if moves and use_behind and inside:
                    moves = p >= table[behind[fy, fx, 0] // HUE_STEP, behind[fy, fx, 1] // SAT_STEP]
                moving[y, x] = 1 if moves else 0


@kernel
def hs_histograms(hsv, step, in_range, discs):
    """Hue-saturation histograms (counts, float32) of every ``step``-th pixel in each direction: the pixels
    inside ``discs`` (a mask on that subsampled grid; empty: none) that are in range (the ball's colours), and
    the pixels outside the discs (the background's). What cv2.calcHist gives on the subsampled copies."""
    h, w = hsv.shape[0], hsv.shape[1]
    ball = np.zeros((180 // HUE_STEP, 256 // SAT_STEP), np.float32)
    rest = np.zeros((180 // HUE_STEP, 256 // SAT_STEP), np.float32)
    use_discs = discs.shape[0] > 0
    for j in range(0, (h + step - 1) // step):
        y = j * step
        for i in range(0, (w + step - 1) // step):
            x = i * step
            hb = hsv[y, x, 0] // HUE_STEP
            sb = hsv[y, x, 1] // SAT_STEP
            if use_discs and discs[j, i]:
                if in_range[y, x]:
                    ball[hb, sb] += 1.0
            else:
                rest[hb, sb] += 1.0
    return ball, rest


@kernel
def background_step(image, background, previous, calm, learn, gain, rate, threshold, moving):
    """One frame of the background model (motion.py), in one pass over the image: each 2 x 2 block of
    ``image`` (H x W x 3 uint8) averaged (as cv2.resize's INTER_AREA halves an image) and scaled by the frame's
    ``gain`` per channel (the lighting's drift undone) is compared with its ``background`` cell (H/2 x W/2 x 3
    float32): ``moving`` = 1 where |dB| + |dG| + |dR| (against the background rounded to grey levels) exceeds
    ``threshold``. ``calm`` counts the frames in a row (at most 255) each block has differed from the
    ``previous`` frame's (uint8, updated here) by at most ``threshold``. Then the cell learns the block,
    b += rate (block - b), where ``learn`` is set."""
    h, w = background.shape[0], background.shape[1]
    a = np.float32(rate)
    for j in range(h):
        top, bottom = image[2 * j], image[2 * j + 1]
        cells, before, count, learning, out = background[j], previous[j], calm[j], learn[j], moving[j]
        for i in range(w):
            change = np.int32(0)
            step = np.int32(0)
            for c in range(3):
                block = (
                    np.int32(top[2 * i, c]) + np.int32(top[2 * i + 1, c]) + np.int32(bottom[2 * i, c]) + np.int32(bottom[2 * i + 1, c]) + 2
                ) >> 2
                if gain[c] != 1.0:
                    block = min(np.int32(np.float32(block) * gain[c] + np.float32(0.5)), np.int32(255))
                change += abs(block - np.int32(cells[i, c] + np.float32(0.5)))  # the background is >= 0: + 0.5 rounds it
                step += abs(block - np.int32(before[i, c]))
                before[i, c] = block
                if learning[i]:
                    cells[i, c] += a * (np.float32(block) - cells[i, c])
            out[i] = 1 if change > threshold else 0
            count[i] = min(count[i] + 1, 255) if step <= threshold else 0
