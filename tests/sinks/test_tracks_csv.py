"""The tracks CSV sink: a ball is in the file from the frame it was first seen, rows in frame order."""

import numpy as np
import pytest

from stereotrack.capture.signals import interrupt_in
from stereotrack.config import TrackSettings
from stereotrack.frames import FramePair
from stereotrack.results import FrameResult, Object3D
from stereotrack.sinks.tracks_csv import TracksCsvSink, hold_for, read_tracks
from stereotrack.tracks.manager import TrackManager

FPS = 30


def _ball(i: int, rng: np.random.Generator) -> Object3D:
    position = np.array([0.1 * i / FPS, 0.0, 2.0]) + rng.normal(0, 0.002, 3)
    return Object3D(target="red", position=position, covariance=np.eye(3) * 0.005**2, mass=0.5, n_particles=100)


def _write(path, hold: float, frames: int = 20, stop_with=None):
    """A ball seen from frame 5 on, and a speck seen in frame 12 only (clutter: never confirmed)."""
    rng = np.random.default_rng(3)
    settings = TrackSettings()
    manager = TrackManager(settings)
    sink = TracksCsvSink(path, hold)
    try:
        try:
            for i in range(frames):
                objects = [_ball(i, rng)] if i >= 5 else []
                if i == 12:
                    objects.append(
                        Object3D(target="red", position=np.array([1.0, 1.0, 3.0]), covariance=np.eye(3) * 1e-4, mass=0.2, n_particles=20)
                    )
                tracks = manager.update(objects, i / FPS)
                sink.write(FrameResult(FramePair(i, (), (i / FPS,)), tracks=tracks))
            if stop_with is not None:
                raise stop_with
        finally:
            sink.close()  # as a command closes it: while the stop is on its way out
    except BaseException as exc:
        if interrupt_in(exc) is None:
            raise
    return read_tracks(path), settings


def test_a_track_is_written_from_its_first_hit_in_frame_order(tmp_path):
    rows, settings = _write(tmp_path / "t.csv", hold_for(TrackSettings()))
    frames = rows[:, 0]
    assert frames[0] == 5, "the ball is in the file from the frame it was first seen"
    assert np.all(np.diff(frames) >= 0), "rows stay in frame order"
    assert np.array_equal(frames, np.arange(5, 20)), "one row a frame, the speck never confirmed is not there"
    assert np.all(np.abs(rows[:, 3:6] - np.c_[0.1 * frames / FPS, 0 * frames, 2 + 0 * frames]) < 0.02)


def test_without_a_hold_a_track_starts_where_it_was_confirmed(tmp_path):
    rows, settings = _write(tmp_path / "t.csv", 0.0)
    assert rows[0, 0] == 5 + round(settings.confirm_time * FPS)


def _wrapped_stop() -> SystemError:
    """A Ctrl-C as a compiled kernel hands it on: a SystemError caused by it (tests/capture/test_signals.py)."""
    error = SystemError("CPUDispatcher(<function project_points>) returned a result with an exception set")
    error.__cause__ = KeyboardInterrupt()
    return error


@pytest.mark.parametrize("stop", [KeyboardInterrupt, _wrapped_stop])
@pytest.mark.parametrize("frames", [6, 9, 20])
def test_ctrl_c_writes_the_held_rows(tmp_path, frames, stop):
    rows, _ = _write(tmp_path / "t.csv", hold_for(TrackSettings()), frames=frames, stop_with=stop())
    confirmed = frames - 1 >= 5 + round(TrackSettings().confirm_time * FPS)
    assert len(rows) == (frames - 5 if confirmed else 0) and (not len(rows) or rows[-1, 0] == frames - 1)


