"""The evidence stage's compiled map kernels (kernels.py) against OpenCV and numpy; the blob kernels: test_blob_kernels.py."""

import cv2
import numpy as np

from stereotrack.evidence import kernels as evidence_kernels


def _scene(rng, h=121, w=163):
    """A smooth random colour image (odd sizes: the nearest-neighbour maps must not assume even ones)."""
    bgr = cv2.GaussianBlur(rng.integers(0, 256, (h, w, 3), dtype=np.uint8), (0, 0), 3)
    bgr = cv2.normalize(bgr, None, 0, 255, cv2.NORM_MINMAX)
    return cv2.cvtColor(bgr, cv2.COLOR_BGR2HSV)


def test_the_one_pass_evidence_maps_are_what_opencv_gives_step_by_step():
    from scene_helpers import default_rig

    from stereotrack.evidence.colour_model import H_BINS, HUE_STEP, S_BINS, SAT_STEP, ColourModel
    from stereotrack.evidence.gather import CameraEvidence

    rng = np.random.default_rng(11)
    hsv = _scene(rng)
    in_range = (cv2.inRange(hsv, (0, 60, 0), (120, 255, 255)) > 0).astype(np.uint8)
    assert 0.2 < in_range.mean() < 0.9
    model = ColourModel(rng.random((H_BINS, S_BINS)).astype(np.float32), rng.random((H_BINS, S_BINS)).astype(np.float32))
    table = model.table(hsv)
    assert HUE_STEP * H_BINS == 180 and SAT_STEP * S_BINS == 256
    foreground = (rng.random((60, 81)) < 0.4).astype(np.uint8)  # the background model's half-size grid
    camera = default_rig().cameras[0]
    ev = CameraEvidence.from_mask(camera, in_range, foreground=foreground, colour_table=table, hsv=hsv, blob_method="components")

    probability = model.probability(hsv)  # OpenCV's back-projection of the same table
    soft = cv2.bitwise_and(probability, probability, mask=in_range)
    assert np.array_equal(ev.soft_integral, cv2.integral(soft, sdepth=cv2.CV_32S))
    assert np.array_equal(ev.mask, (soft > 127).astype(np.uint8))
    assert np.array_equal(ev.integral, cv2.integral(ev.mask, sdepth=cv2.CV_32S))
    moving = cv2.bitwise_and(in_range, cv2.resize(foreground, (163, 121), interpolation=cv2.INTER_NEAREST))
    assert 0 < moving.sum() < in_range.sum()
    assert np.array_equal(ev.moving, moving)
    assert np.array_equal(ev.moving_integral, cv2.integral(moving, sdepth=cv2.CV_32S))

    plain = CameraEvidence.from_mask(camera, in_range, foreground=foreground)  # no colour model: the range is the mask
    assert np.array_equal(plain.mask, in_range) and plain.soft_integral is None
    assert np.array_equal(plain.integral, cv2.integral(in_range, sdepth=cv2.CV_32S))


