"""Blobs that could be a ball: the right width for some depth in range, and compact (a box passes here: the
ball-shape likelihood judges its corners)."""

from __future__ import annotations

import cv2
import numpy as np

from stereotrack.evidence.blobs import ball_like, find_blobs, minor_skew, short_streaks

F, R = 554.0, 0.035  # focal length in pixels, ball radius in metres: 19 px wide at 1 m, 3.9 px at 5 m


def blob_of(draw) -> bool:
    m = np.zeros((480, 640), np.uint8)
    draw(m)
    b = find_blobs(m)
    assert len(b) == 1
    return bool(ball_like(b, F, R, 0.2, 5.0)[0])


def test_balls_pass():
    assert blob_of(lambda m: cv2.circle(m, (300, 200), 12, 1, -1))  # a ball at 1.6 m
    assert blob_of(lambda m: cv2.circle(m, (300, 200), 4, 1, -1))  # at 4.8 m
    assert blob_of(
        lambda m: cv2.ellipse(m, (300, 200), (12, 6), 0, 0, 360, 1, -1) * 0 + cv2.rectangle(m, (288, 194), (312, 200), 0, -1)
    )  # half hidden
    assert blob_of(lambda m: cv2.line(m, (200, 200), (300, 230), 1, 14))  # a streak: long, ball-wide (rounded ends drawn by the circle)


def test_a_ball_partly_in_range_passes():
    """A striped or half-lit ball whose in-range pixels are a crescent (as on the real ball videos) still seeds."""

    def crescent(m):
        cv2.circle(m, (300, 200), 30, 1, -1)
        cv2.circle(m, (300, 214), 30, 0, -1)  # the part out of range: fill of its ellipse about 0.53

    assert blob_of(crescent)


def test_walls_rings_and_specks_fail():
    assert not blob_of(lambda m: cv2.rectangle(m, (100, 50), (500, 450), 1, -1))  # a wall: wider than a ball at 0.2 m
    assert not blob_of(lambda m: cv2.circle(m, (300, 200), 30, 1, 3))  # a ring (a hoop, a plate's rim): hollow
    assert not blob_of(lambda m: cv2.rectangle(m, (300, 200), (302, 202), 1, -1))  # a speck: narrower than a ball at 5 m


def test_a_streak_is_as_wide_as_its_ball_and_a_ball_cut_by_the_edge_keeps_its_size():
    """The apparent radius that sets a blob's depth range and its ray crossings: a streak's is its half width (half its
    length would put a fast ball at half its depth); a ball cut in half by the image's edge keeps half its longer side."""
    m = np.zeros((480, 640), np.uint8)
    cv2.line(m, (200, 200), (320, 240), 1, 16)  # a ball of radius 8 px smeared over 126 px
    cv2.circle(m, (0, 400), 10, 1, -1)  # half a ball of radius 10 px at the left edge
    cv2.circle(m, (500, 100), 9, 1, -1)  # a whole ball
    b = find_blobs(m)
    order = np.argsort(b.centres[:, 0])
    edge, streak, ball = b.ball_radii()[order]
    assert 7.5 < streak < 10.0 and 9.5 <= edge <= 11.0 and 8.5 <= ball <= 10.0
    assert abs(abs(b.major[order[1]] @ np.array([120.0, 40.0]) / np.hypot(120, 40)) - 1) < 0.01  # along the streak


def test_two_balls_side_by_side_are_not_a_streak():
    """As long and as filled as a streak, but narrow at the middle: each ball's size, not a streak's width (a crossing
    of two rays through the pair's centroid would put a ghost between them)."""
    m = np.zeros((480, 640), np.uint8)
    cv2.circle(m, (300, 200), 12, 1, -1)
    cv2.circle(m, (323, 205), 12, 1, -1)
    b = find_blobs(m)
    assert len(b) == 1 and b.ball_radii()[0] > 20


