"""A ball's outline (round_rims) and a ball at rest that one view buries in its own colour, found by it."""

from dataclasses import replace

import numpy as np
import pytest
from scene_helpers import RADIUS, default_rig, lit_ball

from stereotrack.config import Config, Target
from stereotrack.evidence.colour import target_mask, to_hsv
from stereotrack.evidence.outlines import OUTLINE_MIN_PX, buried_partners, held_discs, per_camera, round_rim, round_rims
from stereotrack.frames import FramePair
from stereotrack.pipeline.tracker import Tracker

WALL_Y = 3.0  # metres ahead of the rig
PINK_BGR = np.array([180, 105, 255], np.uint8)
PINK = Target("pink", (158, 80, 80), (178, 255, 255), RADIUS)  # the range a user would type for the pink drawn here
WALL_GREY = 160  # a pale grey wall: the ball's limb is darker, its lit side lighter
WHITE_BGR = np.array([235, 235, 235], np.uint8)
WHITE = Target("white", (0, 0, 170), (179, 50, 255), RADIUS)  # a white ball's range: every hue
BALL = np.array([0.05, 1.2, 0.0])


def _rays(cam):
    v, u = np.mgrid[0 : cam.height, 0 : cam.width]
    return cam.rays(np.column_stack([u.ravel() + 0.5, v.ravel() + 0.5]))


def _wall_x(cam, point) -> float:
    """Where the ray from ``cam`` through ``point`` meets the wall (its x)."""
    o, d = (a[0] for a in cam.rays(cam.view(np.asarray(point, float)[None])[0]))
    return float(o[0] + (WALL_Y - o[1]) / d[1] * d[0])


def _scene(rig, ball=BALL, buried: int = 1, noise: int = 0, seed: int = 0, white: bool = False):
    """Each camera's image of a grey wall at WALL_Y with a pink panel on it that lies behind the ball (lit from above and in
    front: shaded) in camera ``buried`` only, ray-traced pixel by pixel; with ``noise``, a sensor's (seeded); ``white``: a
    white panel and a white ball."""
    rng = np.random.default_rng(seed)
    behind = [_wall_x(cam, ball) for cam in rig.cameras]
    edge = 0.5 * (behind[0] + behind[1])  # the panel starts between the two points behind the ball, towards the buried one
    towards = np.sign(behind[buried] - edge)
    images = []
    for cam in rig.cameras:
        o, d = _rays(cam)
        hit = o + ((WALL_Y - o[:, 1]) / d[:, 1])[:, None] * d
        image = np.tile(np.array([WALL_GREY] * 3 if white else [128, 128, 128], np.uint8), (len(d), 1))
        image[(hit[:, 0] - edge) * towards > 0] = WHITE_BGR if white else PINK_BGR
        if white and cam is rig.cameras[buried]:  # a dark leg beside the ball: its shading's patch joins it there
            reach = RADIUS * WALL_Y / np.linalg.norm(ball - cam.centre)  # the ball's radius as seen on the wall
            image[np.abs(hit[:, 0] - behind[buried] - 1.4 * reach) < 0.5 * reach] = (60, 60, 60)
        on, lit = lit_ball(o, d, ball)
        if white:
            image[on] = (WHITE_BGR * (0.55 + 0.45 * lit)[:, None]).astype(np.uint8)
        else:
            image[on] = (PINK_BGR * (0.3 + 0.55 * lit)[:, None]).astype(np.uint8)  # never as bright as the panel
        image = image.reshape(cam.height, cam.width, 3)
        if noise:
            image = np.clip(image + rng.normal(0, noise, image.shape), 0, 255).astype(np.uint8)
        images.append(image)
    return images


def _seen(cam, point):
    uv, _, z = cam.view(np.asarray(point, float)[None])
    return uv[0], float(cam.apparent_radius(RADIUS, z[0]))


