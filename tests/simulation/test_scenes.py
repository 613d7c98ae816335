import dataclasses

import cv2
import numpy as np
import pytest

from stereotrack.cli import main
from stereotrack.errors import StereotrackError
from stereotrack.recording import open_recording, read_truth
from stereotrack.simulation.presets import PRESETS, load_scene_yaml, make_preset
from stereotrack.simulation.render import CLEAR_SHARE, SceneRenderer
from stereotrack.simulation.spec import BallSpec, Occluder, RigSpec, SceneSpec
from stereotrack.simulation.trajectories import Static
from stereotrack.simulation.visibility import shown
from stereotrack.simulation.write import ensure_demo_recording


def hsv_mask(image: np.ndarray, target) -> np.ndarray:
    hsv = cv2.cvtColor(image, cv2.COLOR_BGR2HSV)
    lo, hi = np.array(target.hsv_min), np.array(target.hsv_max)
    if target.wraps:
        a = cv2.inRange(hsv, lo, np.array([179, hi[1], hi[2]]))
        b = cv2.inRange(hsv, np.array([0, lo[1], lo[2]]), hi)
        return (a | b) > 0
    return cv2.inRange(hsv, lo, hi) > 0


def one_ball_scene(position, dist=(), noise=0.0, occluders=(), width=640, height=480) -> SceneSpec:
    rig = RigSpec(width=width, height=height, dist=tuple(dist))
    return SceneSpec("t", (BallSpec(Static(tuple(position))),), rig, n_frames=1, noise=noise, occluders=tuple(occluders))


@pytest.mark.parametrize("dist", [(), (-0.25, 0.08, 0.001, -0.0005, 0.0)])
def test_mask_centroid_within_half_pixel_of_projected_centre(dist):
    # A ball 1.5 m ahead, slightly off the aim point so the centre is not on a pixel grid point.
    centre = np.array([0.013, 1.5, -0.021])
    spec = one_ball_scene(centre, dist=dist, noise=2.0)
    renderer = SceneRenderer(spec)
    images, truth = renderer.render(0)
    target = spec.targets()[0]
    for cam, img in zip(renderer.rig.cameras, images):
        uv, front = cam.project(centre[None])
        assert front[0]
        mask = hsv_mask(img, target)
        ys, xs = np.nonzero(mask)
        radius_px = cam.K[0, 0] * 0.035 / cam.depth(centre[None])[0]
        assert abs(len(xs) - np.pi * radius_px**2) < 0.1 * np.pi * radius_px**2  # the whole disc, nothing else
        err = np.hypot(xs.mean() - uv[0, 0], ys.mean() - uv[0, 1])
        assert err < 0.5, f"{cam.name}: centroid {err:.3f} px from the projected centre"
    assert len(truth) == 1 and truth[0][4] == 2


def test_distortion_moves_the_ball_where_the_camera_model_projects_it():
    # Far from the axis strong barrel distortion shifts the ball by many pixels; the render must follow.
    centre = np.array([0.45, 1.5, 0.25])
    for dist in [(), (-0.3, 0.1, 0.0, 0.0, 0.0)]:
        spec = one_ball_scene(centre, dist=dist)
        renderer = SceneRenderer(spec)
        images, _ = renderer.render(0)
        cam = renderer.rig.cameras[0]
        uv, _ = cam.project(centre[None])
        ys, xs = np.nonzero(hsv_mask(images[0], spec.targets()[0]))
        assert np.hypot(xs.mean() - uv[0, 0], ys.mean() - uv[0, 1]) < 1.0
    undistorted = SceneRenderer(one_ball_scene(centre)).rig.cameras[0].project(centre[None])[0]
    assert np.linalg.norm(uv - undistorted) > 4  # the distortion case really moved it (5.8 px)


@pytest.mark.parametrize("name", list(PRESETS))
def test_every_preset_renders_with_truth(name):
    spec = make_preset(name, width=320, height=240, n_frames=2)
    renderer = SceneRenderer(spec)
    assert renderer.rig.cameras[0].image_size == (320, 240)
    images, truth = renderer.render(1)
    assert len(images) == 2 and all(img.shape == (240, 320, 3) and img.dtype == np.uint8 for img in images)
    assert truth, f"{name}: no ball in view at frame 1"
    for oid, x, y, z, visible, clear in truth:
        assert 0 <= oid < len(spec.balls) and 0 <= clear <= visible <= 2
        for cam in renderer.rig.cameras:  # truth rows are balls whose centre every camera sees
            uv, front = cam.project(np.array([[x, y, z]]))
            assert front[0] and 0 <= uv[0, 0] <= 319 and 0 <= uv[0, 1] <= 239
    assert spec.targets(), f"{name}: no targets"


