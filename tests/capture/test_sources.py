import time

import cv2
import numpy as np
import pytest

from stereotrack.capture.cameras import CameraPairSource, Pairer
from stereotrack.capture.devices import CaptureSettings, SimulatedCamera, VideoFileCamera, open_device
from stereotrack.capture.replay import RecordingSource, paced
from stereotrack.errors import StereotrackError
from stereotrack.frames import FramePair
from stereotrack.recording import RecordingWriter, decode_jpeg

FPS = 30.0
PERIOD = 1.0 / FPS
SMALL = CaptureSettings(width=160, height=120, fps=FPS)


def camera_stream(rng, n, offset=0.0, jitter=0.002, drop=0.0, fps=FPS):
    """(frame index, timestamp) of one simulated camera: jittered, with lost frames."""
    k = np.arange(n)
    t = offset + k / fps + np.clip(rng.normal(0, jitter, n), -0.005, 0.005)
    keep = rng.random(n) >= drop
    return k[keep], t[keep]


def run_pairer(streams, rng, tolerance=0.5 * PERIOD, max_pending=8, max_delay=0.05):
    """Push the frames in order of arrival: capture time plus a random delivery delay (per camera in order)."""
    pairer = Pairer(len(streams), tolerance, max_pending)
    arrivals = []
    for cam, (ks, ts) in enumerate(streams):
        arrive = np.maximum.accumulate(ts + rng.uniform(0, max_delay, len(ts)))  # a camera delivers in order
        arrivals += [(a, cam, int(k), t) for a, k, t in zip(arrive, ks, ts)]
    pairs = []
    for _, cam, k, t in sorted(arrivals):
        pairs += pairer.push(cam, t, k)  # the "image" is the frame index, to check who was paired
    return pairer, pairs


# --------------------------------------------------------------------------- pairing logic


def test_pairs_every_common_frame_of_a_60s_session_with_jitter_and_drops():
    rng = np.random.default_rng(0)
    n = int(60 * FPS)
    s0 = camera_stream(rng, n, offset=0.0, drop=0.02)
    s1 = camera_stream(rng, n, offset=0.003, drop=0.02)
    pairer, pairs = run_pairer([s0, s1], rng)
    common = np.intersect1d(s0[0], s1[0])
    # each pair holds the same frame of both cameras: exactly the frames both delivered
    assert [p[1] for p in pairs] == [(int(k), int(k)) for k in common]
    spreads = np.array([max(ts) - min(ts) for ts, _ in pairs])
    assert spreads.max() <= 0.5 * PERIOD
    assert pairer.unpaired == [len(s0[0]) - len(common), len(s1[0]) - len(common)]
    assert len(common) > 0.95 * n


def test_three_cameras_and_interleaving_do_not_change_the_pairs():
    rng = np.random.default_rng(1)
    streams = [camera_stream(rng, 300, offset=o, drop=0.05) for o in (0.0, 0.004, -0.002)]
    common = set(streams[0][0]) & set(streams[1][0]) & set(streams[2][0])
    results = [run_pairer(streams, np.random.default_rng(seed))[1] for seed in (2, 3)]
    for pairs in results:
        assert [p[1] for p in pairs] == [(k, k, k) for k in sorted(common)]


def test_a_stalled_camera_is_never_paired_with_a_stale_frame():
    rng = np.random.default_rng(4)
    s0 = camera_stream(rng, 120)
    k1, t1 = camera_stream(rng, 120)
    gap = (k1 >= 30) & (k1 < 60)  # camera 1 delivers nothing for one second
    pairer, pairs = run_pairer([s0, (k1[~gap], t1[~gap])], rng, max_pending=4)
    assert all(a == b for _, (a, b) in pairs)
    assert {a for _, (a, _) in pairs} == set(range(120)) - set(range(30, 60))
    assert pairer.unpaired == [30, 0]
    # while camera 1 was silent, at most max_pending frames of camera 0 waited
    assert all(len(q) <= 4 for q in pairer._pending)


def test_different_rates_pair_only_within_tolerance_and_use_each_frame_once():
    rng = np.random.default_rng(5)
    s0 = camera_stream(rng, 300, fps=30.0)
    s1 = camera_stream(rng, 200, fps=20.0, offset=0.001)
    pairer, pairs = run_pairer([s0, s1], rng)
    assert pairs and all(max(ts) - min(ts) <= 0.5 * PERIOD for ts, _ in pairs)
    used0 = [a for _, (a, _) in pairs]
    used1 = [b for _, (_, b) in pairs]
    assert len(set(used0)) == len(used0) and len(set(used1)) == len(used1)
    # every frame is either paired or counted as unpaired
    assert len(pairs) + pairer.unpaired[0] + len(pairer._pending[0]) == 300
    assert len(pairs) + pairer.unpaired[1] + len(pairer._pending[1]) == 200
    # every 0.1 s both cameras take a frame at the same instant: those always pair
    assert {(3 * j, 2 * j) for j in range(100)} <= {p[1] for p in pairs}
    assert pairer.unpaired[0] >= 100  # the other 30 fps frames lie about one tolerance from a partner: many stay unpaired


