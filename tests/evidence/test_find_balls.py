"""The ball finder of `colour learn --auto` on drawn sequences: a moving pink ball, a static ball-sized pink
disc, a skin-coloured arm that moves, the ghost the ball leaves where it started, flickering light."""

import cv2
import numpy as np
import pytest

from stereotrack.camera import Camera, intrinsics_from_fov
from stereotrack.evidence.find_balls import BallFinder, _hue_runs, propose

W, H = 320, 240
BALL, DISC, SKIN = (166, 220, 220), (165, 215, 210), (12, 120, 200)
CAMERA = Camera("cam0", (W, H), intrinsics_from_fov(W, H, 60.0), np.zeros(5), np.eye(3), np.zeros(3))


def frames(n=30, moving=True, flicker=False, seed=0):
    """BGR frames and the ball's centre per frame."""
    rng = np.random.default_rng(seed)
    base = np.zeros((H, W, 3), np.uint8)
    base[:] = (0, 0, 110)
    base[:, 200:] = (100, 40, 150)  # a pale blue wall
    cv2.circle(base, (260, 60), 9, DISC, -1)  # a static pink disc of a ball's size
    cv2.circle(base, (40, 80), 11, (60, 200, 160), -1)  # a green patch the ball hides at first: its ghost is round and green
    out, centres = [], []
    for i in range(n):
        hsv = base.copy()
        arm_x = 20 + 4 * i
        cv2.rectangle(hsv, (arm_x, 170), (arm_x + 90, 190), SKIN, -1)  # an arm: long and thin
        c = (40 + 7 * i, 80 + 2 * i) if moving else (120, 100)
        cv2.circle(hsv, c, 9, BALL, -1)
        bgr = cv2.cvtColor(hsv, cv2.COLOR_HSV2BGR).astype(np.float32)
        if flicker:
            bgr *= 1.0 + 0.25 * np.sin(i * 1.3)
        bgr += rng.normal(0, 3, bgr.shape)
        out.append(np.clip(bgr, 0, 255).astype(np.uint8))
        centres.append(c)
    return out, np.array(centres, float)


def found(images):
    finder = BallFinder([CAMERA])
    for i, im in enumerate(images):
        finder.look(i, [im])
    return finder


@pytest.mark.parametrize("flicker", [False, True], ids=["steady", "flickering light"])
def test_the_moving_ball_is_found_and_nothing_else(flicker):
    images, centres = frames(flicker=flicker)
    groups = found(images).groups()
    assert len(groups) == 1
    g = groups[0]
    assert abs(g.hue - 166) <= 3 and len(g.frames) >= 15
    for d in g.detections:
        assert np.hypot(*(d.centre - centres[d.frame])) < 3 and 6 < d.radius_px < 12
    t = g.target("pink", 0.035)
    assert t.hsv_min[0] <= 166 <= t.hsv_max[0] and not t.hsv_min[0] <= 12 <= t.hsv_max[0]  # not the arm's hue


def test_a_ball_that_never_moves_is_no_proposal():
    images, _ = frames(moving=False)
    finder = found(images)
    assert finder.groups() == []
    proposals, looked = propose(lambda only: ((i, [images[i]]) for i in only), len(images), [CAMERA], False)
    assert proposals == [] and looked == len(images)


def test_propose_learns_the_target_and_its_separation():
    images, _ = frames(n=24)
    proposals, _ = propose(lambda only: ((i, [images[i]]) for i in only), len(images), [CAMERA], False, name="ball")
    assert [p.name for p in proposals] == ["ball"] and proposals[0].radius is None  # one camera: no radius
    learnt = proposals[0].learnt
    assert learnt.target.radius == 0.035 and learnt.ball_coverage > 0.9
    # The static pink disc is in the range; the colour model counts it less than the ball, not nothing.
    assert learnt.held_out is not None and 0.0 < learnt.held_out < 1.0


def test_hues_split_at_gaps_and_join_a_drifting_ball():
    runs = _hue_runs(np.array([40, 42, 45, 47, 50, 53, 10, 12, 165, 170, 174, 178, 1]))  # one run wraps past 179
    assert sorted(sorted(r & {1, 10, 12, 40, 53, 165, 178}) for r in runs) == [[1, 165, 178], [10, 12], [40, 53]]