def test_two_frames_of_one_time_get_a_row_each(tmp_path):
    """A bad recording repeats a timestamp (frames.csv allows it): the track's tentative hits in both frames go one to
    each frame, not both to the later one (a duplicated row, and a frame without the ball)."""
    settings = TrackSettings()
    manager = TrackManager(settings)
    sink = TracksCsvSink(tmp_path / "t.csv", hold_for(settings))
    times = [i / FPS for i in range(20)]
    times[7] = times[6]
    for i, t in enumerate(times):
        ball = Object3D(target="red", position=np.array([0.1 * t, 0.0, 2.0]), covariance=np.eye(3) * 0.005**2, mass=0.5, n_particles=100)
        sink.write(FrameResult(FramePair(i, (), (t,)), tracks=manager.update([ball] if i >= 5 else [], t)))
    sink.close()
    frames = read_tracks(tmp_path / "t.csv")[:, 0]
    assert np.array_equal(frames, np.arange(5, 20)), frames


def test_each_row_is_its_tracks_smoothed_state_at_its_frame(tmp_path):
    """A row is written with the state its track had at its frame smoothed with the frames after (TrackEstimate.smoothed,
    smooth_time later); the last rows, which no later frame smooths, keep the filter's."""
    rng = np.random.default_rng(4)
    manager = TrackManager(TrackSettings())
    sink = TracksCsvSink(tmp_path / "t.csv", hold_for(TrackSettings()))
    smoothed, filtered = {}, {}
    try:
        for i in range(30):
            tracks = manager.update([_ball(i, rng)], i / FPS)
            sink.write(FrameResult(FramePair(i, (), (i / FPS,)), tracks=tracks))
            for tr in tracks:
                filtered[i] = tr.position
                for time, position, *_ in tr.smoothed:
                    smoothed[round(time * FPS)] = position
    finally:
        sink.close()
    rows = read_tracks(tmp_path / "t.csv")
    assert np.array_equal(rows[:, 0], np.arange(30))
    assert len(smoothed) >= 20
    for frame, x, y, z in rows[:, [0, 3, 4, 5]]:
        expected = smoothed.get(int(frame), filtered[int(frame)])
        assert np.allclose([x, y, z], expected, atol=1e-5)
    assert all(int(f) in smoothed for f in rows[:-6, 0]), "every row but the last smooth_time's is smoothed"
    assert not np.allclose(rows[10, 3:6], filtered[10], atol=1e-5), "and smoothing moved them"


def test_frames_a_track_coasted_through_unreported_are_written_once_its_ball_is_met_again(tmp_path):
    """A ball rolling at 0.6 m/s, missed at frames 10-13 (a hand over it): past report_coasting (frames 12 and 13) its
    track was not written live, but its ball met again at frame 14 places it there in hindsight, smoothed between the
    frames it was seen (hands tune seeds: 345 such rows of 32310 missing). A ball gone for good at frame 21 is not
    written past report_coasting: nothing met it again."""
    rng = np.random.default_rng(8)
    settings = TrackSettings()
    manager = TrackManager(settings, radius={"red": 0.03})
    sink = TracksCsvSink(tmp_path / "t.csv", hold_for(settings))

    def truth(i):
        return np.array([0.6 * i / FPS, 0.0, 2.0])

    try:
        for i in range(40):
            seen = i < 21 and not 10 <= i < 14
            ball = Object3D(
                target="red", position=truth(i) + rng.normal(0, 0.002, 3), covariance=np.eye(3) * 0.005**2, mass=0.5, n_particles=100
            )
            sink.write(FrameResult(FramePair(i, (), (i / FPS,)), tracks=manager.update([ball] if seen else [], i / FPS)))
    finally:
        sink.close()
    rows = read_tracks(tmp_path / "t.csv")
    coasting = round(settings.report_coasting * FPS)  # frames written live after the last hit: 2
    assert np.array_equal(rows[:, 0], np.arange(21 + coasting)), rows[:, 0]
    assert len(set(rows[:, 2])) == 1, "one track"
    for frame, x, y, z in rows[:, [0, 3, 4, 5]]:
        if frame <= 20:
            assert np.linalg.norm([x, y, z] - truth(int(frame))) < 0.01, (frame, x, y, z)
