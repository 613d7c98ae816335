"""Stress scenes (simulation/stress.py): each category holds what it claims, a seed always gives the same scene,
and the target is what a user would type."""

import argparse
import dataclasses

import numpy as np
import pytest

from stereotrack.commands.stress import scene_key
from stereotrack.evidence.colour import target_mask, to_hsv
from stereotrack.simulation.render import MOVER_IDS, SceneRenderer
from stereotrack.simulation.rooms import bgr_to_hsv, hue_distance
from stereotrack.simulation.shapes import TAG_SCENERY, TAG_TARGET_COLOURED, Ellipsoid
from stereotrack.simulation.stress import CATEGORIES, scene_name, seeds, stress_scene


def small(spec, scale=0.5):
    """The same scene at a smaller image size (everything else unchanged)."""
    w, h = (max(32, int(round(x * scale))) for x in (spec.rig.width, spec.rig.height))
    return dataclasses.replace(spec, rig=dataclasses.replace(spec.rig, width=w, height=h))


def masks(renderer, images):
    target = renderer.spec.config().targets[0]
    return [target_mask(to_hsv(im), target).astype(bool) for im in images]


def test_pixel_rays_undo_the_lens_like_the_camera_model():
    from stereotrack.simulation.spec import RigSpec
    from stereotrack.simulation.stage import pixel_rays

    cam = RigSpec(dist=(-0.15, 0.05, 0.001, -0.002, 0.01)).build().cameras[1]
    uu, vv = np.meshgrid(np.arange(0, 640, 7.3), np.arange(0, 480, 5.1))
    rays = pixel_rays(cam, uu, vv).reshape(-1, 3)
    _, exact = cam.rays(np.column_stack([uu.ravel(), vv.ravel()]))
    assert np.abs(rays - exact).max() < 1e-6
    uv, _ = cam.project(cam.centre + 2.0 * rays.astype(float))
    assert np.abs(uv - np.column_stack([uu.ravel(), vv.ravel()])).max() < 1e-3


def test_tune_and_report_seeds_never_overlap():
    assert not set(seeds("tune", 1_000_000)) & set(seeds("report", 1_000_000))
    assert seeds("tune", 3) == [0, 1, 2] and seeds("report", 2) == [1_000_000, 1_000_001]


@pytest.mark.parametrize("category", list(CATEGORIES))
def test_a_seed_always_gives_the_same_scene_and_another_seed_another(category):
    a, b, other = stress_scene(category, 7), stress_scene(category, 7), stress_scene(category, 8)
    assert scene_key(a) == scene_key(b) and scene_key(a) != scene_key(other)
    assert a.config().targets[0].hsv_min != other.config().targets[0].hsv_min or a.balls != other.balls


def test_the_same_seed_renders_the_same_pixels():
    spec = small(stress_scene("hands", 3), 0.25)
    first, again = SceneRenderer(spec).render(5), SceneRenderer(spec).render(5)
    assert all(np.array_equal(x, y) for x, y in zip(first[0], again[0])) and first[1] == again[1]
    other = SceneRenderer(small(stress_scene("hands", 4), 0.25)).render(5)[0]
    assert not np.array_equal(first[0][0], other[0])


@pytest.mark.parametrize("category", list(CATEGORIES))
def test_the_target_is_what_a_user_would_type_not_a_fit(category):
    for seed in range(3):
        spec = stress_scene(category, seed)
        (target,) = spec.config().targets
        h, s, v = bgr_to_hsv(spec.balls[0].bgr)
        assert target.radius == pytest.approx(spec.balls[0].radius)
        if s < 60:  # white or grey: any hue, low saturation, high value
            assert target.hsv_min[:2] == (0, 0) and target.hsv_max[0] == 179 and target.hsv_max[1] <= 70
            assert 90 <= target.hsv_min[2] <= v
        else:
            centre = (target.hsv_min[0] + ((target.hsv_max[0] - target.hsv_min[0]) % 180) / 2) % 180
            assert hue_distance(centre, h) <= 2.5
            assert 18 <= (target.hsv_max[0] - target.hsv_min[0]) % 180 <= 22
            assert 70 <= target.hsv_min[1] <= 90 and 70 <= target.hsv_min[2] <= 90 and target.hsv_max[1:] == (255, 255)