def test_presets_keep_every_ball_in_view_the_whole_time():
    for name in ("pendulum4", "crossing", "throw1", "juggle5"):
        spec = make_preset(name)
        renderer = SceneRenderer(spec)
        in_view = 0
        frames = range(0, spec.n_frames, 3)
        for f in frames:
            pos = renderer.ball_positions(renderer.time(f))
            ok = np.isfinite(pos[:, 0])
            for cam in renderer.rig.cameras:
                uv, front = cam.project(np.nan_to_num(pos))
                ok &= front & (uv[:, 0] >= 0) & (uv[:, 0] < cam.width) & (uv[:, 1] >= 0) & (uv[:, 1] < cam.height)
            in_view += ok.sum()
        present = sum(np.isfinite(renderer.ball_positions(renderer.time(f))[:, 0]).sum() for f in frames)
        assert in_view == present, f"{name}: {present - in_view} ball-frames out of view"
        if name != "juggle5":  # the capture loses balls now and then; synthetic balls are always there
            assert present == len(spec.balls) * len(frames)


def test_same_seed_same_images_other_seed_other_images():
    a = SceneRenderer(make_preset("clutter", width=320, height=240, seed=4)).render(5)[0]
    b = SceneRenderer(make_preset("clutter", width=320, height=240, seed=4)).render(5)[0]
    c = SceneRenderer(make_preset("clutter", width=320, height=240, seed=5)).render(5)[0]
    assert all(np.array_equal(x, y) for x, y in zip(a, b))
    assert not np.array_equal(a[0], c[0])
    # Frames render on their own: the same frame out of order comes out the same.
    r = SceneRenderer(make_preset("clutter", width=320, height=240, seed=4))
    r.render(9)
    assert all(np.array_equal(x, y) for x, y in zip(a, r.render(5)[0]))


def test_occluder_hides_the_ball_in_one_view():
    centre = (0.0, 1.5, 0.0)
    # A panel between cam0 (x = -0.15) and the ball, clear of cam1's line of sight.
    panel = Occluder(centre=(-0.1, 0.5, 0.0), size=(0.08, 0.01, 0.1))
    spec = one_ball_scene(centre, occluders=[panel])
    renderer = SceneRenderer(spec)
    images, truth = renderer.render(0)
    target = spec.targets()[0]
    seen = [hsv_mask(img, target).sum() for img in images]
    free = [hsv_mask(img, target).sum() for img in SceneRenderer(one_ball_scene(centre)).render(0)[0]]
    assert seen[0] == 0 and free[0] > 500
    assert seen[1] == free[1]
    assert truth == [(0, 0.0, 1.5, 0.0, 1, 1)]
    labels = renderer.labels(0)
    assert (labels[0] == 0).sum() == 0 and (labels[0] == -2).sum() > 1000 and (labels[1] == 0).sum() > 500
    cam0, cam1 = shown(renderer, 0)[:, 0]
    assert cam0 == 0.0 and 0.95 < cam1 < 1.05  # hidden from cam0, all of it in cam1 (its disc's pixels, to its edge's)


def _at_column(cam, u: float, y: float = 1.5) -> np.ndarray:
    """The point at depth ``y`` (z 0) that ``cam`` shows at column ``u`` of its middle row (off its image, too)."""
    o, d = (a[0] for a in cam.rays(np.array([[u, cam.height / 2]])))
    return o + (y - o[1]) / d[1] * d


