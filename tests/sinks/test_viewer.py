"""The rerun sink, checked by reading the saved .rrd back with rerun's own tools.

Scenes here are small: a two-camera rig, three balls of two colours drawn as
discs on grey images, and FrameResults built from them (particles around the
balls, one object and one confirmed track per ball).
"""

import argparse
import os
import re
import shutil
import signal
import subprocess
import sys
import textwrap
import time
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np
import pytest

from stereotrack.camera import Camera, Rig, intrinsics_from_fov, look_at
from stereotrack.config import Config, Target
from stereotrack.errors import StereotrackError
from stereotrack.frames import FramePair
from stereotrack.results import FrameResult, Object3D, ParticleSet, TrackEstimate
from stereotrack.sinks.viewer.flags import add_viz_arguments, make_viz_sink
from stereotrack.sinks.viewer.process import rerun_executable
from stereotrack.sinks.viewer.sink import RerunSink, VizOutputs, VizSettings
from stereotrack.sinks.viewer.style import target_colour

RERUN = rerun_executable()
W, H = 320, 240
TARGETS = (
    Target("pink", (140, 60, 50), (175, 255, 255), radius=0.04),
    Target("green", (40, 80, 50), (80, 255, 255), radius=0.03),
)
BALL_TARGET = ("pink", "green", "pink")


def make_rig() -> Rig:
    K = intrinsics_from_fov(W, H, 70.0)
    cams = []
    for i, eye in enumerate([(-0.2, -0.1, 0.0), (0.25, -0.15, 0.05)]):
        R, t = look_at(eye, (0.0, 0.0, 1.6))
        cams.append(Camera(f"cam{i}", (W, H), K, np.zeros(5), R, t))
    return Rig(tuple(cams))


def ball_positions(frame: int) -> np.ndarray:
    a = 0.15 * frame + np.array([0.0, 2.1, 4.2])
    return np.column_stack([0.3 * np.cos(a), 0.2 * np.sin(a), 1.6 + 0.2 * np.sin(a + 1.0)])


def render(rig: Rig, balls: np.ndarray) -> tuple[np.ndarray, ...]:
    images = []
    for cam in rig.cameras:
        img = np.full((H, W, 3), 90, np.uint8)
        uv, _ = cam.project(balls)
        depth = cam.depth(balls)
        for (u, v), z, name in zip(uv, depth, BALL_TARGET):
            target = next(t for t in TARGETS if t.name == name)
            r = max(3, int(round(cam.K[0, 0] * target.radius / z)))
            cv2.circle(img, (int(round(u)), int(round(v))), r, tuple(int(c) for c in target_colour(target)[::-1]), -1)
        images.append(img)
    return tuple(images)