def test_hue_walls_are_in_the_users_range_and_the_rest_of_the_room_is_not():
    shown = 0
    for seed in range(3):
        r = SceneRenderer(small(stress_scene("hue_wall", seed)))
        images, _ = r.render(0)
        labels = r.labels(0)
        for cam, (mask, lab) in enumerate(zip(masks(r, images), labels)):
            tags = r.stage_tags(cam)
            wall = (tags == TAG_TARGET_COLOURED) & (lab < 0)
            room = (tags == TAG_SCENERY) & (lab < 0)
            if wall.sum() > 300:
                shown += 1
                assert mask[wall].mean() > 0.6, (seed, cam, mask[wall].mean())
            assert mask[room].mean() < 0.02, (seed, cam, mask[room].mean())
    assert shown >= 3  # the walls are in view, not behind the cameras


def test_static_props_stand_in_both_views_and_ball_sized_ones_in_one_only():
    one_view = 0
    for seed in range(2):
        spec = small(stress_scene("static_props", seed))
        r = SceneRenderer(spec)
        images, _ = r.render(0)
        labels = r.labels(0)
        for cam, mask in enumerate(masks(r, images)):
            props = r.stage_tags(cam) == TAG_TARGET_COLOURED
            assert props.sum() > 100 and mask[props].mean() > 0.4
        radius = spec.balls[0].radius
        for k, p in enumerate(spec.stage.props):
            if (
                isinstance(p, Ellipsoid)
                and p.material.tag == TAG_TARGET_COLOURED
                and max(p.axes) < 1.3 * radius
                and min(p.axes) > 0.8 * radius
            ):
                seen = [bool((lab == -1000 - k).any()) for lab in labels]
                assert sum(seen) == 1, (seed, k, seen)
                one_view += 1
    assert one_view >= 2


def test_hands_hold_the_balls_and_hide_part_of_them():
    hidden = 0
    for seed in range(2):
        spec = small(stress_scene("hands", seed), 0.35)
        with_hands, without = SceneRenderer(spec), SceneRenderer(dataclasses.replace(spec, movers=()))
        hand = spec.movers[0]
        for frame in range(0, spec.n_frames, 6):
            t = frame / spec.fps
            grip, holding = hand.pattern.hand(hand.side, np.array([t]))
            balls = with_hands.ball_positions(t)
            if holding[0]:  # the ball in a hand moves with it
                assert np.min(np.linalg.norm(balls - grip, axis=1)) < 1e-9
            for a, b in zip(with_hands.labels(frame), without.labels(frame)):
                hidden += int(((b >= 0) & (a <= MOVER_IDS)).sum())
    assert hidden > 50  # fingers in front of balls


def test_white_balls_against_white_walls_also_in_greyscale():
    specs = [small(stress_scene("white_ball", seed), 0.25) for seed in range(10)]
    assert all(bgr_to_hsv(s.balls[0].bgr)[1] < 25 for s in specs)
    mono = [s for s in specs if s.responses[0].greyscale]
    assert 2 <= len(mono) <= 8
    for spec in [*specs[:2], mono[0]]:
        r = SceneRenderer(spec)
        images, _ = r.render(0)
        assert max(m.mean() for m in masks(r, images)) > 0.2  # the walls are what the user's range takes
        assert all(np.array_equal(im[..., 0], im[..., 2]) for im in images) == spec.responses[0].greyscale


def test_lighting_drifts_and_each_camera_has_its_own_white_balance():
    spec = small(stress_scene("lighting", 1), 0.25)
    balance = [np.array(resp.gains) / resp.gains[1] for resp in spec.responses]
    assert np.abs(balance[0] - balance[1]).max() > 0.03
    r = SceneRenderer(spec)
    level = [np.mean(r.render(f)[0][0]) for f in range(0, spec.n_frames, 10)]
    assert max(level) / min(level) > 1.05


def test_the_other_categories_have_their_trouble():
    blur = stress_scene("motion_blur", 0)
    assert blur.blur >= 9 and blur.exposure >= 0.6
    jpeg = small(stress_scene("mjpg", 0), 0.25)
    assert 25 <= jpeg.jpeg_quality <= 65
    assert not np.array_equal(SceneRenderer(jpeg).render(0)[0][0], SceneRenderer(dataclasses.replace(jpeg, jpeg_quality=0)).render(0)[0][0])
    hd = stress_scene("hd60", 0)
    assert (hd.rig.width, hd.rig.height, hd.fps) == (1280, 720, 60.0)
    three = small(stress_scene("three_cams", 0), 0.25)
    assert three.rig.cameras == 3 and max(row[4] for row in SceneRenderer(three).render(3)[1]) == 3