@pytest.mark.parametrize("out_px, out_radii, clear", [(3.0, 0.0, 2), (0.0, 0.8, 1)])
def test_truth_holds_a_ball_whose_centre_is_out_of_an_image_that_shows_part_of_it(out_px, out_radii, clear):
    """A ball whose centre lies 3 pixels left of cam0's image shows nearly half its disc there: it has a truth row, clear
    in both cameras (a tracker that follows it there is right, not false). One that shows cam0 a sliver (its centre 0.8
    radii out) has a row that leaves it optional (clear 1); one out of every image has none."""
    cam = RigSpec().build().cameras[0]  # one_ball_scene's rig
    r = cam.apparent_radius(0.035, np.array([1.5]))[0]
    point = _at_column(cam, -(out_px + out_radii * r))
    renderer = SceneRenderer(one_ball_scene(tuple(point)))
    (row,) = renderer.render(0)[1]
    assert row[0] == 0 and np.allclose(row[1:4], point) and row[4] == 2 and row[5] == clear
    share = shown(renderer, 0)[0, 0]
    assert (0.3 < share < 0.5) if clear == 2 else (0 < share < CLEAR_SHARE)
    assert SceneRenderer(one_ball_scene((-5.0, 1.5, 0.0))).render(0)[1] == []
    # hidden from both cameras behind a board, its centre inside both images: a row (optional), where a track coasts
    board = Occluder(centre=(0.0, 1.0, 0.0), size=(1.0, 0.01, 1.0))
    assert SceneRenderer(one_ball_scene((0.0, 1.5, 0.0), occluders=[board])).render(0)[1] == [(0, 0.0, 1.5, 0.0, 0, 0)]


def test_shown_is_the_share_of_a_ball_that_an_occluder_leaves():
    centre = (0.0, 1.5, 0.0)
    half = Occluder(centre=(-0.075 - 0.04, 0.75, 0.0), size=(0.08, 0.01, 0.2))  # halfway to cam0, its edge on the ball's centre
    renderer = SceneRenderer(one_ball_scene(centre, occluders=[half]))
    cam0, cam1 = shown(renderer, 0)[:, 0]
    free = (SceneRenderer(one_ball_scene(centre)).labels(0)[0] == 0).sum()
    assert 0.3 < cam0 < 0.7 and 0.95 < cam1 < 1.05
    assert cam0 == pytest.approx((renderer.labels(0)[0] == 0).sum() / free, rel=0.05)  # the share of the ball's own pixels
    assert np.isnan(shown(SceneRenderer(one_ball_scene((3.0, 1.5, 0.0))), 0)).all()  # out of both views


@pytest.mark.parametrize("edge, clear", [(-0.075 - 0.04, 2), (-0.075 - 0.04 + 0.01, 1)])
def test_truth_counts_a_camera_clear_of_a_ball_when_it_shows_a_quarter_of_it(edge, clear):
    """Half the ball behind a panel: both cameras see it clearly. A sliver (the panel's edge near the ball's far rim in
    cam0): seen by both, clear in one, as ``shown`` measures it."""
    renderer = SceneRenderer(one_ball_scene((0.0, 1.5, 0.0), occluders=[Occluder(centre=(edge, 0.75, 0.0), size=(0.08, 0.01, 0.2))]))
    ((_, *_, visible, got),) = renderer.render(0)[1]
    share = shown(renderer, 0)[0, 0]
    assert visible == 2 and got == clear
    assert (share >= CLEAR_SHARE) == (clear == 2) and share > 0  # a sliver: some of it, under a quarter


def test_crossing_balls_hide_each_other_in_turn():
    spec = make_preset("crossing", width=320, height=240)
    renderer = SceneRenderer(spec)
    visible_far = [dict((r[0], r[4]) for r in renderer.render(f)[1]).get(1) for f in range(30, 60)]
    assert min(visible_far) < 2  # the far ball disappears behind the near one in at least one view
    assert visible_far[0] == 2 and visible_far[-1] == 2


@pytest.mark.parametrize("name", ["pendulum4", "static_depths", "juggle5", "clutter"])
def test_target_range_covers_balls_and_little_background(name):
    spec = make_preset(name, n_frames=3)
    renderer = SceneRenderer(spec)
    target = spec.targets()[0]
    for f in (0, 2):
        images, _ = renderer.render(f)
        for img, labels in zip(images, renderer.labels(f)):
            mask = hsv_mask(img, target)
            ball = labels >= 0
            core = cv2.erode(ball.astype(np.uint8), np.ones((3, 3), np.uint8)) > 0  # edge pixels blend with the background
            inside = mask[core].mean()
            assert inside > 0.9, f"{name}: only {inside:.1%} of ball pixels in the HSV range"
            background = mask[labels == -1].mean()
            limit = 0.02 if name == "clutter" else 0.001  # clutter has similar-hue distractors on purpose
            assert background < limit, f"{name}: {background:.2%} of background pixels in the HSV range"