def test_a_ball_merged_with_scenery_of_its_hue_still_seeds_where_its_colour_is_sure():
    """A ball held by an arm, or touching a prop or a wall of its hue: the mask (p > 0.5) makes one blob of both,
    which is no ball. Where p(ball | colour) is near 1 (the ball, not the arm at about 0.55) the ball is a blob
    of its own, and it seeds abductive particles."""
    from scene_helpers import default_rig

    from stereotrack.evidence.colour_model import H_BINS, HUE_STEP, S_BINS, SAT_STEP
    from stereotrack.evidence.gather import CameraEvidence

    camera = default_rig().cameras[0]
    hsv = np.zeros((480, 640, 3), np.uint8)
    cv2.rectangle(hsv, (150, 100), (330, 400), (100, 120, 200), -1)  # an arm of the ball's hue, a bit paler
    cv2.circle(hsv, (350, 250), 20, (100, 220, 200), -1)  # the ball, touching it
    table = np.zeros((H_BINS, S_BINS), np.uint8)
    table[100 // HUE_STEP, 120 // SAT_STEP] = 140  # p 0.55: in the mask
    table[100 // HUE_STEP, 220 // SAT_STEP] = 250
    in_range = (hsv[:, :, 1] > 0).astype(np.uint8)
    ev = CameraEvidence.from_mask(camera, in_range, ball=(R, 0.3, 5.0), colour_table=table, hsv=hsv)
    assert len(ev.blobs) == 1  # arm and ball: one blob, no ball
    seeds = ev.proposal_seeds()
    assert len(seeds) == 1 and np.linalg.norm(seeds.centres[0] - (350, 250)) < 2 and 15 < seeds.radii[0] < 25


def test_labelling_only_the_box_of_the_set_pixels_gives_the_whole_masks_labels():
    """Blobs are labelled inside the box of the mask's set pixels; their order (which later stages follow) must be
    that of labelling the whole mask, with one OpenCV thread or several."""
    rng = np.random.default_rng(8)
    threads = cv2.getNumThreads()
    try:
        for trial in range(40):
            cv2.setNumThreads(1 if trial % 2 else max(threads, 2))
            h, w = (480, 640) if trial % 3 else (121, 163)
            mask = np.zeros((h, w), np.uint8)
            y, x = rng.integers(0, h - 60), rng.integers(0, w - 80)
            mask[y : y + 60, x : x + 80] = cv2.GaussianBlur(rng.random((60, 80)), (0, 0), 1.5) > 0.55
            blobs = find_blobs(mask, min_area=1)
            n, labels = cv2.connectedComponents(np.ascontiguousarray(mask[::2, ::2]), connectivity=8, ltype=cv2.CV_32S)
            assert n > 3 and np.array_equal(blobs.labels, labels)
            assert len(blobs) == n - 1 and np.array_equal(blobs.label_blob, np.arange(-1, n - 1))
    finally:
        cv2.setNumThreads(threads)
    empty = find_blobs(np.zeros((48, 64), np.uint8))
    assert len(empty) == 0 and not empty.labels.any()


def test_seeds_say_which_blobs_move():
    """A blob of the colour mask that is a blob of the moving map too is flagged ``moved`` (the proposal gives the
    moving blobs their share of the particles), a still speck of the colour is not, nor a wall's."""
    from scene_helpers import default_rig

    from stereotrack.evidence.gather import CameraEvidence

    camera = default_rig().cameras[0]
    mask = np.zeros((480, 640), np.uint8)
    cv2.circle(mask, (200, 200), 12, 1, -1)  # a ball, moving
    cv2.circle(mask, (450, 300), 12, 1, -1)  # a ball-like patch of the wall's colour, still
    foreground = np.zeros((240, 320), np.uint8)  # motion.py's grid: half the image's
    cv2.circle(foreground, (100, 100), 6, 1, -1)
    ev = CameraEvidence.from_mask(camera, mask, ball=(R, 0.3, 5.0), foreground=foreground)
    seeds = ev.proposal_seeds()
    assert len(seeds) == 2 and seeds.moved is not None
    moving = np.linalg.norm(seeds.centres - (200, 200), axis=1) < 3
    assert moving.sum() == 1 and seeds.moved[moving].all() and not seeds.moved[~moving].any()


def test_a_streak_that_does_not_move_seeds_nothing():
    """A rod, a stripe on a wall, a disc's rim seen edge on, of the ball's colour: as wide as a ball and long, shaped
    like a fast ball's streak, but still. With motion it seeds no particles (static_props tune seed 38: a rod was
    tracked from the first frame to the last); the same streak moving does, and so does a still round ball (a ball at
    rest). Without motion (no background model) nothing says it is still, and it seeds as before."""
    from scene_helpers import default_rig

    from stereotrack.evidence.gather import CameraEvidence

    camera = default_rig().cameras[0]
    mask = np.zeros((480, 640), np.uint8)
    cv2.line(mask, (100, 100), (220, 130), 1, 14)  # a rod, still
    cv2.line(mask, (300, 300), (420, 330), 1, 14)  # a streak, moving
    cv2.circle(mask, (500, 150), 12, 1, -1)  # a ball at rest
    foreground = np.zeros((240, 320), np.uint8)  # motion.py's grid: half the image's
    cv2.line(foreground, (150, 150), (210, 165), 1, 8)
    still = np.zeros_like(foreground)

    def seeded(fg):
        seeds = CameraEvidence.from_mask(camera, mask, ball=(R, 0.3, 5.0), foreground=fg).proposal_seeds()
        return [bool((np.linalg.norm(seeds.centres - c, axis=1) < 4).any()) for c in ((160, 115), (360, 315), (500, 150))]

    assert seeded(foreground) == [False, True, True]
    assert seeded(still) == [False, False, True]  # the first frame, or a streak's still frame: nothing moves
    seeds = CameraEvidence.from_mask(camera, mask, ball=(R, 0.3, 5.0)).proposal_seeds()
    assert len(seeds) == 3  # no motion evidence: every ball-like blob


def test_a_streak_whose_edges_move_is_not_still():
    """A uniform thing changes only at its edges when it moves: an arm of the ball's hue moving a ball at its end is
    a streak-shaped blob with a rim of moving pixels, not a still rod (``still_streaks`` asks that under a tenth of a
    streak's pixels move). A rod with a speck of sensor noise on it is still."""
    from stereotrack.evidence.gather import still_streaks

    mask = np.zeros((480, 640), np.uint8)
    cv2.line(mask, (100, 100), (220, 130), 1, 14)  # the arm
    cv2.line(mask, (300, 300), (420, 330), 1, 14)  # the rod
    moving = np.zeros_like(mask)
    cv2.line(moving, (100, 100), (220, 130), 1, 14)
    cv2.line(moving, (104, 101), (216, 129), 0, 8)  # only its rim moves: about a third of its pixels
    moving[315, 360] = 1  # noise on the rod
    b = find_blobs(mask)
    order = np.argsort(b.centres[:, 0])
    assert b.swept.all()
    assert still_streaks(b, moving)[order].tolist() == [False, True]
    assert not still_streaks(b, None).any()  # no motion: nothing is known still


def test_a_small_ball_touching_a_bigger_one_is_not_a_streak():
    """Long and filled like a streak, no gap at its centroid (which lies inside the bigger ball), but narrow where
    the two touch: as wide all along is what a streak is (pendulum4: a far ball behind a near one)."""
    m = np.zeros((480, 640), np.uint8)
    cv2.circle(m, (300, 200), 9, 1, -1)
    cv2.circle(m, (321, 200), 12, 1, -1)
    streak = np.zeros_like(m)
    cv2.line(streak, (200, 300), (260, 300), 1, 12)  # a streak 12 px wide drawn the same way
    b, s = find_blobs(m), find_blobs(streak)
    assert len(b) == 1 and b.ball_radii()[0] > 20  # the pair's size, not a streak's width
    assert len(s) == 1 and s.ball_radii()[0] < 8


def test_a_half_disc_is_lopsided_across_its_axis_and_a_short_blur_is_not():
    """A ball cut straight by a prop in front of it and a ball blurred to 1.6-1.9 times its width along its path: both
    are short blurs to their shape alone (as long, as full, as even), but the half disc has a flat side and a curved one
    across its major axis, the blur a ball's round end on either side of its path."""
    m = np.zeros((480, 640), np.uint8)
    for x, r in ((100, 7), (250, 10), (420, 14)):
        cv2.circle(m, (x, 100), r, 1, -1)
        m[100 - r - 1 : 100 + r + 2, x - r - 1 : x] = 0  # its left half hidden
        for t in np.linspace(-0.4, 0.4, 17):  # the ball swept along a slant: a blur
            cv2.circle(m, (int(round(x + t * r)), int(round(300 + 0.75 * t * r))), r, 1, -1)
    b = find_blobs(m)
    halves, blurs = np.flatnonzero(b.centres[:, 1] < 200), np.flatnonzero(b.centres[:, 1] > 200)
    assert len(halves) == 3 and len(blurs) == 3
    assert short_streaks(b, m)[halves].all() and short_streaks(b, m)[blurs].all()  # alike to the short-blur rule
    assert (minor_skew(b, m, halves) > 0.15).all(), minor_skew(b, m, halves)
    assert (minor_skew(b, m, blurs) < 0.06).all(), minor_skew(b, m, blurs)


def test_a_ball_whose_colour_the_model_doubts_pixel_by_pixel_still_seeds_from_the_range_where_it_is_round():
    """Where the room holds much of the ball's colour, p(ball | colour) of the ball's own pixels sits near 0.5 and
    the mask keeps them here and there: a speckled disc that is no ball, and no pixel is surely the ball's. The
    range's blob is then a seed if it is round and the model leans to the ball over it as a whole; a speckled
    square (a piece of a wall between a shelf's uprights) or a disc the model leans against is not."""
    from scene_helpers import default_rig

    from stereotrack.evidence.colour_model import H_BINS, HUE_STEP, S_BINS, SAT_STEP
    from stereotrack.evidence.gather import CameraEvidence

    camera = default_rig().cameras[0]
    rng = np.random.default_rng(3)
    hsv = np.zeros((480, 640, 3), np.uint8)
    table = np.zeros((H_BINS, S_BINS), np.uint8)
    table[100 // HUE_STEP, 220 // SAT_STEP] = 250  # sure
    table[100 // HUE_STEP, 100 // SAT_STEP] = 110  # p 0.43: out of the mask

    def speckled(shape, kept_share):
        region = np.zeros((480, 640), np.uint8)
        shape(region)
        ys, xs = np.nonzero(region)
        sat = np.where(rng.random(len(ys)) < kept_share, 220, 100)
        hsv[ys, xs] = np.stack([np.full(len(ys), 100), sat, np.full(len(ys), 200)], axis=1)

    speckled(lambda m: cv2.circle(m, (350, 250), 20, 1, -1), 0.42)  # the ball: p 0.67 on average, 42 % of it in the mask
    speckled(lambda m: cv2.rectangle(m, (100, 100), (140, 140), 1, -1), 0.42)  # a square of the same colours
    speckled(lambda m: cv2.circle(m, (500, 380), 20, 1, -1), 0.2)  # a disc the model leans against: p 0.54
    in_range = (hsv[:, :, 1] > 0).astype(np.uint8)
    ev = CameraEvidence.from_mask(camera, in_range, ball=(R, 0.3, 5.0), colour_table=table, hsv=hsv)
    seeds = ev.proposal_seeds()
    assert len(seeds) == 1 and np.linalg.norm(seeds.centres[0] - (350, 250)) < 2 and 15 < seeds.radii[0] < 25