def test_pairer_refuses_time_going_backwards():
    p = Pairer(2, 0.01)
    p.push(0, 1.0, None)
    with pytest.raises(ValueError):
        p.push(0, 0.5, None)


# --------------------------------------------------------------------------- replay pacing


class FakeClock:
    def __init__(self):
        self.now = 100.0

    def __call__(self):
        return self.now

    def sleep(self, s):
        self.now += s


def pairs_of(times):
    return [FramePair(i, (), (t, t)) for i, t in enumerate(times)]


def test_paced_replay_sleeps_to_the_recorded_timestamps():
    times = np.array([0.0, 0.033, 0.070, 0.100, 0.300])
    clock = FakeClock()
    seen = []
    for _pair in paced(pairs_of(times), np.column_stack([times, times]), clock=clock, sleep=clock.sleep):
        seen.append(clock.now - 100.0)
    np.testing.assert_allclose(seen, times, atol=1e-12)


def test_paced_replay_skips_what_a_slow_consumer_missed():
    times = np.arange(30) * PERIOD
    clock = FakeClock()
    skipped, yielded = [], []
    for pair in paced(
        pairs_of(times), np.column_stack([times, times]), clock=clock, sleep=clock.sleep, on_skip=lambda p: skipped.append(p.index)
    ):
        yielded.append(pair.index)
        clock.now += 0.1  # the consumer needs 3 frame periods per pair
    assert len(yielded) + len(skipped) == 30
    assert 7 <= len(yielded) <= 12  # about one pair in three: it keeps up with the present
    assert np.diff(yielded).max() <= 4
    clock = FakeClock()
    slow_all = []
    for pair in paced(pairs_of(times), np.column_stack([times, times]), skip_late=False, clock=clock, sleep=clock.sleep):
        slow_all.append(pair.index)
        clock.now += 0.1
    assert slow_all == list(range(30))


def write_recording(folder, n=6, size=(64, 48)):
    rng = np.random.default_rng(7)
    frames = [[rng.integers(0, 256, (size[1], size[0], 3), dtype=np.uint8) for _ in range(2)] for _ in range(n)]
    with RecordingWriter(folder, ["cam0", "cam1"], size, FPS, codec="ffv1") as w:
        for i, imgs in enumerate(frames):
            w.write(imgs, [i * PERIOD, i * PERIOD + 0.001])
    return frames


def test_recording_source_replays_every_frame_as_fast_as_possible_or_paced(tmp_path):
    frames = write_recording(tmp_path / "rec")
    src = RecordingSource(tmp_path / "rec")
    assert (src.n_frames, src.fps, src.camera_names, src.rig) == (6, FPS, ("cam0", "cam1"), None)
    got = list(src)
    assert [p.index for p in got] == list(range(6))
    for pair, imgs in zip(got, frames):
        assert all(np.array_equal(a, b) for a, b in zip(pair.images, imgs))  # FFV1 is lossless
    assert src.stats.pairs == 6
    src.close()
    realtime = RecordingSource(tmp_path / "rec", realtime=True)
    start = time.monotonic()
    assert [p.index for p in realtime] == list(range(6))
    assert time.monotonic() - start >= 5 * PERIOD * 0.9  # it waited for the recorded pace


# --------------------------------------------------------------------------- devices


def test_simulated_camera_behaves_like_a_videocapture():
    cam = SimulatedCamera("dots", view=0, jitter=0.0, drop=0.5, seed=3, width=160, height=120, fps=60.0)
    assert cam.isOpened() and cam.get(cv2.CAP_PROP_FRAME_WIDTH) == 160
    assert cam.set(cv2.CAP_PROP_EXPOSURE, 50) and cam.get(cv2.CAP_PROP_EXPOSURE) == 50
    ok, img = cam.read()
    assert ok and img.shape == (120, 160, 3) and img.dtype == np.uint8
    grabbed = []
    for _ in range(20):
        assert cam.grab()
        grabbed.append(cam._grabbed)
    lost = grabbed[-1] - grabbed[0] + 1 - len(grabbed)
    assert 8 <= lost <= 35  # about half the frames are lost in the device (seeded)
    cam.release()
    assert not cam.isOpened() and not cam.grab()