def test_round_rims_are_round_rim_of_each_circle():
    """The circles share one gradient box, and each scores as it does alone (on the image and off it, colour and grey)."""
    rng = np.random.default_rng(0)
    for k in range(200):
        h, w = rng.integers(20, 120, 2)
        image = rng.integers(0, 256, (h // 4 + 1, w // 4 + 1) + ((3,) if k % 2 else ())).astype(np.uint8)
        image = np.ascontiguousarray(np.repeat(np.repeat(image, 4, 0), 4, 1)[:h, :w])
        centres, radii = rng.uniform(-15, max(h, w) + 15, (5, 2)), rng.uniform(0.5, 25, 5)
        assert round_rims(image, centres, radii).tolist() == [round_rim(image, c, r) for c, r in zip(centres, radii)]


def test_a_ball_buried_in_its_colour_in_one_view_is_found_there_by_its_outline():
    """Camera 1 shows the ball before a panel of its colour (its ring full of the colour), camera 0 before the grey wall
    (a clean disc). From camera 0's disc, the depth along its ray where camera 1 shows a round outline of the ball's
    size is the ball's: both discs are found within a pixel and a half (a pixel centre is half a pixel from its corner).
    A disc of a wrong size finds nothing; a panel with no ball before it in the buried view (the ball gone, the disc a
    flat one seen by camera 0 only) neither."""
    rig = default_rig(320, 240)
    images = _scene(rig)
    in_range = [target_mask(to_hsv(image), PINK) for image in images]
    (uv0, r0), (uv1, r1) = (_seen(cam, BALL) for cam in rig.cameras)
    assert r1 >= OUTLINE_MIN_PX and in_range[1][int(uv1[1]), int(uv1[0] + 2 * r1)]  # buried: the panel beside it in range
    assert not in_range[0][int(uv0[1]), int(uv0[0] + 2 * r0)]  # the other view's ring is clean
    # the seed's centre a pixel off, as a blob's centroid is
    finds = buried_partners([np.array([[uv0[0] + 1, uv0[1] - 1, r0]]), np.zeros((0, 3))], images, rig.cameras, in_range, RADIUS, 0.3, 6)
    found = per_camera(finds, 2)
    assert found[0].shape == (1, 3) and found[1].shape == (1, 3)
    assert np.linalg.norm(found[1][0, :2] - uv1) < 1.5 and abs(found[1][0, 2] - r1) < 0.5
    assert np.linalg.norm(found[0][0, :2] - uv0) < 1.5
    assert len(finds) == 1 and np.linalg.norm(finds[0].point - BALL) < 0.02
    too_big = buried_partners([np.array([[*uv0, 3 * r0]]), np.zeros((0, 3))], images, rig.cameras, in_range, RADIUS, 0.3, 6)
    assert not too_big
    # no ball: camera 0 shows a flat pink disc where the ball was, camera 1 the panel alone
    empty = _scene(rig, ball=np.array([0.05, 50.0, 0.0]))
    empty[0][in_range[0] > 0] = PINK_BGR
    masks = [target_mask(to_hsv(image), PINK) for image in empty]
    none = buried_partners([np.array([[*uv0, r0]]), np.zeros((0, 3))], empty, rig.cameras, masks, RADIUS, 0.3, 6)
    assert not none


def test_a_tracked_ball_is_held_where_two_views_show_its_outline_at_the_depth_they_show():
    """A track 10 cm behind the ball (a ball rolled away from the cameras) is held by discs where the ball is; a track
    where nothing is round is not held."""
    rig = default_rig(320, 240)
    images = _scene(rig)
    in_range = [target_mask(to_hsv(image), PINK) for image in images]
    behind = BALL + 0.1 * BALL / np.linalg.norm(BALL)
    kept = held_discs(np.array([behind, BALL + [0.0, 0.0, 0.3]]), images, rig.cameras, in_range, RADIUS)
    for cam, discs in zip(rig.cameras, per_camera(kept, 2)):
        uv, r = _seen(cam, BALL)
        assert discs.shape == (1, 3) and np.linalg.norm(discs[0, :2] - uv) < 1.5 and abs(discs[0, 2] - r) < 0.3
        assert abs(_seen(cam, behind)[1] - r) > 0.5  # (the track's disc would have been another size)
    assert len(kept) == 1 and np.linalg.norm(kept[0].point - BALL) < 0.02


@pytest.mark.parametrize("outlines", [True, False])
def test_the_tracker_finds_a_white_ball_at_rest_buried_in_a_white_wall_in_one_view_only_by_its_outline(outlines):
    """A white ball at rest from the first frame before a white panel in one view and a grey wall in the other: nothing
    moves, its ring is of its colour in the buried view, and without the outline search no track ever comes to it. A
    coloured target is not searched (a larger ball of its colour shows round outlines of its size)."""
    rig = default_rig(320, 240)
    config = Config(targets=(WHITE,))
    config = replace(config, tracker=replace(config.tracker, outlines=outlines))
    tracker = Tracker(rig, config)
    near = 0
    for frame in range(20):
        result = tracker.step(FramePair(frame, tuple(_scene(rig, noise=3, seed=frame, white=True)), (frame / 30.0,) * 2))
        near += any(np.linalg.norm(np.asarray(t.position) - BALL) < 0.05 for t in result.tracks)
    if outlines:
        assert near >= 15
    else:
        assert near == 0
    assert not Tracker(rig, Config(targets=(PINK,)))._outline_finders