def test_static_depths_places_balls_at_the_given_depths():
    spec = make_preset("static_depths", depths=[0.8, 1.6, 2.4, 3.0])
    _, truth = SceneRenderer(spec).render(0)
    assert [round(r[2], 6) for r in truth] == [0.8, 1.6, 2.4, 3.0]


def test_appear_schedule():
    spec = make_preset("appear5", interval=0.5, width=160, height=120)
    renderer = SceneRenderer(spec)
    counts = [len(renderer.render(f)[1]) for f in (0, 16, 31, 46, 61)]
    assert counts == [1, 2, 3, 4, 5]
    together = make_preset("appear5", all_at_once=True, width=160, height=120)
    assert len(SceneRenderer(together).render(0)[1]) == 5


def test_unknown_preset_and_setting_are_clear_errors():
    with pytest.raises(StereotrackError, match="unknown scene preset 'pendulum5'.*pendulum4"):
        make_preset("pendulum5")
    with pytest.raises(StereotrackError, match="unknown setting 'depht'"):
        make_preset("static_depths", depht=[1.0])


def test_scene_yaml(tmp_path):
    path = tmp_path / "scene.yaml"
    path.write_text(
        """
name: two
fps: 20
n_frames: 4
rig: {width: 160, height: 120, baseline: 0.2}
balls:
  - colour: orange
    radius: 0.05
    trajectory: {type: line, start: [-0.2, 1.5, 0], end: [0.2, 1.5, 0], period: 2}
  - trajectory: {type: pendulum, pivot: [0, 1.8, 0.6], length: 0.6, amplitude: 20}
    appear: 0.1
"""
    )
    spec = load_scene_yaml(path)
    assert spec.name == "two" and spec.fps == 20 and spec.rig.baseline == 0.2 and len(spec.balls) == 2
    assert [t.name for t in spec.targets()] == ["orange", "pink"]
    _, truth = SceneRenderer(spec).render(1)
    assert [r[0] for r in truth] == [0]  # the pendulum comes in at 0.1 s
    assert truth[0][1] == pytest.approx(-0.2 + 0.4 * (0.05 / 1.0))
    preset = tmp_path / "p.yaml"
    preset.write_text("preset: static_depths\nparams: {depths: [1.0]}\nseed: 3\n")
    assert load_scene_yaml(preset).seed == 3
    bad = tmp_path / "bad.yaml"
    bad.write_text("balls:\n  - trajectory: {type: spiral}\n")
    with pytest.raises(StereotrackError, match="trajectory.type"):
        load_scene_yaml(bad)


def test_synth_command_writes_a_readable_recording(tmp_path, capsys):
    out = tmp_path / "rec"
    assert (
        main(
            [
                "synth",
                "pendulum4",
                "--out",
                str(out),
                "--frames",
                "3",
                "--width",
                "320",
                "--height",
                "240",
                "--no-progress",
                "--codec",
                "ffv1",
            ]
        )
        == 0
    )
    rec = open_recording(out)
    assert rec.n_frames == 3 and rec.rig is not None and rec.rig.world == "custom"
    assert rec.meta["up"] == [0.0, 0.0, 1.0] and rec.targets_path.is_file()
    truth = read_truth(rec.truth_path)
    assert truth.shape == (12, 5)
    assert rec.truth_path.read_text().splitlines()[0] == "frame,object_id,x,y,z,visible,clear"
    renderer = SceneRenderer(make_preset("pendulum4", n_frames=3, width=320, height=240))
    frames = list(rec.frames())
    for pair in frames:
        images, rows = renderer.render(pair.index)
        assert all(np.array_equal(a, b) for a, b in zip(images, pair.images))  # FFV1 is lossless
        assert np.allclose(truth[truth[:, 0] == pair.index, 2:5], [r[1:4] for r in rows], atol=1e-6)
    assert main(["synth", "pendulum5", "--out", str(tmp_path / "x")]) == 2
    assert "unknown scene preset" in capsys.readouterr().err
    assert main(["synth", "--list"]) == 0
    assert "juggle5" in capsys.readouterr().out