def test_simulated_views_of_one_scene_are_different_images():
    a = open_device("sim:pendulum4,jitter=0,drop=0", 0, SMALL)
    b = open_device("sim:pendulum4,jitter=0,drop=0", 1, SMALL)
    ok_a, jpeg_a = a.read()
    ok_b, jpeg_b = b.read()
    # asked for MJPG (the default), they send JPEGs as webcams do: the raw buffer, decoded by the consumer
    assert ok_a and ok_b and jpeg_a.shape[0] == 1 and bytes(jpeg_a[0, :2]) == b"\xff\xd8"
    img_a, img_b = decode_jpeg(jpeg_a), decode_jpeg(jpeg_b)
    assert img_a.shape == img_b.shape == (120, 160, 3)
    assert np.abs(img_a.astype(int) - img_b.astype(int)).mean() > 1.0
    a.release()
    b.release()


@pytest.mark.parametrize(
    "spec, words",
    [
        ("sim:", "name a scene"),
        ("sim:dots,speed=3", "unknown option 'speed'"),
        ("sim:dots,drop=x", "needs a float"),
        ("sim:dots,drop=1.5", "probability"),
        ("no/such/video.mkv", "not a device index"),
    ],
)
def test_bad_device_specs_are_refused_with_a_clear_message(spec, words):
    with pytest.raises(StereotrackError, match=words):
        open_device(spec)


# --------------------------------------------------------------------------- live pair source (threads)


def test_live_source_pairs_simulated_cameras_within_half_a_period():
    with CameraPairSource(["sim:dots,drop=0.05", "sim:dots,drop=0.05"], settings=SMALL, queue_size=30) as src:
        assert src.n_frames is None and src.camera_names == ("cam0", "cam1") and src.tolerance == pytest.approx(0.5 * PERIOD)
        pairs = []
        for pair in src:
            pairs.append(pair)
            if len(pairs) == 45:
                break
        stats = src.stats
    assert [p.index for p in pairs] == list(range(45))
    assert all(max(p.timestamps) - min(p.timestamps) <= 0.5 * PERIOD for p in pairs)
    # the two views show the same scene frame (dots draw the frame number; compare the pictures)
    assert all(p.images[0].shape == (120, 160, 3) for p in pairs)
    assert stats.pairs == 45 and stats.pairs_dropped == 0
    assert all(c.frames >= 45 for c in stats.cameras)
    assert sum(c.unpaired for c in stats.cameras) >= 1  # 5% lost frames leave their partners unpaired


class LateSimulatedView(SimulatedCamera):
    """A simulated view whose thread first grabs 0.6 periods late; each image holds its scene frame's number."""

    def __init__(self, late: float, **kwargs):
        super().__init__("dots", jitter=0.0, drop=0.0, width=32, height=24, fps=FPS, **kwargs)
        self.late, self.grabs = late, 0
        self.prepare()  # as open_device does: the scene is built before the clock starts

    def grab(self) -> bool:
        self.grabs += 1
        if self.grabs == 1:
            time.sleep(self.late)
        return super().grab()

    def retrieve(self):
        ok, _ = super().retrieve()
        return ok, np.full((24, 32, 3), self._grabbed % 256, np.uint8)


def test_simulated_views_share_one_clock_so_a_pair_is_one_moment_of_the_scene():
    """Started on their own clocks, a view 0.6 periods late would pair its frame k with frame k+1 of the other."""
    cams = [LateSimulatedView(0.0, view=0), LateSimulatedView(0.6 * PERIOD, view=1)]
    with CameraPairSource(cams, settings=CaptureSettings(None, None, None, None), queue_size=60) as src:
        pairs = []
        for pair in src:
            pairs.append(pair)
            if len(pairs) == 30:
                break
    indices = [tuple(int(img[0, 0, 0]) for img in p.images) for p in pairs]
    assert len(indices) == 30 and all(a == b for a, b in indices), indices


def test_slow_consumer_drops_the_oldest_pairs_and_stays_in_the_present():
    with CameraPairSource(["sim:dots,drop=0", "sim:dots,drop=0"], settings=SMALL, queue_size=2) as src:
        received = []
        for pair in src:
            received.append((time.monotonic(), pair))
            time.sleep(0.15)  # a consumer at under 7 pairs/s against 30 pairs/s
            if len(received) == 10:
                break
        stats = src.stats
    assert stats.pairs == 10 and stats.pairs_dropped >= 20
    assert all(c.dropped == stats.pairs_dropped for c in stats.cameras)
    # the pairs handed out keep up with the clock: no backlog builds up
    lag = [now - p.time for now, p in received]
    assert max(lag[5:]) < 0.15 + 3 * PERIOD
    ages = np.diff([p.time for _, p in received])
    assert ages.min() >= 3 * PERIOD - 0.01  # consecutive pairs jump over the dropped ones (less the frames' 2 ms jitter)


