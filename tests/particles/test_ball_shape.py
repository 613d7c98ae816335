"""The ball-shape likelihood: a ball-sized disc of evidence with an empty ring, at the particle's depth."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest
from scene_helpers import RADIUS, balls_at, default_rig, disc_masks, evidence

from stereotrack.particles.likelihoods.ball_shape import BallShape
from stereotrack.particles.likelihoods.colour_window import ColourWindow

BALL = np.array([0.0, 1.5, 0.0])


def _wall_masks(rig, ball=None):
    """Each camera's mask: a wall of the ball's colour (a big rectangle) right of centre, and the ball's disc if given."""
    masks, _ = disc_masks(rig, ball[None]) if ball is not None else ([np.zeros((c.height, c.width), np.uint8) for c in rig.cameras], None)
    for m in masks:
        cv2.rectangle(m, (360, 60), (600, 420), 1, -1)
    return masks


def _on_wall(rig):
    """Points in the world that project onto the wall in both cameras, at the ball's depth."""
    out = []
    for x in np.linspace(0.22, 0.45, 6):
        for z in np.linspace(-0.25, 0.25, 5):
            p = np.array([x, 1.5, z])
            if all(c.in_image(c.project(p[None])[0])[0] for c in rig.cameras):
                out.append(p)
    return np.array(out)


def test_a_ball_scores_high_and_a_wall_of_its_colour_scores_the_floor():
    rig = default_rig()
    views = evidence(rig, _wall_masks(rig, BALL))
    wall = _on_wall(rig)
    shape, window = BallShape(RADIUS, 1 / 25), ColourWindow(5)
    at_ball, on_wall = shape(BALL[None], views, None)[0], shape(wall, views, None)
    assert at_ball > 0.5
    assert on_wall.max() < 0.01 and on_wall.max() < at_ball / 50
    # the paper's colour window cannot tell them apart: a full window is a full window
    assert np.allclose(window(wall, views, None), window(BALL[None], views, None)[0])


def test_a_speck_and_a_ball_at_the_wrong_depth_score_less_than_the_ball():
    rig = default_rig()
    shape = BallShape(RADIUS, 1 / 25)
    masks, _ = disc_masks(rig, BALL[None])
    views = evidence(rig, masks)
    ray = BALL / np.linalg.norm(BALL)  # the cameras sit 0.15 m either side of the origin: close enough to one ray
    too_near, right = shape(np.array([BALL - 0.5 * ray]), views, None)[0], shape(BALL[None], views, None)[0]
    assert right > 2 * too_near
    specks, _ = disc_masks(rig, BALL[None], radius=RADIUS / 4)
    assert shape(BALL[None], evidence(rig, specks), None)[0] < right / 10


def test_a_square_patch_the_size_of_the_ball_scores_less_than_the_disc():
    rig = default_rig()
    shape = BallShape(RADIUS, 1 / 25)
    discs, _ = disc_masks(rig, BALL[None])
    squares = []
    for d in discs:
        ys, xs = np.nonzero(d)
        m = np.zeros_like(d)
        m[ys.min() : ys.max() + 1, xs.min() : xs.max() + 1] = 1  # the disc's bounding square, filled
        squares.append(m)
    assert shape(BALL[None], evidence(rig, squares), None)[0] < 0.2 * shape(BALL[None], evidence(rig, discs), None)[0]


def _streak_masks(rig, centre, velocity, radius=RADIUS):
    """Per camera: the mask of a ball swept from centre - velocity to centre + velocity (metres) during the exposure."""
    masks = []
    for cam in rig.cameras:
        m = np.zeros((cam.height, cam.width), np.uint8)
        ends = np.array([centre - velocity, centre + velocity])
        (a, b), r = cam.project(ends)[0], cam.K[0, 0] * radius / cam.depth(centre[None])[0]
        cv2.line(m, tuple(int(round(x * 16)) for x in a), tuple(int(round(x * 16)) for x in b), 1, int(round(2 * r)), cv2.LINE_8, 4)
        masks.append(m)
    return masks