def test_a_fast_ball_is_5_to_15_m_away_wherever_a_camera_sees_it():
    """The issue's fast balls are 5-15 m away. A flight slanted across the view (heading up to 25 degrees) used to
    reach 20 m and more at one side, where a ball is a pixel or two across and its streak a faint grey line (tune
    seed 478: 55 frames at 17-19 m of a ball 1 px in radius), and come nearer than 5 m at the other."""
    for seed in range(12):
        spec = stress_scene("fast_ball", seed)
        times = np.arange(spec.n_frames) / spec.fps  # every frame at once, as SceneRenderer.ball_positions places them
        cameras = spec.rig.build().cameras
        seen_rows = 0
        for ball in spec.balls:
            pts = ball.trajectory.positions(times)
            present = (ball.appear <= times) & (times < ball.disappear)
            for cam in cameras:
                uv, front = cam.project(pts)
                seen = present & front & cam.in_image(uv)
                depth = cam.depth(pts)[seen]
                assert np.all((depth >= 5.0) & (depth <= 15.0)), (seed, np.nonzero(seen)[0], depth)
                seen_rows += len(depth)
        assert seen_rows > 20


def test_a_fast_ball_is_a_streak_as_long_as_its_speed_says():
    spec = small(stress_scene("fast_ball", 2), 640 / stress_scene("fast_ball", 2).rig.width)
    r, empty = SceneRenderer(spec), SceneRenderer(dataclasses.replace(spec, balls=()))
    cam = r.rig.cameras[0]
    in_view = [f for f in range(spec.n_frames) if np.isfinite(r.ball_positions(f / spec.fps)[:, 0]).any()]
    checked = 0
    for frame in in_view[len(in_view) // 4 :: 9]:
        images, truth = r.render(frame)
        if not truth or checked >= 2:
            continue
        k = truth[0][0]
        ball = spec.balls[k]
        speed = np.linalg.norm(ball.trajectory.velocity)
        assert 10 <= speed <= 30 and 5 <= truth[0][2] <= 15.5
        t = frame / spec.fps
        half = 0.5 * spec.exposure / spec.fps
        ends, _ = cam.project(ball.trajectory.positions(np.array([t - half, t + half])))
        radius_px = cam.focal_px * ball.radius / cam.depth(np.array([truth[0][1:4]]))[0]
        expected = np.linalg.norm(ends[1] - ends[0]) + 2 * radius_px
        diff = np.abs(images[0].astype(int) - empty.render(frame)[0][0].astype(int)).sum(axis=2) > 12
        ys, xs = np.nonzero(diff)
        if len(xs) == 0 or xs.min() == 0 or xs.max() == cam.width - 1:
            continue  # cut by the border
        direction = (ends[1] - ends[0]) / np.linalg.norm(ends[1] - ends[0])
        along = np.column_stack([xs, ys]) @ direction
        assert along.max() - along.min() == pytest.approx(expected, rel=0.25), (frame, expected)
        assert np.linalg.norm(ends[1] - ends[0]) > radius_px  # smeared by half a ball or more: a streak
        checked += 1
    assert checked >= 1


def test_a_stress_scene_is_named_category_colon_seed():
    assert scene_name("hue_wall:18") == ("hue_wall", 18)
    for bad in ("nope:3", "hue_wall:x", "hue_wall", ":4", "hue_wall:-1"):
        with pytest.raises(argparse.ArgumentTypeError, match="CATEGORY:SEED"):
            scene_name(bad)


def test_a_fast_ball_slows_by_air_drag_as_its_kind_does():
    """A pitched ball is no drag-free parabola: a tennis ball at 30 m/s slows by about 18 m/s^2, a baseball by 6. Each
    fast_ball scene's balls slow as their kind's drag says (k |v| v), and fall by g besides."""
    from stereotrack.simulation.stress import BALL_KINDS
    from stereotrack.simulation.trajectories import drag_per_metre

    kinds = {drag_per_metre(*kind): name for name, kind in BALL_KINDS.items()}
    seen = set()
    for seed in range(6):
        spec = stress_scene("fast_ball", seed)
        for ball in spec.balls:
            flight = ball.trajectory
            assert flight.drag in kinds
            seen.add(kinds[flight.drag])
            h, t = 1e-3, flight.t0 + np.array([0.1, 0.3])
            p = flight.positions(np.r_[t - h, t, t + h])
            v = (p[4:] - p[:2]) / (2 * h)  # at t
            a = (p[4:] - 2 * p[2:4] + p[:2]) / h**2
            expected = np.array([0.0, 0.0, -9.81]) - flight.drag * np.linalg.norm(v, axis=1)[:, None] * v
            assert np.allclose(a, expected, atol=0.05), (seed, a, expected)
            assert np.linalg.norm(v[1]) < np.linalg.norm(v[0]) - 0.1
    assert len(seen) >= 2
