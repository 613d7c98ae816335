"""Compiled loops of the evidence stage's maps: the picked frame, range and motion maps, colour histograms, background.

For ``gather.py``, ``colour_model.py`` and ``motion.py``; the blob finder's and the streak checks' loops are in
``blob_kernels.py``. See ``stereotrack/kernels.py`` for how
kernels are compiled, cached and warmed up.
"""

from __future__ import annotations

import numpy as np

from ..kernels import kernel

# A colour model's bins (colour_model.py): this many hue and saturation steps each. Constants here, so the
# compiled code divides by shifts, not by a division per pixel.
HUE_STEP, SAT_STEP = 4, 8


@kernel
def picked_and_halved(image, scale):
    """Every ``scale``-th pixel of a BGR image in each direction (gather.every_nth: pixel j is the image's pixel
    scale j) and that image on the background's grid (motion.halved: each 2 x 2 block's mean, rounded half up, as
    OpenCV's INTER_AREA halves uint8; an odd last row or column left out), in one pass over the image: each halved
    row is made from the two picked rows just written. A frame 1280 wide costs a third less than OpenCV's
    nearest-neighbour pick and then its area halving (the tracker's evidence grid, pipeline/tracker.py).
    Rows are read as flat bytes (pixel x's channel c at 3 x + c) with strides the compiler knows (scale 2, the
    default grid at 1280 wide, has its own loop), so it vectorises them: a strided pick per channel read 4x slower."""
    h, w = image.shape[0] // scale, image.shape[1] // scale
    small = np.empty((h, w, 3), np.uint8)
    hh, hw = h // 2, w // 2
    half = np.empty((hh, hw, 3), np.uint8)
    picked, halves, frame = small.reshape(h, 3 * w), half.reshape(hh, 3 * hw), image.reshape(image.shape[0], 3 * image.shape[1])
    for y in range(h):
        src, row = frame[scale * y], picked[y]
        if scale == 2:
            for x in range(w):
                row[3 * x], row[3 * x + 1], row[3 * x + 2] = src[6 * x], src[6 * x + 1], src[6 * x + 2]
        else:
            for x in range(w):
                row[3 * x], row[3 * x + 1], row[3 * x + 2] = src[3 * scale * x], src[3 * scale * x + 1], src[3 * scale * x + 2]
        if y % 2 == 1 and y // 2 < hh:
            _halved_row(picked[y - 1], row, halves[y // 2], hw)
    return small, half


@kernel
def halved_frame(image):
    """A BGR image (C-contiguous) on the background's grid, as picked_and_halved halves (motion.halved: OpenCV's
    INTER_AREA): for a frame on the evidence grid already (evidence_scale 1, frames under 1280 wide), in a quarter of
    cv2.resize's time on a 640 x 480 frame."""
    hh, hw = image.shape[0] // 2, image.shape[1] // 2
    half = np.empty((hh, hw, 3), np.uint8)
    halves, frame = half.reshape(hh, 3 * hw), image.reshape(image.shape[0], 3 * image.shape[1])
    for y in range(hh):
        _halved_row(frame[2 * y], frame[2 * y + 1], halves[y], hw)
    return half


@kernel(inline="always")
def _halved_row(a, b, out, hw):
    """Row ``out`` (flat BGR bytes, ``hw`` pixels) of the 2 x 2 means of rows ``a`` and ``b`` (flat BGR bytes)."""
    for x in range(hw):  # the channels spelled out: a loop over them is not vectorised
        out[3 * x] = _mean4(a[6 * x], a[6 * x + 3], b[6 * x], b[6 * x + 3])
        out[3 * x + 1] = _mean4(a[6 * x + 1], a[6 * x + 4], b[6 * x + 1], b[6 * x + 4])
        out[3 * x + 2] = _mean4(a[6 * x + 2], a[6 * x + 5], b[6 * x + 2], b[6 * x + 5])


@kernel(inline="always")
def _mean4(a, b, c, d):
    """The mean of four uint8 values rounded half up, as OpenCV's INTER_AREA halving gives it."""
    return np.uint8((np.uint16(a) + np.uint16(b) + np.uint16(c) + np.uint16(d) + np.uint16(2)) >> np.uint16(2))


@kernel
def range_mask(hsv, bounds):
    """The 0/1 mask (uint8) of the pixels of ``hsv`` (H x W x 3, C-contiguous) in ``bounds`` (h0, s0, v0, h1, s1, v1
    and 1 where the hue wraps, colour.range_bounds): what colour.target_mask gives (cv2.inRange, twice and OR-ed where
    the hue wraps, then a threshold to 0/1), in one pass without branches that the compiler vectorises: a ninth of
    their time on a 640 x 360 frame (the tracker's masks, colour.camera_masks)."""
    h, w = hsv.shape[0], hsv.shape[1]
    out = np.empty((h, w), np.uint8)
    pixels, flat = hsv.reshape(h * w * 3), out.reshape(h * w)
    h0, s0, v0, h1, s1, v1 = (
        np.uint8(bounds[0]),
        np.uint8(bounds[1]),
        np.uint8(bounds[2]),
        np.uint8(bounds[3]),
        np.uint8(bounds[4]),
        np.uint8(bounds[5]),
    )
    top = np.uint8(179)  # a wrapping range is [h0, 179] or [0, h1] (colour.target_mask)
    if bounds[6]:
        for i in range(h * w):
            hue, sat, val = pixels[3 * i], pixels[3 * i + 1], pixels[3 * i + 2]
            flat[i] = np.uint8((((hue >= h0) & (hue <= top)) | (hue <= h1)) & (sat >= s0) & (sat <= s1) & (val >= v0) & (val <= v1))
    else:
        for i in range(h * w):
            hue, sat, val = pixels[3 * i], pixels[3 * i + 1], pixels[3 * i + 2]
            flat[i] = np.uint8((hue >= h0) & (hue <= h1) & (sat >= s0) & (sat <= s1) & (val >= v0) & (val <= v1))
    return out


@kernel
def row_maxima(image, other, other_rows):
    """Per row of ``image`` (H x W) its largest value (``image.max(axis=1)``); with ``other`` (a map on a coarser grid;
    empty: none) the larger of that and the largest of the ``other`` row ``other_rows[y]`` that row y reads
    (``np.maximum(image.max(axis=1), other.max(axis=1)[other_rows])``): gather.py's rows that may hold a pixel of any map,
    in one pass the compiler vectorises (numpy's row reductions took several times as long)."""
    h, w = image.shape
    out = np.zeros(h, image.dtype)
    for y in range(h if w else 0):
        row = image[y]
        top = row[0]
        for x in range(1, w):
            top = max(top, row[x])
        out[y] = top
    if other.shape[0]:
        tops = np.zeros(other.shape[0], other.dtype)
        for y in range(other.shape[0] if other.shape[1] else 0):
            row = other[y]
            top = row[0]
            for x in range(1, other.shape[1]):
                top = max(top, row[x])
            tops[y] = top
        for y in range(h):
            out[y] = max(out[y], tops[other_rows[y]])
    return out


@kernel
def evidence_maps(
    in_range, rows_in_range, hsv, table, foreground, fg_rows, fg_cols, motion_range, soft, mask, moving, behind, things, range_words
):
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
      (``behind``, BGR on the foreground's grid, its hue and saturation read as OpenCV converts it, _hue_sat, at the
      cells read only: a whole-grid conversion cost more; empty: none), a pixel in range moves only where it is at
      least as likely the ball's colour as what the background held there (where a ball was and a wall of its
      hue is now, the wall moved in no sense); with ``things`` too (per bin as the table, 1: a colour of a thing
      of the room, a hand's; empty: none), a pixel of such a colour out of the mask (p <= 127) moves only where
      what it replaced was of the table's colours (p above 0: a ball before a wall of its hue), not where it came
      before a colour out of them (a skin-coloured hand before a wall).
    Rows ``rows_in_range`` marks 0 are passed over: the caller marks the rows with a pixel in range and, with a
    motion range, those with a foreground cell (most rows hold neither: the range is a few balls).
    ``range_words``: ``in_range``'s first pixels of each row 8 at a time (gather.words): a run of 8 with none in range, and
    (with a motion range) no foreground cell any of them reads, is passed over (most of a marked row is: their pixels
    are left 0, as the maps come). Returns how many moving pixels are out of the range (with a motion range: its paler
    pixels)."""
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
        for block in range((w + 7) // 8):
            x_from, x_to = 8 * block, min(8 * block + 8, w)
            if block < range_words.shape[1] and range_words[y, block] == 0:
                if not (use_fg and own_motion_range):
                    continue  # nothing in range: nothing to write
                cells = 0
                for fx in range(fg_cols[x_from], fg_cols[x_to - 1] + 1):  # (fg_cols rises: every cell these pixels read)
                    cells |= foreground[fy, fx]
                if not cells:
                    continue  # nothing in range, nothing moves
            for x in range(x_from, x_to):
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
                        hue, sat = _hue_sat(behind[fy, fx, 0], behind[fy, fx, 1], behind[fy, fx, 2])
                        was = table[hue // HUE_STEP, sat // SAT_STEP]
                        thing = use_things and things[hsv[y, x, 0] // HUE_STEP, hsv[y, x, 1] // SAT_STEP] != 0
                        moves = p >= was and (p > 127 or was > 0 or not thing)
                    moving[y, x] = 1 if moves else 0
                    if moves and not inside:
                        pale += 1
    return pale


@kernel(inline="always")
def _hue_sat(b, g, r):
    """Hue (0..179) and saturation of one BGR uint8 pixel exactly as cv2.cvtColor's 8-bit COLOR_BGR2HSV gives them
    (its integer formula: 12-bit fixed point, the divisions by V and by 6 x (V - min) rounded as its tables round them,
    here reproduced by float32 divisions: the same on all 2^24 colours, tests/evidence/test_kernels.py)."""
    b, g, r = np.int32(b), np.int32(g), np.int32(r)
    v = max(b, g, r)
    diff = v - min(b, g, r)
    v_is_r, v_is_g = -np.int32(v == r), -np.int32(v == g)  # all bits set where true
    sat = (diff * np.int32(np.rint(np.float32(255 << 12) / np.float32(max(v, 1)))) + np.int32(1 << 11)) >> 12
    hue = (v_is_r & (g - b)) + (~v_is_r & ((v_is_g & (b - r + 2 * diff)) + (~v_is_g & (r - g + 4 * diff))))
    hue = (hue * np.int32(np.rint(np.float32(180 << 12) / (np.float32(6.0) * np.float32(max(diff, 1))))) + np.int32(1 << 11)) >> 12
    return hue + (np.int32(180) if hue < 0 else np.int32(0)), sat


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
def colour_table(ball, background, odds):
    """p(ball | colour) x 255 per bin (uint8) from the ball's and the background's histograms (float32, normalised)
    and the ``odds`` the background's weighs: ball / max(ball + odds x background, 1e-12), x 255, rounded half to
    even and clipped, in float32 as numpy computes it on float32 arrays (a Python scalar becomes a float32): what
    colour_model.ColourModel.table's eight array calls gave, in one (a tenth of their time)."""
    out = np.empty(ball.shape, np.uint8)
    weight, least, top = np.float32(odds), np.float32(1e-12), np.float32(255.0)
    for i in range(ball.shape[0]):
        for j in range(ball.shape[1]):
            b = ball[i, j]
            ratio = b / max(b + weight * background[i, j], least)
            out[i, j] = np.uint8(min(max(np.rint(top * ratio), np.float32(0.0)), top))
    return out


@kernel
def hs_histograms(hsv, step, in_range, discs, foreground, off_ball, ring):
    """Hue-saturation histograms (counts, float32) of every ``step``-th pixel in each direction: the pixels
    inside ``discs`` (a mask on that subsampled grid; empty: none) that are in range (the ball's colours), the
    pixels outside the discs (the background's), and, with a ``foreground`` (0/1 on any grid the image's size
    divides, read as colour_model.ColourModel.learn reads it: row y * fh // h, column x * fw // w; empty: none,
    the third histogram is all zeros), the pixels that move outside ``off_ball`` (a mask on the subsampled grid;
    empty: none); the fourth, the pixels in range inside ``ring`` (a mask on the subsampled grid; empty: none, all
    zeros). What cv2.calcHist gives on the subsampled copies, in one pass: the moving pixels' histogram was a
    strided copy of the HSV, a fancy-indexed copy of the foreground and calcHist (a third of learning); the strided
    copy alone is 0.3 ms."""
    h, w = hsv.shape[0], hsv.shape[1]
    ball = np.zeros((180 // HUE_STEP, 256 // SAT_STEP), np.float32)
    rest = np.zeros((180 // HUE_STEP, 256 // SAT_STEP), np.float32)
    moved = np.zeros((180 // HUE_STEP, 256 // SAT_STEP), np.float32)
    around = np.zeros((180 // HUE_STEP, 256 // SAT_STEP), np.float32)
    use_discs = discs.shape[0] > 0
    use_ring = ring.shape[0] > 0
    use_fg = foreground.shape[0] > 0
    use_off = off_ball.shape[0] > 0
    fh, fw = foreground.shape[0], foreground.shape[1]
    cols = np.zeros((w + step - 1) // step, np.int64)  # the foreground's column each sampled column reads, made once:
    if use_fg:  # a division per sample was half of this pass
        for i in range(cols.shape[0]):
            cols[i] = min(i * step * fw // w, fw - 1)
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
            if use_fg and foreground[fy, cols[i]] and not (use_off and off_ball[j, i]):
                moved[hb, sb] += 1.0
            if use_ring and ring[j, i] and in_range[y, x]:
                around[hb, sb] += 1.0
    return ball, rest, moved, around


@kernel
def refuse_moving_things(on_ball, rest, moved, moving, background, spread, moved_share, wall_count, thing_share, refused):
    """colour_model.ColourModel.learn's SPREAD and ELSEWHERE tests on this frame's histograms (H_BINS x S_BINS float32),
    in one pass where its numpy version made a dozen temporaries: a colour bin moves where the room's ``moving`` share of
    it is over ``moved_share`` x its ``background`` share; the cores' colours (``on_ball``) of a moving thing (``spread``
    x the cores' count under the room's, ``rest``) are refused (set to 0 in ``on_ball``) where the room holds fewer than
    ``wall_count`` (WALL x the room's pixels, float32 as numpy gives it) of them, or its ``moving`` share is over
    ``thing_share`` x its ``background`` share (THING_MOVES: a wall's colour does not move so), and ``refused`` marks, where the cores
    showed a colour, whether it was refused as a hand's: more of it moved off the discs (``moved``) than lies on the cores,
    and more than of the cores' main colour (the first largest of the cores' counts outside the moving things'). Every
    product and comparison in float32, as numpy computes them on float32 arrays with Python scalars."""
    h, w = on_ball.shape
    spread32, share32, thing32 = np.float32(spread), np.float32(moved_share), np.float32(thing_share)
    best, bi, bj, own_any = np.float32(0.0), 0, 0, False
    for i in range(h):  # the cores' main colour: argmax of the counts with the moving things' set to 0 (first in C order)
        for j in range(w):
            moves = moving[i, j] > share32 * background[i, j]
            own = np.float32(0.0) if (spread32 * on_ball[i, j] < rest[i, j]) and moves else on_ball[i, j]
            if own != 0:
                own_any = True
            if own > best or (i == 0 and j == 0):
                best, bi, bj = own, i, j
    main = moved[bi, bj]
    for i in range(h):
        for j in range(w):
            moves = moving[i, j] > share32 * background[i, j]
            wall = rest[i, j] >= wall_count and not moving[i, j] > thing32 * background[i, j]
            refuse = (spread32 * on_ball[i, j] < rest[i, j]) and moves and not wall
            if on_ball[i, j] > 0:
                refused[i, j] = refuse and moved[i, j] > on_ball[i, j] and (not own_any or moved[i, j] > main)
            if refuse:
                on_ball[i, j] = 0


@kernel
def blended(old, hist, total, rate):
    """``(1 - rate) x old + rate x hist / total`` (float32 arrays, ``total`` and ``rate`` Python floats): the colour
    model's running averages of a normalised histogram, in float32 as numpy computes them (each scalar made float32)."""
    out = np.empty(old.shape, np.float32)
    keep, take, divisor = np.float32(1 - rate), np.float32(rate), np.float32(total)
    for i in range(old.shape[0]):
        for j in range(old.shape[1]):
            out[i, j] = keep * old[i, j] + take * (hist[i, j] / divisor)
    return out


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


@kernel
def straight_runs(edges, direction, steps, length):
    """motion._straight's runs: the pixels of ``edges`` (uint8, h x w) whose gradient ``direction`` (float32
    radians, 0 .. 2 pi) falls in half-windows 0 .. steps - 1 (steps even). Window k holds half-windows k and k + 1
    (mod steps): the even windows part the circle, and so do the odd ones, so each set is labelled in one raster
    pass (union-find with the 8-neighbours already seen, in the same window). True where a pixel's run in either
    window has a box whose diagonal is ``length`` or more."""
    h, w = edges.shape
    n = h * w
    flat, angle = edges.ravel(), direction.ravel()
    count = 0
    for i in range(n):
        count += flat[i] != 0
    edge = np.empty(count, np.int64)
    half = np.empty(count, np.int32)
    scale = steps / (2 * np.pi)
    count = 0
    for i in range(n):
        if flat[i] != 0:
            edge[count] = i
            half[count] = int(angle[i] * scale) % steps
            count += 1
    out = np.zeros(n, np.bool_)
    parent = np.empty(n, np.int32)
    key = np.full(n, -1, np.int32)
    x0, y0, x1, y1 = np.empty(n, np.int32), np.empty(n, np.int32), np.empty(n, np.int32), np.empty(n, np.int32)
    for odd in range(2):
        for t in range(count):  # raster order: the neighbours left and above are labelled already
            i = edge[t]
            k = ((half[t] + steps - odd) % steps) >> 1
            key[i], parent[i] = k, i
            x = i % w
            if x > 0 and key[i - 1] == k:
                _union(parent, i, i - 1)
            if i >= w:
                j = i - w
                if x > 0 and key[j - 1] == k:
                    _union(parent, i, j - 1)
                if key[j] == k:
                    _union(parent, i, j)
                if x + 1 < w and key[j + 1] == k:
                    _union(parent, i, j + 1)
        for t in range(count):  # a run's root is its first pixel, met before the rest of it
            i = edge[t]
            r = _root(parent, i)
            parent[i] = r
            y, x = i // w, i % w
            if r == i:
                x0[r], y0[r], x1[r], y1[r] = x, y, x, y
            else:
                x0[r], y0[r], x1[r], y1[r] = min(x0[r], x), min(y0[r], y), max(x1[r], x), max(y1[r], y)
        for t in range(count):
            i = edge[t]
            r = parent[i]
            if (x1[r] - x0[r] + 1) ** 2 + (y1[r] - y0[r] + 1) ** 2 >= length * length:
                out[i] = True
            key[i] = -1
    return out.reshape(h, w)


@kernel(inline="always")
def _root(parent, i):
    """Union-find's root of i, halving the path as it goes."""
    while parent[i] != i:
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


@kernel(inline="always")
def _union(parent, i, j):
    """Joins the sets of i and j under the smaller root (raster order: a set's root is its first pixel)."""
    a, b = _root(parent, i), _root(parent, j)
    if a < b:
        parent[b] = a
    elif b < a:
        parent[a] = b


@kernel
def rim_shares(gx, gy, centres, radii, scales, directions, least, tan):
    """outlines.round_rims' count per circle (``centres`` K x 2 and ``radii`` K, pixels of the gradient's box): at each
    of ``scales`` x its radius and each of ``directions`` (A x 2 unit), whether some channel's gradient (``gx``, ``gy``:
    H x W x C, Sobel / 8) at the nearest pixel is ``least`` or more radially and its tangential part at most ``tan`` of
    that; a circle counts the circles either side of it; the share of directions at the best circle. A sample off the
    box counts as no edge."""
    k_n, s_n, a_n, c_n = centres.shape[0], scales.shape[0], directions.shape[0], gx.shape[2]
    h, w = gx.shape[0], gx.shape[1]
    out = np.zeros(k_n)
    edge = np.zeros((s_n, a_n), np.bool_)
    for k in range(k_n):
        for s in range(s_n):
            r = max(scales[s] * radii[k], 1.5)
            for a in range(a_n):
                cos, sin = directions[a, 0], directions[a, 1]
                x, y = int(np.rint(centres[k, 0] + r * cos)), int(np.rint(centres[k, 1] + r * sin))
                hit = False
                if 0 <= x < w and 0 <= y < h:
                    for c in range(c_n):
                        radial = abs(gx[y, x, c] * cos + gy[y, x, c] * sin)
                        if radial >= least and abs(gy[y, x, c] * cos - gx[y, x, c] * sin) <= tan * radial:
                            hit = True
                            break
                edge[s, a] = hit
        best = 0
        for s in range(s_n):
            count = 0
            for a in range(a_n):
                if edge[s, a] or (s > 0 and edge[s - 1, a]) or (s + 1 < s_n and edge[s + 1, a]):
                    count += 1
            best = max(best, count)
        out[k] = best / a_n
    return out