def test_a_camera_that_hangs_ends_iteration_with_a_clear_error():
    # the views share the source's clock: frames due before a starved thread first runs are skipped, so leave 1 s
    with CameraPairSource(["sim:dots,drop=0", "sim:dots,drop=0,stop=1"], settings=SMALL, stall_timeout=0.5) as src:
        n = 0
        with pytest.raises(StereotrackError, match=r"camera cam1 \(sim:dots,drop=0,stop=1\) delivered no frame for 0.5 s"):
            for _ in src:
                n += 1
        assert 1 <= n <= 31  # 30 frames before the hang on a quiet machine; a starved one skips some


def test_video_files_play_at_their_rate_and_end_the_source(tmp_path):
    path = tmp_path / "clip.mkv"
    w = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"FFV1"), FPS, (64, 48))
    for i in range(8):
        w.write(np.full((48, 64, 3), 20 * i, np.uint8))
    w.release()
    assert VideoFileCamera(path).get(cv2.CAP_PROP_FPS) == pytest.approx(FPS)
    with CameraPairSource([str(path), str(path)], settings=CaptureSettings(None, None, None, None)) as src:
        pairs = list(src)
    assert 6 <= len(pairs) <= 8
    for p in pairs:
        assert p.images[0].shape == (48, 64, 3)
        assert max(p.timestamps) - min(p.timestamps) <= 0.5 * PERIOD
    assert pairs[-1].time - pairs[0].time >= (len(pairs) - 1) * PERIOD * 0.8  # delivered at the file's rate


class StarvedFile(VideoFileCamera):
    """A video file camera whose thread gets no CPU for a while before some grabs (a host loaded many times over)."""

    def __init__(self, path, stalls: dict[int, float]):
        super().__init__(path)
        self.stalls, self.grabs = stalls, 0

    def grab(self) -> bool:
        self.grabs += 1
        time.sleep(self.stalls.get(self.grabs, 0.0))
        return super().grab()


def test_video_files_pair_only_frames_of_one_index_however_starved_their_threads(tmp_path):
    """One thread starting 0.1 s late (3 periods) and one starved for 1.5 s mid-file: frames are skipped,
    never paired with another moment of the other file."""
    path = tmp_path / "clip.mkv"
    w = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"FFV1"), 2 * FPS, (32, 24))
    for i in range(150):
        w.write(np.full((24, 32, 3), i, np.uint8))  # the frame's index in every pixel
    w.release()
    cams = [StarvedFile(path, {12: 1.5}), StarvedFile(path, {1: 0.1})]
    with CameraPairSource(cams, settings=CaptureSettings(None, None, None, None), queue_size=200) as src:
        pairs = list(src)
    indices = [tuple(int(img[0, 0, 0]) for img in p.images) for p in pairs]
    assert len(pairs) >= 40, indices
    assert all(a == b for a, b in indices), indices
    assert sum(c.skipped for c in cams) > 0  # the stalls were felt


def test_fewer_than_two_cameras_or_a_rig_of_another_size_is_refused():
    with pytest.raises(StereotrackError, match="at least two cameras"):
        CameraPairSource(["sim:dots"])


def test_a_simulated_camera_keeps_a_few_frames_however_often_its_scene_loops():
    """The scene (pendulum4: 300 frames) loops under a camera that runs for ever: memory must stay flat."""
    from stereotrack.capture.devices import _SharedScene

    scene = _SharedScene("pendulum4", 64, 48, 30.0)
    for k in range(2 * scene.n_frames + 20):
        assert scene.frame(k, 0).shape == scene.frame(k, 1).shape == (48, 64, 3)
    assert len(scene._cache) <= _SharedScene.KEEP  # was: every frame of the scene after the first loop


def test_every_source_has_what_the_source_protocol_promises(tmp_path):
    from stereotrack.frames import Source

    folder = tmp_path / "rec"
    with RecordingWriter(folder, ["cam0", "cam1"], (64, 48), 30.0) as w:
        for i in range(3):
            w.write([np.zeros((48, 64, 3), np.uint8)] * 2, [i / 30.0] * 2)
    replay = RecordingSource(folder)
    live = CameraPairSource(["sim:dots", "sim:dots"], settings=CaptureSettings(width=64, height=48, fps=30.0))
    try:
        for source in (replay, live):
            for name in [n for n in Source.__annotations__] + ["stats", "close", "__iter__"]:
                assert hasattr(source, name), (type(source).__name__, name)
        assert replay.n_frames == 3 and len(list(replay)) == 3 and live.n_frames is None
    finally:
        replay.close()
        live.close()
