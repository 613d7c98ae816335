"""benchmarks/error_classes.py: which misses and false positives a scene's tracks hold, by kind."""

import numpy as np
from benchmark_scripts import load

from stereotrack.evaluate import error_events

ec = load("error_classes")

FPS = 30.0


def test_misses_and_false_positives_are_sorted_by_what_became_of_their_ball():
    n = 40
    times = np.arange(n) / FPS
    # ball 0 flies at 3 m/s along x, then rests from frame 20; ball 1 rests at one place all along; ball 2 is never tracked
    x0 = np.where(np.arange(n) < 20, 3.0 * times, 3.0 * times[19])
    truth = np.array([r for f in range(n) for r in ([f, 0, x0[f], 0, 2], [f, 1, 0, 1, 2], [f, 2, 1, 1, 2])], float)
    tracks = []
    for f in range(n):
        if 5 <= f < 12 or 14 <= f < 25 or f >= 30:  # ball 0 found at frame 5; lost in 12-13 (flying) and 25-29 (at rest)
            tracks.append([f, times[f], 1, x0[f], 0, 2])
        if f >= 3:  # ball 1 found at frame 3
            tracks.append([f, times[f], 2, 0, 1, 2])
        if 10 <= f < 22:  # a ghost for 12 frames ...
            tracks.append([f, times[f], 3, -1, -1, 2])
        if f == 33:  # ... and one for a frame
            tracks.append([f, times[f], 4, -1, 0, 2])
    events = error_events(np.array(tracks, float), truth, frames=np.arange(n))
    c = ec.classify(events, ec.speeds(truth, times))
    assert c.ball_frames == 3 * n
    assert (c.not_yet_found, c.never_found, c.lost_fast, c.lost_slow) == (5 + 3, n, 2, 5)
    assert (c.false_lasting, c.false_brief, c.id_switches) == (12, 1, 0)
    assert (c + c).never_found == 2 * n
    # ball 2 a sliver in some camera in its first 10 frames (simulation.visibility.shown): those are hidden, not missed balls
    h = ec.classify(events, ec.speeds(truth, times), lambda f, b: 0.1 if b == 2 and f < 10 else 1.0)
    assert (h.hidden, h.never_found, h.not_yet_found, h.lost_fast, h.lost_slow) == (10, n - 10, 8, 2, 5)


def test_speeds_come_from_neighbouring_rows_and_their_times():
    times = np.array([0.0, 0.1, 0.3])
    truth = np.array([[0, 4, 0, 0, 1], [1, 4, 0.2, 0, 1], [2, 4, 0.6, 0, 1], [1, 5, 0, 0, 1]], float)
    v = ec.speeds(truth, times)
    assert v[(0, 4)] == np.float64(2.0) and v[(2, 4)] == np.float64(2.0) and v[(1, 5)] == 0.0


def test_a_cache_without_the_scenes_says_what_to_run(tmp_path, capsys):
    assert ec.main(["--cache", str(tmp_path), "--set", "tune", "--seeds", "2", "--categories", "hands"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "stereotrack stress --set tune --seeds 2" in err