def test_a_streak_scores_at_its_centre_as_a_ball_swept_along_it():
    """A fast ball is a capsule in the image, long but a ball wide: at its centre (the ball's mean position during the
    exposure) and depth it scores as a ball would; a disc test alone scores its filled corners near the floor. A nearer
    depth (a bigger disc, wider than the streak) scores less."""
    rig = default_rig()
    shape = BallShape(RADIUS, 1 / 25)
    disc = shape(BALL[None], evidence(rig, disc_masks(rig, BALL[None])[0]), None)[0]
    for velocity in (np.array([0.12, 0.0, 0.0]), np.array([0.09, 0.0, 0.07])):  # along the image's rows, and slanted
        views = evidence(rig, _streak_masks(rig, BALL, velocity))
        assert all(v.blobs.ball_radii()[0] < 1.3 * rig.cameras[0].K[0, 0] * RADIUS / 1.5 for v in views)  # its width, not its length
        at_centre = shape(BALL[None], views, None)[0]
        assert at_centre > 0.5 * disc, (at_centre, disc)
        ray = BALL / np.linalg.norm(BALL)
        assert shape(np.array([BALL - 0.4 * ray]), views, None)[0] < 0.5 * at_centre


def test_the_end_of_a_still_rod_of_the_balls_colour_scores_the_floor():
    """A rod as wide as the ball is the streak a fast ball would leave, but it does not move: with motion evidence its
    end (which fills a ball's core and leaves most of its ring empty) scores the floor in every camera, where without
    motion it scores near a ball (static_props tune seed 40: a plank's end was tracked from the fourth frame to the
    last). The same streak moving still scores as a ball swept along it."""
    from stereotrack.evidence.gather import CameraEvidence

    rig = default_rig()
    shape = BallShape(RADIUS, 1 / 25)
    velocity = np.array([0.12, 0.0, 0.0])
    masks = _streak_masks(rig, BALL, velocity)
    end = BALL + velocity  # a ball at rest at the rod's end
    still = tuple(
        CameraEvidence.from_mask(c, m, foreground=np.zeros((c.height // 2, c.width // 2), np.uint8)) for c, m in zip(rig.cameras, masks)
    )
    assert shape(end[None], evidence(rig, masks), None)[0] > 0.2  # without motion: the rod's end looks like a ball
    assert shape(end[None], still, None)[0] <= (1 / 25) ** 2 * 1.0001
    assert shape(BALL[None], _moving(rig, masks), None)[0] > 0.3


def test_a_ball_with_thin_still_slivers_on_it_scores_as_a_ball():
    """The colour model can cut a held ball's blob into pieces, some of them thin still slivers shaped like a streak;
    a particle on such a sliver is still judged by the ball's disc (only a still streak about the ball's width is a
    rod: hands tune seed 19 lost its ball without this)."""
    from stereotrack.evidence.gather import CameraEvidence

    rig = default_rig()
    shape = BallShape(RADIUS, 1 / 25)
    masks, _ = disc_masks(rig, BALL[None])
    for cam, m in zip(rig.cameras, masks):
        u, v = (int(round(x)) for x in cam.project(BALL[None])[0][0])
        m[v - 5 : v - 2, u - 20 : u + 20] = 0  # two gaps cut a sliver 5 pixels high out of the disc's middle
        m[v + 3 : v + 6, u - 20 : u + 20] = 0
    still = tuple(
        CameraEvidence.from_mask(c, m, foreground=np.zeros((c.height // 2, c.width // 2), np.uint8)) for c, m in zip(rig.cameras, masks)
    )
    assert any(v.still is not None and v.still.any() for v in still)  # the sliver is a still streak
    assert shape(BALL[None], still, None)[0] > 0.3


def _moving(rig, masks):
    """Evidence where everything of the colour moves: the moving map is the mask."""
    from stereotrack.evidence.gather import CameraEvidence

    return tuple(CameraEvidence.from_mask(c, m, foreground=np.ones_like(m)) for c, m in zip(rig.cameras, masks))


def test_a_moving_ball_half_hidden_by_fingers_scores_high_and_the_edge_of_a_wall_does_not():
    """A ball in a hand: fingers (not the ball's colour) cover the lower half of its disc. In the moving map the
    upper half is a full half disc with clear surroundings, which is a ball; the straight edge of a thing of the
    ball's colour also fills half the core, but it fills corners and ring too, and stays near the floor. In the
    colour map alone a half disc is no ball (a curtain's stripes are half discs side by side)."""
    rig = default_rig()
    masks, _ = disc_masks(rig, BALL[None])
    for cam, m in zip(rig.cameras, masks):
        (u, v), z = cam.project(BALL[None])[0][0], cam.depth(BALL[None])[0]
        r = cam.K[0, 0] * RADIUS / z
        m[int(v) + 1 :, :] = 0  # the lower half hidden ...
        for k in (-0.5, 0.0, 0.5):  # ... but for the gaps between three fingers
            cv2.line(m, (int(u + k * r), int(v)), (int(u + k * r), int(v + 0.9 * r)), 1, 1)
    shape = BallShape(RADIUS, 1 / 25)
    assert shape(BALL[None], _moving(rig, masks), None)[0] > 0.3  # a whole disc scores about 1
    assert shape(BALL[None], evidence(rig, masks), None)[0] < 0.15
    wall = _wall_masks(rig)  # its left edge at x = 360 and its top edge at y = 60 in each image
    views = _moving(rig, wall)
    edge = []
    for x in np.linspace(-0.1, 0.6, 36):  # points on the wall's edges at the ball's depth
        for z in np.linspace(-0.6, 0.6, 61):
            p = np.array([x, 1.5, z])
            uv = [c.project(p[None])[0][0] for c in rig.cameras]
            if all(abs(q[0] - 360) < 8 and 80 < q[1] < 400 or abs(q[1] - 60) < 8 and 380 < q[0] < 580 for q in uv):
                edge.append(p)
    assert len(edge) > 20 and shape(np.array(edge), views, None).max() < 0.05


def _count(integral, x_lo, x_hi, y_lo, y_hi):
    """(set, pixels) of the pixels whose centres lie in the rectangle, clipped (kernels._rect_count, plain Python)."""
    h, w = integral.shape[0] - 1, integral.shape[1] - 1
    x0, x1 = min(max(math.ceil(x_lo), 0), w), min(max(math.floor(x_hi) + 1, 0), w)
    y0, y1 = min(max(math.ceil(y_lo), 0), h), min(max(math.floor(y_hi) + 1, 0), h)
    if x1 <= x0 or y1 <= y0:
        return 0.0, 0.0
    return float(integral[y1, x1] - integral[y0, x1] - integral[y1, x0] + integral[y0, x0]), float((x1 - x0) * (y1 - y0))


def _squares(integral, u, v, offsets, half):
    c, a = np.sum([_count(integral, u + ox - half, u + ox + half, v + oy - half, v + oy + half) for ox, oy in offsets], axis=0)
    return c / a if a > 0 else 0.0


def _disc_reference(integral, u, v, r, scale, bound, halves, inner=0.7, mid=1.2, outer=1.8):
    """kernels._centre_surround spelled out in plain Python: core, the ring's second-emptiest strip of four (sorted),
    sides, corners and (``halves``) the better half."""
    hc = max(inner * r, 0.5)
    c_in, a_in = _count(integral, u - hc, u + hc, v - hc, v + hc)
    if a_in == 0.0:
        return 0.0
    core = c_in / (a_in * scale)
    if max(core, 0.8 * min(1.0, 2.0 * core) if halves else 0.0) <= bound:
        return core
    a, b = mid * r, outer * r
    strips = [(u - b, u - a, v - b, v + b), (u + a, u + b, v - b, v + b), (u - b, u + b, v - b, v - a), (u - b, u + b, v + a, v + b)]
    shares = sorted(c / (n * scale) for c, n in (_count(integral, *s) for s in strips) if n > 0)
    ring = 0.0 if not shares else shares[0] if len(shares) == 1 else shares[1]
    half, d = max(0.12 * r, 0.5), 0.85 * r
    sides = _squares(integral, u, v, [(d, 0.0), (-d, 0.0), (0.0, d), (0.0, -d)], half) / scale
    corners = _squares(integral, u, v, [(d, d), (-d, d), (d, -d), (-d, -d)], half) / scale
    shown = 0.0
    for sy in (-1.0, 1.0) if halves else ():
        c, n = _count(integral, u - hc, u + hc, min(v, v + sy * hc), max(v, v + sy * hc))
        cs, ns = _count(integral, u - half, u + half, v + sy * 0.85 * r - half, v + sy * 0.85 * r + half)
        if n > 0.0 and ns > 0.0:
            shown = max(shown, 0.8 * (c / (n * scale)) * (cs / (ns * scale)))
    clear = (1.0 - corners) * (1.0 - ring)
    return max(core * sides * clear, shown * clear * clear)


def test_the_compiled_disc_look_matches_its_plain_python_reference():
    """The likelihood's look at a disc in the soft colour map and the moving map, against _disc_reference on random
    blobs, specks and walls: particles on blobs, beside them, on the image's border and off it (strips clipped or
    outside), so the ring's strips come in every order and with ties (kernels._centre_surround keeps the
    second-emptiest without branches)."""
    from stereotrack.kernels import project_points
    from stereotrack.particles.kernels import ball_shape_likelihood

    rng = np.random.default_rng(7)
    h, w, f, radius, floor = 120, 160, 100.0, 0.04, 0.04
    K = np.array([[f, 0.0, w / 2], [0.0, f, h / 2], [0.0, 0.0, 1.0]])
    cam = (np.eye(3), np.zeros(3), K, np.zeros(12), np.eye(3))
    no_streaks = (np.zeros((1, 1), np.int32), np.zeros(1, np.int64), 1, np.zeros(0, np.bool_), np.zeros(0), np.zeros((0, 2)), np.zeros(0))
    for trial in range(6):
        soft, moving = np.zeros((h, w), np.uint8), np.zeros((h, w), np.uint8)
        for _ in range(5):  # discs of every size, some cut by the border, with p from 0 to 255
            cx, cy, rr = rng.integers(-5, w + 5), rng.integers(-5, h + 5), int(rng.integers(1, 15))
            cv2.circle(soft, (int(cx), int(cy)), rr, int(rng.integers(60, 256)), -1)
            cv2.circle(moving, (int(cx + rng.integers(-3, 4)), int(cy)), rr, 1, -1)
        if trial % 2:
            soft[:, : w // 3] = 200  # a wall of the colour, still
        speck = rng.integers(0, [w, h], size=(20, 2))
        moving[speck[:, 1], speck[:, 0]] = 1  # one-pixel moving specks
        colour, motion = cv2.integral(soft, sdepth=cv2.CV_32S), cv2.integral(moving, sdepth=cv2.CV_32S)
        uv = np.vstack([rng.uniform(-10, [w + 10, h + 10], size=(300, 2)), rng.uniform(0, [w, h], size=(300, 2)).round()])
        z = rng.uniform(0.3, 3.0, len(uv))
        positions = np.column_stack([(uv[:, 0] - w / 2) * z / f, (uv[:, 1] - h / 2) * z / f, z])
        for use_moving in (False, True):
            out = np.ones(len(positions))
            ball_shape_likelihood(
                out, positions, *cam, colour, 255.0, motion, use_moving, radius, 0.7, 1.2, 1.8, floor, np.zeros(3),
                np.zeros((0, 3)), np.zeros(0), *no_streaks,
            )  # fmt: skip
            projected, _, depth = project_points(positions, *cam)  # (pixels on the grid exactly: as the kernel rounds them)
            for i, ((u, v), z, o) in enumerate(zip(projected, depth, out)):
                if not (0 <= u < w and 0 <= v < h):
                    assert o == floor
                    continue
                r = 0.5 * (K[0, 0] + K[1, 1]) * radius / z
                best = max(_disc_reference(colour, u, v, r, 255.0, floor, False), floor)
                if use_moving:
                    best = max(best, _disc_reference(motion, u, v, r, 1.0, best, True))
                assert o == pytest.approx(best, rel=1e-12, abs=1e-15), (trial, use_moving, i)


def test_a_ball_of_another_target_overlapping_the_ball_hides_none_of_it():
    """Two solid balls cannot overlap. A white target that tracks an orange ball's highlight puts a 'white ball' on the
    orange one, a little nearer one camera; taken as a ball in front, it hid from that camera the depths along the other
    camera's ray behind it, and a ghost there scored as the ball did (hue_wall tune seeds with a white target added:
    false tracks along the rays). TrackedBalls.occluding leaves it out; a ball of another target clear of it still hides."""
    rig = default_rig()
    masks, _ = disc_masks(rig, BALL[None])
    views = evidence(rig, masks)
    shape = BallShape(RADIUS, 1 / 25)
    cam0, cam1 = rig.cameras
    towards0 = (cam0.centre - BALL) / np.linalg.norm(cam0.centre - BALL)
    ray1 = (BALL - cam1.centre) / np.linalg.norm(BALL - cam1.centre)
    ghost = BALL + 0.12 * ray1  # behind the ball on camera 1's ray: in camera 0, in the highlight's shadow

    highlight = BALL + 0.02 * towards0  # overlaps the orange ball
    tracked = balls_at([BALL, highlight], ("orange", "white"))
    as_ball = shape(np.array([BALL, ghost]), views, tracked.others("orange"))  # the highlight taken for a ball in front
    assert as_ball[1] >= as_ball[0]  # the ghost scores as the ball does: camera 0 says nothing of it
    kept = tracked.occluding("orange")
    assert len(kept) == 0
    scores = shape(np.array([BALL, ghost]), views, kept)
    assert scores[1] < 0.25 * scores[0]  # (0.16: in camera 0 its disc still overlaps the ball's a little)
    clear = balls_at([BALL, BALL + 0.3 * towards0], ("orange", "pink"))  # a ball of another colour 30 cm in front: it hides
    assert len(clear.occluding("orange")) == 1
    assert len(balls_at([BALL], "orange").occluding("orange")) == 0 and len(balls_at([highlight], "white").occluding("orange")) == 1