def make_result(rig: Rig, frame: int, rng: np.random.Generator, n_particles: int = 600) -> FrameResult:
    balls = ball_positions(frame)
    particles, objects, tracks = [], [], []
    for target in TARGETS:
        mine = [i for i, name in enumerate(BALL_TARGET) if name == target.name]
        pos = np.concatenate([balls[i] + rng.normal(0, 0.01, (n_particles // len(mine), 3)) for i in mine])
        labels = np.repeat(np.arange(len(mine)), n_particles // len(mine))
        labels[::10] = -1  # a few unclustered particles
        abductive = rng.random(len(pos)) < 0.2
        particles.append(ParticleSet(target.name, pos, np.full(len(pos), 1 / len(pos)), abductive, labels))
        for _k, i in enumerate(mine):
            est = balls[i] + rng.normal(0, 0.002, 3)
            objects.append(Object3D(target.name, est, np.eye(3) * 1e-4, 1 / len(mine), n_particles // len(mine)))
            cov = np.diag([4e-4, 1e-4, 2.5e-5])
            tracks.append(TrackEstimate(i + 1, target.name, est, np.zeros(3), cov, "confirmed", n_particles // len(mine), reported=True))
    tracks.sort(key=lambda t: t.track_id)  # track i + 1 is ball i
    tracks.append(TrackEstimate(9, "pink", np.array([0.0, 0.0, 2.0]), np.zeros(3), np.eye(3) * 1e-3, "tentative"))
    pair = FramePair(frame, render(rig, balls), (frame / 30.0, frame / 30.0 + 0.001))
    masks = {(t.name, c.name): np.zeros((H, W), np.uint8) for t in TARGETS for c in rig.cameras}
    return FrameResult(
        pair,
        tuple(particles),
        tuple(objects),
        tuple(tracks),
        masks=masks,
        timings_ms={"masks": 1.5, "particles": 4.0, "clustering": 2.0},
        latency_s=0.02,
    )


def truth_for(frames) -> np.ndarray:
    rows = [[f, i + 1, *p] for f in frames for i, p in enumerate(ball_positions(f))]
    return np.array(rows, dtype=float)


def log_run(path: Path, n: int = 12, settings: VizSettings = VizSettings(), truth=None, seed: int = 0):
    rig, rng = make_rig(), np.random.default_rng(seed)
    config = Config(targets=TARGETS)
    results = [make_result(rig, f, rng) for f in range(n)]
    sink = RerunSink(rig, config, VizOutputs(rrd=path), settings, truth=truth)
    for r in results:
        sink.write(r)
    sink.close()
    return rig, results


def read_rrd(path: Path) -> dict[str, list[dict]]:
    """Every logged row by entity path: {'frame': index or None (static), 'Archetype:field': value}."""
    import rerun.chunk

    rows: dict[str, list[dict]] = {}
    for chunk in rerun.chunk.RrdReader(path).stream():
        batch = chunk.to_record_batch()
        cols = {name: batch.column(name).to_pylist() for name in batch.schema.names if ":" in name or name == "frame"}
        for i in range(batch.num_rows):
            row = {name: values[i] for name, values in cols.items()}
            row.setdefault("frame", None)
            rows.setdefault(chunk.entity_path.lstrip("/"), []).append(row)
    return rows


def frames_of(rows: list[dict]) -> list[int]:
    """The frames an entity was logged at (static rows, e.g. a fixed fill mode, left out)."""
    return [r["frame"] for r in rows if r["frame"] is not None]


def latest(rows: list[dict], component: str, frame: int):
    """The component's value at a frame (static rows count for every frame)."""
    found = [r[component] for r in rows if component in r and r[component] is not None and r["frame"] in (frame, None)]
    assert found, f"{component} not logged at frame {frame}"
    return found[-1]


# --------------------------------------------------------------------------- tests


@pytest.fixture(scope="module")
def run12(tmp_path_factory):
    path = tmp_path_factory.mktemp("viz") / "run.rrd"
    # max_particles above the 600 per target: every particle is in the file
    rig, results = log_run(path, settings=VizSettings(max_particles=1000), truth=truth_for(range(12)) + np.array([0, 0, 0.01, 0, 0]))
    return path, rig, results, read_rrd(path)


def test_rrd_verifies_and_holds_the_scene_entities(run12):
    path, rig, results, rows = run12
    out = subprocess.run([RERUN, "rrd", "verify", str(path)], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    expected = {
        "world",
        "world/particles",
        "world/particles/pink",
        "world/particles/green",
        "world/objects",
        "world/tracks",
        "world/tracks/covariance",
        "world/tracks/trails",
        "world/truth",
        "stats/counts/confirmed_tracks",
        "stats/counts/objects/pink",
        "stats/counts/particles/track_1",
        "stats/timing_ms/particles",
        "stats/rate/frames_per_s",
        "stats/rate/latency_ms",
        "stats/error_mm/mean",
    }
    for cam in rig.names:
        expected |= {f"world/cameras/{cam}{s}" for s in ("", "/image", "/mask", "/objects", "/tracks")}
    assert expected <= set(rows), sorted(expected - set(rows))
    # Two timelines: frame numbers and capture time in seconds since the first frame.
    out = subprocess.run(
        [RERUN, "rrd", "print", "-vvv", "--entity", "/stats/counts/confirmed_tracks", str(path)], capture_output=True, text=True, timeout=60
    )
    assert "capture_time" in out.stdout and "index_name: frame" in out.stdout and "PT0.1S" in out.stdout  # frame 3 at 3/30 s
    import rerun.chunk

    assert rerun.chunk.RrdReader(path).blueprints(), "the default blueprint is saved in the file"


def test_track_positions_in_file_equal_the_results(run12):
    _, _, results, rows = run12
    logged = [r for r in rows["world/tracks"] if r["frame"] is not None]
    assert [r["frame"] for r in logged] == list(range(12))
    for r, res in zip(logged, results):
        want = np.array([t.position for t in res.confirmed])
        assert len(res.confirmed) == 3 and len(res.tracks) == 4  # the tentative track is not drawn
        np.testing.assert_allclose(np.array(r["Ellipsoids3D:centers"]), want, atol=1e-6)  # float32 in the file
        assert r["Ellipsoids3D:labels"] == [f"#{t.track_id} {t.target}" for t in res.confirmed]
        radii = np.array(r["Ellipsoids3D:half_sizes"])[:, 0]
        np.testing.assert_allclose(radii, [0.04, 0.03, 0.04], rtol=1e-6)


def test_a_world_point_projects_to_where_it_was_drawn_in_2d(run12):
    """Camera-from-world transform + pinhole read back from the file put the 3D track on its 2D mark and on the ball."""
    _, rig, results, rows = run12
    for cam in rig.names:
        ent = rows[f"world/cameras/{cam}"]
        assert latest(ent, "Transform3D:relation", 0) == [2]  # ChildFromParent: world -> camera
        R = np.array(latest(ent, "Transform3D:mat3x3", 0)[0]).reshape(3, 3).T  # stored column-major
        t = np.array(latest(ent, "Transform3D:translation", 0)[0])
        K = np.array(latest(ent, "Pinhole:image_from_camera", 0)[0]).reshape(3, 3).T
        assert latest(ent, "Pinhole:resolution", 0) == [[W, H]]
        for frame in (0, 5, 11):
            X = np.array(latest(rows["world/tracks"], "Ellipsoids3D:centers", frame))
            x = (X @ R.T + t) @ K.T
            uv = x[:, :2] / x[:, 2:]
            drawn = np.array(latest(rows[f"world/cameras/{cam}/tracks"], "Points2D:positions", frame))
            assert latest(rows[f"world/cameras/{cam}/tracks"], "Points2D:labels", frame) == ["#1", "#2", "#3"]
            np.testing.assert_allclose(uv, drawn, atol=0.01)
            # ... and the logged image, drawn over the camera's pixels by its scale, has the ball's colour at that pixel.
            blob = latest(rows[f"world/cameras/{cam}/image"], "EncodedImage:blob", frame)[0]
            img = cv2.imdecode(np.frombuffer(bytes(blob), np.uint8), cv2.IMREAD_COLOR)
            assert img.shape == (H // 2, W // 2, 3)  # the default image scale, 0.5
            assert latest(rows[f"world/cameras/{cam}/image"], "Transform3D:scale", frame) == [[2.0, 2.0, 1.0]]
            colours = {t.name: target_colour(t)[::-1].astype(int) for t in TARGETS} | {"background": np.array([90, 90, 90])}
            for (u, v), name in zip(uv, BALL_TARGET):  # the balls are 2-3 pixels wide there: the nearest colour names the ball
                pixel = img[int(round(v)) // 2, int(round(u)) // 2].astype(int)
                assert min(colours, key=lambda c: np.abs(pixel - colours[c]).sum()) == name, (pixel, name)


def test_particles_keep_their_classes_and_cluster_colours(run12):
    _, _, results, rows = run12
    ctx = latest(rows["world/particles"], "AnnotationContext:context", 0)[0]
    assert {c["class_id"]: c["class_description"]["info"]["label"] for c in ctx} == {0: "sequential", 1: "abductive"}
    r = latest(rows["world/particles/pink"], "Points3D:class_ids", 4)
    ps = results[4].particles[0]
    assert len(r) == 600 and sum(r) == int(ps.abductive.sum())
    colours = np.array(latest(rows["world/particles/pink"], "Points3D:colors", 4), dtype=np.uint32)
    # Sequential particles of the two pink clusters have two distinct colours, unclustered ones a third.
    seq = ~ps.abductive
    assert len(np.unique(colours[seq])) == 3
    assert len(np.unique(colours[seq & (ps.labels == 0)])) == 1


def test_truth_points_and_error_series(run12):
    _, _, _, rows = run12
    assert len(latest(rows["world/truth"], "Points3D:positions", 3)) == 3
    # Truth was shifted 10 mm along x; the estimates carry ~2 mm noise per axis.
    errors = [r["Scalars:scalars"][0] for r in rows["stats/error_mm/mean"]]
    assert len(errors) == 12 and 7 < np.mean(errors) < 13


def test_covariance_and_trails(run12):
    _, _, _, rows = run12
    halves = np.array(latest(rows["world/tracks/covariance"], "Ellipsoids3D:half_sizes", 6))
    np.testing.assert_allclose(np.sort(halves, axis=1), [[0.01, 0.02, 0.04]] * 3, rtol=1e-5)  # 2 sigma
    strips = latest(rows["world/tracks/trails"], "LineStrips3D:strips", 11)
    colours = np.array(latest(rows["world/tracks/trails"], "LineStrips3D:colors", 11), dtype=np.uint32)
    assert len(strips) == 3 * 11  # 12 frames within 2 s: 11 steps per confirmed track
    alpha = colours & 0xFF
    assert alpha[10] > alpha[0]  # newer steps are more opaque


def test_decimation_and_particle_limit(tmp_path):
    path = tmp_path / "thin.rrd"
    log_run(path, n=10, settings=VizSettings(every=3, max_particles=100, images=False, trail_seconds=0.5))
    rows = read_rrd(path)
    assert frames_of(rows["world/tracks"]) == [0, 3, 6, 9]
    assert all(len(r["Points3D:positions"]) == 100 for r in rows["world/particles/green"])
    assert "world/cameras/cam0/image" not in rows and "world/cameras/cam0/tracks" in rows
    # Trails follow every frame, not only logged ones: 0.5 s at 30 frames/s.
    strips = latest(rows["world/tracks/trails"], "LineStrips3D:strips", 9)
    assert len(strips) == 3 * 9


def test_raw_images_masks_and_rays(tmp_path):
    from stereotrack.results import Rays

    rig = make_rig()
    result = make_result(rig, 0, np.random.default_rng(3))
    result.masks[("green", "cam1")][10:20, 30:40] = 1
    cam = rig["cam1"]
    o, d = cam.rays(np.array([[100.0, 120.0], [200.0, 80.0]]))
    result = FrameResult(
        result.frame, result.particles, result.objects, result.tracks, (Rays("green", "cam1", o, d, np.zeros((2, 2))),), result.masks
    )
    kept = np.zeros((H // 2, W // 2), np.uint8)  # evidence built on a half-size grid (evidence_scale 2) ...
    kept[5:8, 15:20] = 1  # ... where the observation model kept 60 of the range's 100 pixels
    result = replace(result, evidence={("green", "cam1"): kept})
    path = tmp_path / "raw.rrd"
    with RerunSink(
        rig, Config(targets=TARGETS), VizOutputs(rrd=path), VizSettings(jpeg_quality=0, image_scale=1.0, masks=True, rays=True)
    ) as sink:
        sink.write(result)
    rows = read_rrd(path)
    fmt = latest(rows["world/cameras/cam0/image"], "Image:format", 0)[0]
    assert fmt["width"] == W and fmt["height"] == H
    assert all("Transform3D:scale" not in r for r in rows["world/cameras/cam0/image"])  # full size: drawn as is
    mask = latest(rows["world/cameras/cam1/mask"], "SegmentationImage:buffer", 0)[0]
    assert np.count_nonzero(mask) == 100 and set(mask) == {0, 2}  # class 2 = the second target, green
    after = latest(rows["world/cameras/cam1/evidence"], "SegmentationImage:buffer", 0)[0]
    assert len(after) == W * H and np.count_nonzero(after) == 60 and set(after) == {0, 2}  # shown at the camera's pixels
    strips = np.array(latest(rows["world/rays/green/cam1"], "LineStrips3D:strips", 0))
    assert strips.shape == (2, 2, 3)
    np.testing.assert_allclose(strips[:, 0], cam.centre + 0.2 * d, atol=1e-5)  # from d_min ...
    np.testing.assert_allclose(strips[:, 1], cam.centre + 5.0 * d, atol=1e-5)  # ... to d_max


def test_flags_and_no_viewer_means_no_rerun(tmp_path):
    parser = argparse.ArgumentParser()
    add_viz_arguments(parser)
    assert make_viz_sink(parser.parse_args([]), make_rig(), Config(targets=TARGETS)) is None
    args = parser.parse_args(["--rrd", str(tmp_path / "a" / "b.rrd"), "--viz-every", "2", "--no-images", "--viz-image-scale", "0.75"])
    sink = make_viz_sink(args, make_rig(), Config(targets=TARGETS))
    assert sink.settings.every == 2 and not sink.settings.images and sink.settings.image_scale == 0.75
    sink.close()
    assert (tmp_path / "a" / "b.rrd").is_file()
    with pytest.raises(StereotrackError, match="--connect"):
        make_viz_sink(parser.parse_args(["--connect", "http://x/y"]), make_rig(), Config())
    with pytest.raises(StereotrackError, match="is a folder"):
        make_viz_sink(parser.parse_args(["--rrd", str(tmp_path)]), make_rig(), Config())
    for bad in (["--viz-every", "0"], ["--viz-image-scale", "0"], ["--viz-image-scale", "1.5"]):
        with pytest.raises(SystemExit):
            parser.parse_args(bad)
    # Without a viewer flag nothing imports rerun.
    code = "import sys, stereotrack.sinks.viewer, stereotrack.results; assert 'rerun' not in sys.modules, 'rerun imported'"
    subprocess.run([sys.executable, "-c", code], check=True, timeout=60)


def _ctrl_c_enabled() -> None:
    """In a child about to run: Ctrl-C (SIGINT) at its default, even when this test run inherited it
    ignored (a job started in the background by a non-interactive shell ignores SIGINT)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


SCRIPT = textwrap.dedent(
    """
    import sys
    import numpy as np
    sys.path.insert(0, {tests!r})
    from test_viewer import make_rig, make_result, TARGETS
    from stereotrack.capture.signals import interrupt_in
    from stereotrack.config import Config
    from stereotrack.sinks.viewer import RerunSink, VizOutputs
    rig, rng = make_rig(), np.random.default_rng(0)
    sink = RerunSink(rig, Config(targets=TARGETS), VizOutputs(rrd={rrd!r}))
    try:
        frame = 0
        while True:
            sink.write(make_result(rig, frame, rng))
            print(frame, flush=True)
            frame += 1
    except BaseException as exc:  # Ctrl-C, or as a compiled kernel hands it on (capture/signals.interrupt_in)
        if interrupt_in(exc) is None:
            raise
        print("interrupted", flush=True)
    finally:
        sink.close()
    """
)


def test_ctrl_c_leaves_a_readable_rrd(tmp_path):
    rrd = tmp_path / "cut.rrd"
    script = tmp_path / "run.py"
    script.write_text(SCRIPT.format(tests=str(Path(__file__).parent), rrd=str(rrd)))
    proc = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE, text=True, preexec_fn=_ctrl_c_enabled)
    try:
        for line in proc.stdout:
            if line.strip() == "5":
                break
        proc.send_signal(signal.SIGINT)
        out, _ = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert "interrupted" in out and proc.returncode == 0
    verify = subprocess.run([RERUN, "rrd", "verify", str(rrd)], capture_output=True, text=True, timeout=60)
    assert verify.returncode == 0, verify.stderr  # footer included: close() ran
    frames = frames_of(read_rrd(rrd)["world/tracks"])
    assert frames[:6] == list(range(6))


def _free_ports(n):
    import socket

    socks = [socket.socket() for _ in range(n)]
    for s in socks:
        s.bind(("127.0.0.1", 0))
    ports = [s.getsockname()[1] for s in socks]
    for s in socks:
        s.close()
    return ports


def test_serve_hosts_a_web_viewer_on_localhost(tmp_path):
    import urllib.request

    grpc_port, web_port = _free_ports(2)
    rig = make_rig()
    sink = RerunSink(
        rig, Config(targets=TARGETS), VizOutputs(rrd=tmp_path / "s.rrd", serve=True, grpc_port=grpc_port, web_port=web_port, hold=False)
    )
    try:
        sink.write(make_result(rig, 0, np.random.default_rng(0)))
        html = urllib.request.urlopen(f"http://127.0.0.1:{web_port}/", timeout=10).read().decode()
        assert "rerun" in html.lower()
        assert f"127.0.0.1%3A{grpc_port}" in sink.web_url
        if shutil.which("ss"):  # iproute2: who listens where
            listening = subprocess.run(["ss", "-ltn"], capture_output=True, text=True).stdout
            assert f"127.0.0.1:{web_port}" in listening and f"0.0.0.0:{web_port}" not in listening
        server = sink._children[0]
        assert sink._batch_seconds == 0.25  # a watched run is sent in quarter seconds' batches
    finally:
        sink.close()
    assert server.poll() is not None  # the server child is stopped with the sink


# --------------------------------------------------------------------------- end to end through `stereotrack track`


def _cli(*args, **kw):
    return subprocess.run([sys.executable, "-m", "stereotrack", *args], capture_output=True, text=True, timeout=300, **kw)


@pytest.fixture(scope="module")
def small_recording(tmp_path_factory):
    folder = tmp_path_factory.mktemp("rec") / "pendulum"
    # 10 fps: played at its recorded pace (--realtime) it lasts 4 s, so even a loaded machine interrupts it midway.
    out = _cli(
        "synth", "pendulum4", "--frames", "40", "--fps", "10", "--width", "320", "--height", "240", "--out", str(folder), "--no-progress"
    )
    assert out.returncode == 0, out.stderr
    return folder


def test_track_command_rrd_matches_tracks_csv(small_recording, tmp_path):
    from stereotrack.sinks.tracks_csv import read_tracks

    rrd, csv = tmp_path / "t.rrd", tmp_path / "tracks.csv"
    out = _cli("track", str(small_recording), "--out", str(csv), "--rrd", str(rrd), "--quiet")
    assert out.returncode == 0, out.stderr
    assert f"rerun {rrd}" in out.stderr  # the command that opens it
    tracks = read_tracks(csv)
    rows = read_rrd(rrd)
    logged = {r["frame"]: r for r in rows["world/tracks"] if r["frame"] is not None}
    assert sorted(logged) == list(range(40))
    assert len(tracks) > 40  # the pendulums are tracked
    for frame in range(40):
        mine = tracks[tracks[:, 0] == frame]
        r = logged[frame]
        ids = [int(label.split()[0][1:]) for label in r["Ellipsoids3D:labels"]]
        assert sorted(ids) == sorted(mine[:, 2].astype(int).tolist())
        by_id = dict(zip(ids, np.array(r["Ellipsoids3D:centers"]).reshape(-1, 3)))
        for row in mine:
            np.testing.assert_allclose(by_id[int(row[2])], row[3:6], atol=2e-5)  # csv keeps 5 decimals, the file float32
    assert "world/truth" in rows and "stats/error_mm/mean" in rows and "stats/timing_ms/step" in rows


def test_ctrl_c_on_track_command_leaves_a_readable_rrd(small_recording, tmp_path):
    rrd = tmp_path / "cut.rrd"
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "stereotrack",
            "track",
            str(small_recording),
            "--out",
            str(tmp_path / "t.csv"),
            "--rrd",
            str(rrd),
            "--realtime",
        ],
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=_ctrl_c_enabled,
    )
    try:
        for line in proc.stderr:  # non-terminal progress: a line every 10 %
            done = re.search(r"(\d+)/40 frames", line)
            if done and int(done.group(1)) >= 4:
                break
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130 and "interrupted" in err
    verify = subprocess.run([RERUN, "rrd", "verify", str(rrd)], capture_output=True, text=True, timeout=60)
    assert verify.returncode == 0, verify.stderr
    frames = frames_of(read_rrd(rrd)["world/tracks"])
    # --realtime skips frames it is late for, as a live camera would: increasing, not contiguous.
    assert 4 <= len(frames) and frames[-1] < 39 and frames == sorted(set(frames))


def test_served_viewer_dies_with_a_killed_tracker(tmp_path):
    grpc_port, web_port = _free_ports(2)
    script = tmp_path / "serve.py"
    script.write_text(
        textwrap.dedent(f"""
        import sys, time
        sys.path.insert(0, {str(Path(__file__).parent)!r})
        from test_viewer import make_rig, TARGETS
        from stereotrack.config import Config
        from stereotrack.sinks.viewer import RerunSink, VizOutputs
        sink = RerunSink(make_rig(), Config(targets=TARGETS), VizOutputs(serve=True, grpc_port={grpc_port}, web_port={web_port}))
        print(sink._children[0].pid, flush=True)
        time.sleep(120)
    """)
    )
    proc = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    try:
        child = int(proc.stdout.readline())
        assert Path(f"/proc/{child}").exists()
        proc.kill()  # SIGKILL: no finally, no close()
        proc.wait(10)
        deadline = time.monotonic() + 10
        while Path(f"/proc/{child}").exists() and Path(f"/proc/{child}/stat").read_text().split()[2] != "Z" and time.monotonic() < deadline:
            time.sleep(0.1)
        alive = Path(f"/proc/{child}").exists() and Path(f"/proc/{child}/stat").read_text().split()[2] != "Z"
        assert not alive, "the served viewer outlived the killed tracker"
    finally:
        if proc.poll() is None:
            proc.kill()
        if "child" in locals() and Path(f"/proc/{child}").exists():
            os.kill(child, signal.SIGKILL)  # do not leave a server behind when the test fails


def test_quaternions_match_scipy_for_all_rotations():
    from scipy.spatial.transform import Rotation

    from stereotrack.sinks.viewer.style import quaternions_xyzw

    rng = np.random.default_rng(5)
    R = Rotation.random(500, random_state=rng).as_matrix()
    flips = np.array([np.diag(d) for d in ([1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1])])  # 180 deg turns: w = 0
    R = np.concatenate([R, flips])
    q = quaternions_xyzw(R)
    ref = Rotation.from_matrix(R).as_quat()
    same = np.minimum(np.abs(q - ref).max(axis=1), np.abs(q + ref).max(axis=1))  # q and -q are one rotation
    assert same.max() < 1e-9


def test_live_sink_skips_frames_rather_than_hold_the_tracker(tmp_path, monkeypatch):
    rig, rng = make_rig(), np.random.default_rng(0)
    results = [make_result(rig, f, rng, n_particles=60) for f in range(30)]
    path = tmp_path / "live.rrd"
    sink = RerunSink(rig, Config(targets=TARGETS), VizOutputs(rrd=path), VizSettings(images=False, skip_when_behind=True))
    slow = sink._log_frame

    def slow_log(result, now, log, fps):  # a logger far slower than the frames come
        if log:
            time.sleep(0.05)
        slow(result, now, log, fps)

    monkeypatch.setattr(sink, "_log_frame", slow_log)
    start = time.perf_counter()
    for r in results:
        sink.write(r)
    held = time.perf_counter() - start
    sink.close()
    assert held < 0.5  # 30 frames at 50 ms of logging each would hold a waiting tracker 1.5 s
    frames = frames_of(read_rrd(path)["world/tracks"])
    assert 1 <= len(frames) < 30 and sink.skipped == 30 - len(frames)
    assert frames == sorted(frames) and frames[0] == 0


def test_batches_hold_the_same_as_frame_by_frame(tmp_path, monkeypatch):
    """Frames are sent as columns in batches; the file holds the same as if each frame were sent on its own."""
    import stereotrack.sinks.viewer.sink as viz  # the module whose constants the sink reads

    truth = truth_for(range(12))
    files = {}
    for batch in (1, 5, viz.FILE_BATCH):  # 5: batches split mid-run, trails handed out frames before they are sent
        monkeypatch.setattr(viz, "FILE_BATCH", batch)
        log_run(tmp_path / f"b{batch}.rrd", truth=truth)
        files[batch] = read_rrd(tmp_path / f"b{batch}.rrd")

    def by_frame(rows):
        return {
            path: {(r["frame"], name): value for r in entity for name, value in r.items() if name != "frame" and value is not None}
            for path, entity in rows.items()
            if not path.startswith("__") and path != "stats/rate/frames_per_s"  # recording properties and wall-clock rates differ
        }

    one = by_frame(files[1])
    assert len(one["world/tracks"]) > 12 and "world/cameras/cam0/image" in one
    for batch in (5, viz.FILE_BATCH):
        other = by_frame(files[batch])
        assert set(other) == set(one)
        for path in one:
            assert other[path].keys() == one[path].keys(), path
            for key, value in one[path].items():
                assert other[path][key] == value, (path, key)


def test_a_slow_camera_gets_its_frames_sent_without_a_full_batch(tmp_path, monkeypatch):
    import stereotrack.sinks.viewer.sink as viz  # the module whose constants the sink reads

    rig, rng = make_rig(), np.random.default_rng(0)
    monkeypatch.setattr(viz, "FILE_BATCH_SECONDS", viz.BATCH_SECONDS)  # as when a viewer watches (a file alone waits longer)
    sink = RerunSink(rig, Config(targets=TARGETS), VizOutputs(rrd=tmp_path / "slow.rrd"), VizSettings(images=False))
    sent, send = [], sink.columns.send
    monkeypatch.setattr(sink.columns, "send", lambda batch: (sent.append((time.monotonic(), [b.index for b in batch])), send(batch)))
    start = time.monotonic()
    for f in range(2):
        sink.write(make_result(rig, f, rng, n_particles=60))
    while not sent and time.monotonic() < start + 10:
        time.sleep(0.01)
    try:
        assert sent and sent[0][1] == [0, 1]
        assert sent[0][0] - start < viz.BATCH_SECONDS + 1.0  # the time limit, not a full batch, sent them
    finally:
        sink.close()
    assert frames_of(read_rrd(tmp_path / "slow.rrd")["world/tracks"]) == [0, 1]


def test_images_at_another_scale_cover_the_cameras_pixels(tmp_path):
    rig = make_rig()
    result = make_result(rig, 0, np.random.default_rng(3))
    path = tmp_path / "scaled.rrd"
    with RerunSink(rig, Config(targets=TARGETS), VizOutputs(rrd=path), VizSettings(image_scale=0.7)) as sink:
        sink.write(result)
    rows = read_rrd(path)
    blob = latest(rows["world/cameras/cam0/image"], "EncodedImage:blob", 0)[0]
    img = cv2.imdecode(np.frombuffer(bytes(blob), np.uint8), cv2.IMREAD_COLOR)
    assert img.shape == (168, 224, 3)  # 0.7 x 240, 0.7 x 320
    sx, sy, sz = latest(rows["world/cameras/cam0/image"], "Transform3D:scale", 0)[0]
    assert (sx * 224, sy * 168, sz) == pytest.approx((W, H, 1.0))  # the image spans the camera's W x H pixels


@pytest.mark.parametrize("batch_frames", [1, 90])
def test_a_track_confirmed_later_is_shown_from_its_first_hits_as_in_tracks_csv(tmp_path, batch_frames):
    """tracks.csv writes a track from its first hit (TrackEstimate.before, the frame it is confirmed); the viewer
    shows it there too, whether those frames wait in the batch (90) or were sent already (1: sent again)."""
    from stereotrack.sinks.viewer.sink import RerunSink, VizOutputs

    rig, rng = make_rig(), np.random.default_rng(5)
    results = [make_result(rig, f, rng) for f in range(8)]
    late = np.array([0.1, 0.0, 2.0])
    before = tuple((r.frame.time, late + 0.01 * k, np.eye(3) * 1e-4, 50) for k, r in enumerate(results[:3]))
    confirmed = TrackEstimate(20, "pink", late + 0.03, np.zeros(3), np.eye(3) * 1e-4, "confirmed", 50, reported=True, before=before)
    results[3] = replace(results[3], tracks=(*results[3].tracks, confirmed))
    sink = RerunSink(rig, Config(targets=TARGETS), VizOutputs(rrd=tmp_path / "h.rrd"))
    sink._batch_frames = batch_frames  # 1: every frame sent on its own, before the track is confirmed
    for r in results:
        sink.write(r)
    sink.close()
    rows = read_rrd(tmp_path / "h.rrd")
    for frame in range(8):
        labels = latest(rows["world/tracks"], "Ellipsoids3D:labels", frame)
        assert ("#20 pink" in labels) == (frame <= 3), (frame, labels)
        assert any(lb.startswith("#1 ") for lb in labels)  # the frame's own tracks stay
    centres = np.array(latest(rows["world/tracks"], "Ellipsoids3D:centers", 1)).reshape(-1, 3)
    assert np.min(np.linalg.norm(centres - (late + 0.01), axis=1)) < 1e-5


@pytest.mark.parametrize("every", [1, 2])
def test_a_tracks_smoothed_state_is_shown_at_its_frame_even_when_it_comes_with_a_frame_not_logged(tmp_path, every):
    """A track's smoothed state at an earlier frame (TrackEstimate.smoothed) takes that frame's place in the viewer as
    in tracks.csv, also when it comes with a frame the viewer does not log (--viz-every 2: half of them were lost)."""
    from stereotrack.sinks.viewer.sink import RerunSink, VizOutputs

    rig, rng = make_rig(), np.random.default_rng(5)
    results = [make_result(rig, f, rng) for f in range(8)]
    revised = np.array([0.3, -0.2, 2.5])
    tracks = tuple(
        replace(t, smoothed=((results[2].frame.time, revised, np.eye(3) * 1e-4, True),)) if t.track_id == 1 else t
        for t in results[5].tracks
    )
    results[5] = replace(results[5], tracks=tracks)
    sink = RerunSink(rig, Config(targets=TARGETS), VizOutputs(rrd=tmp_path / "s.rrd"), VizSettings(every=every))
    for r in results:
        sink.write(r)
    sink.close()
    rows = read_rrd(tmp_path / "s.rrd")
    centres = np.array(latest(rows["world/tracks"], "Ellipsoids3D:centers", 2)).reshape(-1, 3)
    assert np.min(np.linalg.norm(centres - revised, axis=1)) < 1e-5


@pytest.mark.parametrize("fill", [True, False])
def test_a_frame_a_track_coasted_through_unreported_is_shown_when_the_track_fills_it(tmp_path, fill):
    """A frame a track was not written at (it coasted unreported) shows it at its smoothed state once the track says to
    fill it (TrackEstimate.smoothed's last field: its ball met again since, placed sharply), as tracks.csv writes it;
    not otherwise."""
    from stereotrack.sinks.viewer.sink import RerunSink, VizOutputs

    rig, rng = make_rig(), np.random.default_rng(6)
    results = [make_result(rig, f, rng) for f in range(8)]
    results[2] = replace(results[2], tracks=tuple(t for t in results[2].tracks if t.track_id != 1))
    revised = np.array([0.3, -0.2, 2.5])
    tracks = tuple(
        replace(t, smoothed=((results[2].frame.time, revised, np.eye(3) * 1e-4, fill),)) if t.track_id == 1 else t
        for t in results[5].tracks
    )
    results[5] = replace(results[5], tracks=tracks)
    sink = RerunSink(rig, Config(targets=TARGETS), VizOutputs(rrd=tmp_path / "f.rrd"))
    for r in results:
        sink.write(r)
    sink.close()
    rows = read_rrd(tmp_path / "f.rrd")
    labels = latest(rows["world/tracks"], "Ellipsoids3D:labels", 2)
    assert any(lb.startswith("#1 ") for lb in labels) == fill, labels
    if fill:
        centres = np.array(latest(rows["world/tracks"], "Ellipsoids3D:centers", 2)).reshape(-1, 3)
        assert np.min(np.linalg.norm(centres - revised, axis=1)) < 1e-5