def test_demo_recording_is_rendered_once_and_atomically(tmp_path, monkeypatch):
    import stereotrack.simulation.presets as scenes

    real = scenes.make_preset
    monkeypatch.setattr(scenes, "make_preset", lambda name, **kw: real(name, **dict(kw, n_frames=4, width=160, height=120)))
    demo = ensure_demo_recording(tmp_path)
    assert demo == tmp_path / "recordings" / "demo" and open_recording(demo).n_frames == 4
    stamp = (demo / "cam0.avi").stat().st_mtime_ns
    assert ensure_demo_recording(tmp_path) == demo and (demo / "cam0.avi").stat().st_mtime_ns == stamp
    (demo / "frames.csv").write_text("frame,t_cam0,t_cam1\n0,0,0\n")  # a damaged demo is rendered again
    ensure_demo_recording(tmp_path)
    assert open_recording(demo).n_frames == 4
    assert [p.name for p in (tmp_path / "recordings").iterdir()] == ["demo"]
    again = ensure_demo_recording(tmp_path / "elsewhere")  # deterministic: the same files anywhere
    for name in ("truth.csv", "frames.csv", "calib.yaml", "config.yaml", "cam0.avi", "cam1.avi"):
        assert (again / name).read_bytes() == (demo / name).read_bytes(), name


def test_committed_demo_calibration_is_the_pendulum4_rig():
    from pathlib import Path

    from stereotrack.camera import load_rig

    committed = load_rig(Path(__file__).resolve().parents[2] / "calib" / "demo.yaml")
    rig = make_preset("pendulum4").rig.build()
    assert committed.world == "custom" and committed.names == rig.names
    for a, b in zip(committed.cameras, rig.cameras):
        assert a.image_size == b.image_size and np.allclose(a.K, b.K) and np.allclose(a.R, b.R) and np.allclose(a.t, b.t)
    assert abs(rig.baseline() - 0.3) < 1e-12
    # World frame: origin midway between the cameras, y forward, z up, cameras aimed 1.5 m ahead.
    assert np.allclose((rig[0].centre + rig[1].centre) / 2, 0) and rig[0].centre[0] < rig[1].centre[0]
    uv, _ = rig[0].project(np.array([[0.0, 1.5, 0.0], [0.0, 1.5, 0.2]]))
    assert np.allclose(uv[0], rig[0].K[:2, 2]) and uv[1, 1] < uv[0, 1]  # the aim point at the image centre; up is up


def test_readme_scene_examples_load_and_render(tmp_path):
    from pathlib import Path

    readme = (Path(__file__).resolve().parents[2] / "README.md").read_text()
    section = readme.split("<!-- section: synth -->")[1].split("<!-- /section: synth -->")[0]
    blocks = [b.split("```")[0] for b in section.split("```yaml\n")[1:]]
    assert len(blocks) == 2
    for i, block in enumerate(blocks):
        path = tmp_path / f"scene{i}.yaml"
        path.write_text(block)
        spec = load_scene_yaml(path)
        renderer = SceneRenderer(spec)
        images, truth = renderer.render(0)
        assert len(images) == 2 and truth
    assert len(spec.balls) == 5 and len(spec.occluders) == 1 and [t.name for t in spec.targets()] == ["pink", "orange"]
    assert spec.balls[4].trajectory.drag == 0.0  # every trajectory type is shown