def test_a_moving_map_of_its_own_range_reads_it_from_the_hsv_where_something_moves_as_target_mask_does():
    """A white ball's motion range and a fast ball's streak range (wrapping around red too) are read pixel by pixel
    where the foreground is set: the moving map is what OpenCV's mask of that range AND the foreground give."""
    from scene_helpers import default_rig

    from stereotrack.config import Target
    from stereotrack.evidence.colour import motion_range, target_mask
    from stereotrack.evidence.gather import CameraEvidence

    rng = np.random.default_rng(13)
    hsv = _scene(rng)
    hsv[..., 0] = (hsv[..., 0].astype(int) * 179 // 255).astype(np.uint8)  # hues over the whole circle
    foreground = (rng.random((60, 81)) < 0.4).astype(np.uint8)
    moves = cv2.resize(foreground, (163, 121), interpolation=cv2.INTER_NEAREST)
    camera = default_rig().cameras[0]
    white = Target("white", (0, 0, 120), (179, 90, 230))
    for own in (motion_range(white), Target("red", (160, 60, 40), (25, 255, 255)), Target("teal", (70, 50, 50), (100, 200, 255))):
        wanted = cv2.bitwise_and(target_mask(hsv, own), moves)
        assert 0 < wanted.sum() < moves.sum()
        in_range = np.zeros_like(wanted)  # nothing in the typed range: only the own range moves
        ev = CameraEvidence.from_mask(camera, in_range, foreground=foreground, hsv=hsv, motion_range=own)
        assert np.array_equal(ev.moving, wanted), own


def test_the_colour_histograms_are_what_calchist_counts_on_the_subsampled_grid():
    from stereotrack.evidence.colour_model import H_BINS, LEARN_STEP, S_BINS

    rng = np.random.default_rng(12)
    hsv = _scene(rng)
    in_range = (rng.random(hsv.shape[:2]) < 0.5).astype(np.uint8)
    small = np.ascontiguousarray(hsv[::LEARN_STEP, ::LEARN_STEP])
    discs = np.zeros(small.shape[:2], np.uint8)
    cv2.circle(discs, (20, 15), 9, 255, -1)
    none = np.zeros((0, 0), np.uint8)
    ring = np.zeros(small.shape[:2], np.uint8)
    cv2.circle(ring, (20, 15), 14, 255, -1)
    cv2.circle(ring, (20, 15), 10, 0, -1)
    ball, rest, moved, around = evidence_kernels.hs_histograms(hsv, LEARN_STEP, in_range, discs, none, none, ring)
    ranges = [0, 180, 0, 256]
    on_ball = cv2.bitwise_and(discs, np.ascontiguousarray(in_range[::LEARN_STEP, ::LEARN_STEP]))
    assert ball.sum() > 50
    assert np.array_equal(ball, cv2.calcHist([small], [0, 1], on_ball, [H_BINS, S_BINS], ranges))
    in_ring = cv2.bitwise_and(ring, np.ascontiguousarray(in_range[::LEARN_STEP, ::LEARN_STEP]))
    assert around.sum() > 50
    assert np.array_equal(around, cv2.calcHist([small], [0, 1], in_ring, [H_BINS, S_BINS], ranges))  # HOLDER's ring
    assert np.array_equal(rest, cv2.calcHist([small], [0, 1], cv2.bitwise_not(discs), [H_BINS, S_BINS], ranges))
    assert not moved.any()  # no foreground: no moving pixel
    _, everything, _, nothing = evidence_kernels.hs_histograms(hsv, LEARN_STEP, in_range, none, none, none, none)
    assert np.array_equal(everything, cv2.calcHist([small], [0, 1], None, [H_BINS, S_BINS], ranges))
    assert not nothing.any()  # no ring: nothing around


def test_the_moving_colours_histogram_is_what_calchist_counts_on_the_foreground_read_at_the_grid():
    """The third histogram: the subsampled pixels whose foreground cell (nearest, on a grid the image's size divides)
    is set and that are off the ``off_ball`` discs: what ColourModel.learn counted with a strided copy and calcHist."""
    from stereotrack.evidence.colour_model import H_BINS, LEARN_STEP, S_BINS

    rng = np.random.default_rng(14)
    hsv = _scene(rng)
    h, w = hsv.shape[:2]
    fh, fw = h // 2, w // 2  # the background's grid (an odd last row and column left out)
    in_range = (rng.random((h, w)) < 0.5).astype(np.uint8)
    small = np.ascontiguousarray(hsv[::LEARN_STEP, ::LEARN_STEP])
    foreground = (rng.random((fh, fw)) < 0.3).astype(np.uint8)
    off_ball = np.zeros(small.shape[:2], np.uint8)
    cv2.circle(off_ball, (12, 9), 6, 255, -1)
    rows = np.minimum(np.arange(0, h, LEARN_STEP) * fh // h, fh - 1)
    cols = np.minimum(np.arange(0, w, LEARN_STEP) * fw // w, fw - 1)
    for off in (off_ball, np.zeros((0, 0), np.uint8)):
        sampled = foreground[np.ix_(rows, cols)]
        if off.shape[0]:
            sampled = sampled & (off == 0)
        expected = cv2.calcHist([small], [0, 1], sampled.astype(np.uint8), [H_BINS, S_BINS], [0, 180, 0, 256])
        _, _, moved, _ = evidence_kernels.hs_histograms(
            hsv, LEARN_STEP, in_range, np.zeros((0, 0), np.uint8), foreground, off, np.zeros((0, 0), np.uint8)
        )
        assert moved.sum() > 100
        assert np.array_equal(moved, expected)


def test_the_background_step_is_what_opencv_gives_step_by_step():
    rng = np.random.default_rng(13)
    first = rng.integers(0, 256, (120, 160, 3), dtype=np.uint8)
    image = np.clip(first.astype(int) + rng.integers(-40, 41, first.shape), 0, 255).astype(np.uint8)
    background = cv2.resize(first, (80, 60), interpolation=cv2.INTER_AREA).astype(np.float32)
    learn = (rng.random((60, 80)) < 0.7).astype(np.uint8)
    small = cv2.resize(image, (80, 60), interpolation=cv2.INTER_AREA)
    change = cv2.transform(cv2.absdiff(small, cv2.convertScaleAbs(background)), np.ones((1, 3), np.float32))
    expected_moving = (change > 30).astype(np.uint8)
    expected = background.copy()
    cv2.accumulateWeighted(small, expected, 0.05, mask=learn * 255)
    moving = np.empty((60, 80), np.uint8)
    previous = cv2.resize(first, (80, 60), interpolation=cv2.INTER_AREA)
    calm = np.full((60, 80), 4, np.uint8)
    was = background.copy()
    behind = np.empty((60, 80, 3), np.uint8)
    calm_moving = evidence_kernels.background_step(
        small, background, previous, calm, learn, np.ones(3, np.float32), 0.05, 30.0, moving, behind, 5, 12.0, np.zeros((0, 0), np.uint8)
    )
    assert np.array_equal(behind, cv2.convertScaleAbs(was))  # the background as it was, rounded as OpenCV rounds
    assert calm_moving == 0  # a moving cell changed from the frame before: none is calm
    assert np.array_equal(previous, small)  # the frame, kept for the next one
    assert np.array_equal(calm, np.where(change > 30, 0, 5))  # frames in a row each cell has not changed
    assert 0.1 < expected_moving.mean() < 0.9
    assert np.array_equal(moving, expected_moving)
    assert np.allclose(background, expected, atol=1e-4)
    assert not np.allclose(background[learn == 1], cv2.resize(first, (80, 60), interpolation=cv2.INTER_AREA)[learn == 1])

    # a frame under a gain, against the model's arithmetic spelled out in float32 numpy (bit for bit)
    gain = np.array([1.1, 0.93, 1.0], np.float32)
    blocks = np.minimum((small.astype(np.float32) * gain + np.float32(0.5)).astype(np.int32), 255)
    before, cells, counts = previous.astype(np.int32), background.copy(), calm.copy()
    change = np.abs(blocks - (cells + np.float32(0.5)).astype(np.int32)).sum(axis=2)
    steady = np.abs(blocks - before).sum(axis=2) <= 30
    learnt = np.where(learn[..., None] > 0, cells + np.float32(0.05) * (blocks.astype(np.float32) - cells), cells)
    calm_moving = evidence_kernels.background_step(
        small, background, previous, calm, learn, gain, 0.05, 30.0, moving, behind, 1, 12.0, np.zeros((0, 0), np.uint8)
    )
    assert np.array_equal(behind, cv2.convertScaleAbs(cells)) and np.array_equal(previous, blocks.astype(np.uint8))
    assert np.array_equal(moving, (change > 30).astype(np.uint8)) and np.array_equal(background, learnt)
    assert np.array_equal(calm, np.where(steady, np.minimum(counts.astype(int) + 1, 255), 0))
    assert calm_moving == np.count_nonzero((change > 30) & steady)


def test_the_background_steps_faint_marks_and_calm_counts_are_numpys():
    """The per-cell part of the background step against numpy: the faint map (1 where the change from the background
    exceeds the faint threshold, 2 where the change from the frame before does too), the calm counts (capped at 255,
    0 where the cell stepped), and the moving cells calm for absorb_frames or more."""
    rng = np.random.default_rng(17)
    shape = (50, 70)
    previous = rng.integers(0, 256, (*shape, 3), dtype=np.uint8)
    small = np.clip(previous.astype(int) + rng.integers(-12, 13, previous.shape), 0, 255).astype(np.uint8)
    background = np.clip(previous.astype(np.float32) + rng.normal(0, 12, previous.shape).astype(np.float32), 0, 255)
    calm = rng.choice(np.array([0, 3, 4, 5, 6, 254, 255], np.uint8), shape)
    before, cells, counts = previous.astype(np.int32), background.copy(), calm.copy()
    change = np.abs(small.astype(np.int32) - (cells + np.float32(0.5)).astype(np.int32)).sum(axis=2)
    stepped = np.abs(small.astype(np.int32) - before).sum(axis=2)
    moving, behind, faint = np.empty(shape, np.uint8), np.empty((*shape, 3), np.uint8), np.empty(shape, np.uint8)
    learn = np.ones(shape, np.uint8)
    calm_moving = evidence_kernels.background_step(
        small, background, previous, calm, learn, np.ones(3, np.float32), 0.05, 30.0, moving, behind, 5, 12.0, faint
    )
    assert np.array_equal(moving, (change > 30).astype(np.uint8))
    assert np.array_equal(faint, np.where(change > 12, np.where(stepped > 12, 2, 1), 0))
    assert {0, 1, 2} <= set(np.unique(faint).tolist())
    want_calm = np.where(stepped <= 30, np.minimum(counts.astype(int) + 1, 255), 0)
    assert np.array_equal(calm, want_calm) and (want_calm == 255).any() and (want_calm == 0).any()
    assert calm_moving == np.count_nonzero((change > 30) & (want_calm >= 5)) > 0


def test_where_the_background_held_the_ball_a_wall_of_its_hue_does_not_move():
    """A ghost: the background holds a ball (p near 1) where a wall of its hue (p near 0.5) is now. The wall
    differs from the background, but it is less the ball's colour than what it replaced: it is not moving
    evidence. A ball that comes in front of the wall is."""
    from scene_helpers import default_rig

    from stereotrack.evidence.colour_model import H_BINS, HUE_STEP, S_BINS, SAT_STEP
    from stereotrack.evidence.gather import CameraEvidence

    camera = default_rig().cameras[0]
    wall, ball = (60, 120, 200), (60, 230, 200)
    table = np.zeros((H_BINS, S_BINS), np.uint8)
    table[60 // HUE_STEP, 120 // SAT_STEP], table[60 // HUE_STEP, 230 // SAT_STEP] = 130, 250
    hsv = np.zeros((480, 640, 3), np.uint8)
    hsv[:] = wall
    cv2.circle(hsv, (400, 240), 15, ball, -1)  # the ball now; it was at (200, 240)
    behind = np.zeros((240, 320, 3), np.uint8)
    behind[:] = wall
    cv2.circle(behind, (100, 120), 8, ball, -1)
    foreground = np.zeros((240, 320), np.uint8)
    cv2.circle(foreground, (100, 120), 8, 1, -1)
    cv2.circle(foreground, (200, 120), 8, 1, -1)
    in_range = np.ones((480, 640), np.uint8)
    background = cv2.cvtColor(behind, cv2.COLOR_HSV2BGR)  # (its colours' bins survive the round trip)
    ev = CameraEvidence.from_mask(camera, in_range, foreground=foreground, colour_table=table, hsv=hsv, background=background)
    assert ev.moving[240, 400] == 1 and ev.moving[235:246, 395:406].all()  # the ball moved in
    assert ev.moving[230:251, 190:211].sum() == 0  # its old place: the wall, no ghost
    plain = CameraEvidence.from_mask(camera, in_range, foreground=foreground, colour_table=table, hsv=hsv)
    assert plain.moving[235:246, 195:206].all()  # without the background's colours, the ghost moves


def test_a_hand_of_the_range_moving_before_a_wall_out_of_it_is_no_moving_evidence():
    """A moving pixel in range but less likely the ball's than the room's, of a colour of things of the room that
    move (``things``: a skin-coloured hand), moves only where it replaced a colour of the range: a hand before a
    wall of the range's hue still moves, one before a wall out of the range does not. A colour less likely the
    ball's but of no moving thing (a prop of the ball's colour, hue_wall and static_props: the ball itself) moves
    before any wall; without ``things`` (a white ball) every one does."""
    from scene_helpers import default_rig

    from stereotrack.evidence.colour_model import H_BINS, HUE_STEP, S_BINS, SAT_STEP
    from stereotrack.evidence.gather import CameraEvidence

    camera = default_rig().cameras[0]
    wall, own_wall, skin, ball = (100, 60, 150), (17, 120, 200), (8, 110, 120), (20, 200, 200)
    table = np.zeros((H_BINS, S_BINS), np.uint8)  # the wall out of the range: 0
    table[17 // HUE_STEP, 120 // SAT_STEP], table[8 // HUE_STEP, 110 // SAT_STEP] = 30, 40  # in range, both the room's
    table[20 // HUE_STEP, 200 // SAT_STEP] = 60  # the ball's colour, a prop's too
    things = np.zeros((H_BINS, S_BINS), np.uint8)
    things[8 // HUE_STEP, 110 // SAT_STEP] = 1  # skin moves in the room
    hsv = np.zeros((480, 640, 3), np.uint8)
    hsv[:] = wall
    hsv[:, 320:] = own_wall
    cv2.circle(hsv, (200, 240), 15, skin, -1)  # the hand, before the wall
    cv2.circle(hsv, (450, 240), 15, skin, -1)  # and before a wall of the range's hue
    cv2.circle(hsv, (100, 120), 15, ball, -1)  # the ball, before the wall
    behind = np.zeros((240, 320, 3), np.uint8)
    behind[:] = wall
    behind[:, 160:] = own_wall
    foreground = np.zeros((240, 320), np.uint8)
    for u, v in ((100, 120), (225, 120), (50, 60)):
        cv2.circle(foreground, (u, v), 8, 1, -1)
    in_range = np.zeros((480, 640), np.uint8)
    in_range[:, 320:] = 1
    cv2.circle(in_range, (200, 240), 15, 1, -1)
    cv2.circle(in_range, (100, 120), 15, 1, -1)
    background = cv2.cvtColor(behind, cv2.COLOR_HSV2BGR)  # (its colours' bins survive the round trip)
    for known, before_wall in ((things, 0), (None, 1)):
        ev = CameraEvidence.from_mask(
            camera, in_range, foreground=foreground, colour_table=table, hsv=hsv, background=background, things=known
        )
        assert (ev.moving[235:246, 195:206] == before_wall).all()
        assert ev.moving[235:246, 445:456].all()  # p 40 >= 30: it replaced a colour of the range
        assert ev.moving[115:126, 95:106].all()  # the ball's colour is no moving thing's


def _numpy_gain(image, background, step=8, scale=2):
    """The lighting's gain as motion.py measured it before the compiled pass: np.median per channel."""
    then = background[::step, ::step]
    rows, cols = then.shape[:2]
    now = image[: scale * step * rows : scale * step, : scale * step * cols : scale * step].reshape(-1, 3).astype(np.float32)
    then = then.reshape(-1, 3)
    ok = (now > 20) & (now < 250) & (then > 20)
    gain = np.ones(3, np.float32)
    for c in range(3):
        if ok[:, c].sum() > 100:
            gain[c] = np.median(then[ok[:, c], c] / now[ok[:, c], c])
    gain[np.abs(gain - 1.0) < 0.005] = 1.0
    return gain


def test_the_frame_gain_is_numpys_median_of_the_ratios():
    rng = np.random.default_rng(14)
    for h, w, dim in ((480, 640, 0.8), (121, 163, 1.002), (720, 1280, 1.3), (241, 321, 0.97)):
        background = rng.uniform(40, 190, (h // 2, w // 2, 3)).astype(np.float32)
        image = np.clip(cv2.resize(background, (w, h), interpolation=cv2.INTER_NEAREST) / dim + rng.normal(0, 2, (h, w, 3)) + 0.5, 0, 255)
        image = image.astype(np.uint8)
        gain = evidence_kernels.frame_gain(image, background, 8, 2)
        assert gain.dtype == np.float32 and np.array_equal(gain, _numpy_gain(image, background))
        assert np.allclose(gain, dim, atol=0.05)
    background = rng.uniform(21, 240, (60, 80, 3)).astype(np.float32)
    same = cv2.resize(np.rint(background * 1.003).astype(np.uint8), (160, 120), interpolation=cv2.INTER_NEAREST)
    assert np.array_equal(evidence_kernels.frame_gain(same, background, 8, 2), np.ones(3, np.float32))  # within 0.005 of 1: 1
    for trial in range(20):  # odd and even counts of samples (an even count's median is a mean of two)
        background = rng.uniform(10, 250, (60 + trial, 80, 3)).astype(np.float32)
        image = rng.integers(0, 256, (120 + 2 * trial, 160, 3), dtype=np.uint8)
        assert np.array_equal(evidence_kernels.frame_gain(image, background, 4, 2), _numpy_gain(image, background, 4))
    dark = np.full((120, 160, 3), 10, np.uint8)  # too few cells to measure: no gain
    assert np.array_equal(evidence_kernels.frame_gain(dark, np.full((60, 80, 3), 100, np.float32), 8, 2), np.ones(3, np.float32))


def test_still_patches_are_absorbed_as_labelling_every_patch_gives():
    """The flood fill from calm cells against cv2.connectedComponents' patches: a patch with a cell that changed
    lately stays, a still one is learnt where ``learn`` is set."""
    rng = np.random.default_rng(15)
    for trial in range(20):
        moving = (cv2.GaussianBlur(rng.random((60, 80)), (0, 0), 2) > 0.55).astype(np.uint8)
        calm = np.where(rng.random((60, 80)) < 0.3, 0, 9).astype(np.uint8)
        if trial % 2 == 0:
            calm[:, 40:] = 9  # the right half's patches are still (unless they reach into the left half)
        learn = (rng.random((60, 80)) < 0.9).astype(np.uint8)
        background = rng.uniform(0, 255, (60, 80, 3)).astype(np.float32)
        previous = rng.integers(0, 256, (60, 80, 3), dtype=np.uint8)
        n, labels = cv2.connectedComponents(moving, connectivity=8)
        changing = np.zeros(n, bool)
        changing[0] = True
        changing[labels[(moving > 0) & (calm < 5)]] = True
        still = ~changing[labels] & (learn > 0)
        want_background, want_moving = background.copy(), moving.copy()
        want_background[still] = previous[still]
        want_moving[still] = 0
        evidence_kernels.absorb_still_patches(moving, calm, learn, background, previous, 5)
        assert np.array_equal(moving, want_moving) and np.array_equal(background, want_background)
        assert trial % 2 or still.any()


def test_the_evidence_pass_counts_the_moving_pixels_out_of_the_range():
    """What the streak check needs to know before it labels anything (gather._streaks_only runs only when some are)."""
    from stereotrack.config import Target
    from stereotrack.evidence.colour import range_bounds, streak_range, target_mask
    from stereotrack.evidence.gather import _NO_HSV, _NO_TABLE, _nearest, words

    rng = np.random.default_rng(17)
    hsv = _scene(rng)
    target = Target("teal", (70, 90, 90), (100, 255, 255))
    in_range = target_mask(hsv, target)
    foreground = (rng.random((60, 81)) < 0.4).astype(np.uint8)
    moving = np.zeros_like(in_range)
    rows = np.ones(121, np.uint8)
    pale = evidence_kernels.evidence_maps(
        in_range, rows, hsv, _NO_TABLE, foreground, _nearest(60, 121), _nearest(81, 163), range_bounds(streak_range(target)),
        _NO_TABLE, _NO_TABLE, moving, _NO_HSV, _NO_TABLE, words(in_range),
    )  # fmt: skip
    out_of_range = cv2.countNonZero(cv2.subtract(moving, in_range))
    assert 0 < out_of_range < cv2.countNonZero(moving)
    assert pale == out_of_range


def test_the_picked_and_halved_frames_are_opencvs_nearest_pick_and_area_halving():
    """kernels.picked_and_halved: every scale-th pixel (gather.every_nth, OpenCV's INTER_NEAREST by a whole factor) and
    that image halved (motion.halved, OpenCV's INTER_AREA: rounded half up), odd sizes' last row and column left out."""
    from stereotrack.evidence.gather import every_nth, every_nth_and_halved
    from stereotrack.evidence.motion import halved

    rng = np.random.default_rng(18)
    for (h, w), scale in (((720, 1280), 2), ((722, 1282), 2), ((726, 1286), 2), ((121, 163), 2), ((90, 120), 3)):
        image = rng.integers(0, 256, (h, w, 3), dtype=np.uint8)
        small, half = evidence_kernels.picked_and_halved(image, scale)
        assert np.array_equal(small, every_nth(image, scale)), (h, w)
        assert np.array_equal(half, halved(every_nth(image, scale))), (h, w)
    odd_view = image[:, ::-1]  # not contiguous: OpenCV's two passes
    small, half = every_nth_and_halved(odd_view, 2)
    assert np.array_equal(small, every_nth(odd_view, 2)) and np.array_equal(half, halved(small))


def test_a_frame_on_the_evidence_grid_is_halved_as_opencvs_area_halving():
    """kernels.halved_frame (every_nth_and_halved at scale 1: frames under 1280 wide) against motion.halved (OpenCV's
    INTER_AREA), odd sizes' last row and column left out; the frame itself is the evidence grid's, not a copy."""
    from stereotrack.evidence.gather import every_nth_and_halved
    from stereotrack.evidence.motion import halved

    rng = np.random.default_rng(19)
    for h, w in ((480, 640), (481, 643), (3, 5), (2, 2)):
        image = rng.integers(0, 256, (h, w, 3), dtype=np.uint8)
        assert np.array_equal(evidence_kernels.halved_frame(image), halved(image)), (h, w)
        small, half = every_nth_and_halved(image, 1)
        assert small is image and np.array_equal(half, halved(image))


def test_the_range_mask_is_target_masks_inrange_and_threshold():
    """kernels.range_mask (colour.camera_masks' masks) against colour.target_mask (OpenCV's inRange, OR-ed twice where
    the hue wraps, and a threshold): hues past 179 too, which a wrapping range's upper half leaves out."""
    from stereotrack.config import Target
    from stereotrack.evidence.colour import range_bounds, target_mask

    rng = np.random.default_rng(11)
    for shape in ((121, 163, 3), (2, 5, 3)):
        hsv = rng.integers(0, 256, shape, dtype=np.uint8)
        for lo, hi in (
            ((154, 103, 48), (174, 255, 255)),
            ((170, 60, 40), (10, 250, 220)),
            ((0, 0, 0), (179, 255, 255)),
            ((90, 0, 200), (90, 30, 255)),
        ):
            target = Target("t", lo, hi, 0.03)
            mask = evidence_kernels.range_mask(hsv, range_bounds(target))
            assert mask.dtype == np.uint8 and np.array_equal(mask, target_mask(hsv, target)), (lo, hi)


def test_the_colour_table_is_numpys_float32_ratio():
    """kernels.colour_table (ColourModel.table) against its numpy formula on float32 histograms: ratios at every
    rounding, empty bins (0 / 1e-12), a background weighed more or less than the ball."""
    from stereotrack.evidence.colour_model import H_BINS, S_BINS

    rng = np.random.default_rng(12)
    for odds in (1.0, 0.25, 7.3, 1.0 + 4.0 * (1.0 - 0.95**17)):
        for _ in range(20):
            ball = (rng.random((H_BINS, S_BINS)) ** 4).astype(np.float32)
            background = (rng.random((H_BINS, S_BINS)) ** 4).astype(np.float32)
            ball[rng.random(ball.shape) < 0.3], background[rng.random(ball.shape) < 0.3] = 0, 0
            ball, background = ball / ball.sum(), background / background.sum()
            expected = np.clip(np.rint(255.0 * (ball / np.maximum(ball + odds * background, 1e-12))), 0, 255).astype(np.uint8)
            assert np.array_equal(evidence_kernels.colour_table(ball, background, odds), expected), odds


def test_the_backgrounds_hue_and_saturation_are_opencvs_on_every_colour():
    """kernels._hue_sat (evidence_maps reads the background's colour where something moves, not a converted copy of
    it) against cv2.cvtColor's 8-bit BGR -> HSV on all 2^24 colours."""
    from numba import njit

    @njit
    def hue_sat(image):
        out = np.empty((image.shape[0], image.shape[1], 2), np.uint8)
        for y in range(image.shape[0]):
            for x in range(image.shape[1]):
                hue, sat = evidence_kernels._hue_sat(image[y, x, 0], image[y, x, 1], image[y, x, 2])
                out[y, x, 0], out[y, x, 1] = hue, sat
        return out

    colours = np.arange(1 << 24, dtype=np.uint32)
    image = np.stack([colours & 255, (colours >> 8) & 255, colours >> 16], axis=-1).astype(np.uint8).reshape(4096, 4096, 3)
    assert np.array_equal(hue_sat(image), cv2.cvtColor(image, cv2.COLOR_BGR2HSV)[..., :2])