def test_motion_blur_smears_a_fast_ball_along_its_motion():
    from stereotrack.simulation.trajectories import Line

    fast = Line((-0.6, 1.5, 0.0), (0.6, 1.5, 0.0), period=0.8)  # 3 m/s across the image
    widths = {}
    for blur in (1, 8):
        spec = SceneSpec(
            "b", (BallSpec(fast, colour=(40, 200, 40)),), RigSpec(width=320, height=240), n_frames=4, noise=0.0, blur=blur, exposure=1.0
        )
        renderer = SceneRenderer(spec)
        images, truth = renderer.render(3)
        # Where the image differs from the empty background: the ball and its streak.
        diff = (
            np.abs(images[0].astype(int) - SceneRenderer(dataclasses.replace(spec, balls=())).render(3)[0][0].astype(int)).sum(axis=2) > 6
        )
        ys, xs = np.nonzero(diff)
        widths[blur] = (xs.max() - xs.min(), ys.max() - ys.min())
        uv, _ = renderer.rig.cameras[0].project(np.array(truth[0][1:4])[None])
        assert abs(xs.mean() - uv[0, 0]) < 1.0  # the streak is centred on the mid-exposure position
    # 3 m/s for 1/30 s is 0.1 m, about 18 px at 1.5 m (f = 277 px): the streak is that much longer, no taller.
    assert widths[8][0] - widths[1][0] == pytest.approx(18, abs=3)
    assert abs(widths[8][1] - widths[1][1]) <= 1
    assert spec.targets()[0].name == "bgr_40_200_40"


def test_the_first_frame_shows_every_ball_whole_under_motion_blur():
    """The recording starts at time 0: a ball at rest looks the same in its first frame as in every later one (the first
    exposure's sub-frames before time 0 drew no ball, and the first frame's balls were a third transparent)."""
    spec = SceneSpec("s", (BallSpec(Static((0.0, 1.5, 0.0)), colour=(40, 200, 40)),), RigSpec(width=320, height=240), n_frames=3,
                     noise=0.0, blur=3, exposure=1.0)  # fmt: skip
    renderer = SceneRenderer(spec)
    first, later = renderer.render(0)[0][0], renderer.render(2)[0][0]
    empty = SceneRenderer(dataclasses.replace(spec, balls=())).render(2)[0][0]
    ball = np.abs(later.astype(int) - empty.astype(int)).sum(axis=2) > 6
    assert ball.sum() > 100  # the ball is in view
    assert np.array_equal(first, later)


def test_a_flight_with_drag_is_the_same_at_a_time_whatever_else_is_asked_and_without_drag_the_parabola():
    """A frame renders on its own: a flight with drag, integrated on a fixed grid from its start, gives a time the same
    position whichever times are asked with it (or before it); without drag it is the closed-form parabola."""
    from stereotrack.simulation.trajectories import Flight, drag_per_metre

    k = drag_per_metre(0.033, 0.058, 0.55)  # a tennis ball
    flight = Flight((0.0, 0.0, 1.0), (28.0, 3.0, 2.0), 0.4, k)
    t = np.array([0.9, 1.7333])
    alone = Flight((0.0, 0.0, 1.0), (28.0, 3.0, 2.0), 0.4, k).positions(t[1:])
    assert np.array_equal(flight.positions(t)[1:], alone)
    assert np.array_equal(flight.positions(np.array([5.0, 1.7333]))[1:], alone)  # a longer grid: the same steps
    free = Flight((0.0, 0.0, 1.0), (28.0, 3.0, 2.0), 0.4)
    tau = np.linspace(-0.2, 2.0, 50)
    parabola = np.array([0.0, 0.0, 1.0]) + (tau - 0.4)[:, None] * np.array([28.0, 3.0, 2.0])
    parabola[:, 2] -= 0.5 * 9.81 * (tau - 0.4) ** 2
    assert np.allclose(free.positions(tau), parabola, atol=1e-12)
    assert np.allclose(Flight((0.0, 0.0, 1.0), (28.0, 3.0, 2.0), 0.4, 1e-12).positions(tau), parabola, atol=1e-6)
    # Drag only slows it: 1.33 s after the start it is metres short of the parabola's distance
    assert flight.positions(t)[1, 0] < free.positions(t)[1, 0] - 5.0


def test_a_scene_files_flight_takes_a_drag_and_refuses_a_negative_one(tmp_path):
    scene = tmp_path / "pitch.yaml"
    scene.write_text("balls:\n  - trajectory: {type: flight, start: [0, 3, 0], velocity: [8, 0, 2], drag: 0.0195}\n")
    assert load_scene_yaml(scene).balls[0].trajectory.drag == 0.0195
    scene.write_text("balls:\n  - trajectory: {type: flight, start: [0, 3, 0], velocity: [8, 0, 2], drag: -1}\n")
    with pytest.raises(StereotrackError, match=r"balls\[0\].trajectory.*drag must be 0-10"):
        load_scene_yaml(scene)
