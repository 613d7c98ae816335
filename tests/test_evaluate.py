import numpy as np
import pytest

from stereotrack.evaluate import evaluate


def truth_rows(n_frames=20):
    rows = []
    for f in range(n_frames):
        rows.append([f, 0, 0.0, 0.0, 1.0])
        rows.append([f, 1, 0.5, 0.0, 1.5])
    return np.array(rows, float)


def test_perfect_tracks():
    truth = truth_rows()
    tracks = np.array([[r[0], r[0] / 30, r[1] + 1, r[2], r[3], r[4]] for r in truth])
    ev = evaluate(tracks, truth)
    assert ev.mota == pytest.approx(1.0) and ev.id_switches == 0 and ev.misses == 0 and ev.false_positives == 0
    assert ev.motp_mm == pytest.approx(0.0, abs=1e-9)


def test_offsets_misses_false_positives_and_switches():
    truth = truth_rows(20)
    rows = []
    for f in range(20):
        # ball 0: 3 cm off, id 1 then id 5 from frame 10 (one switch); ball 1 missed in frames 0..4
        rows.append([f, 0, 1 if f < 10 else 5, 0.03, 0.0, 1.0])
        if f >= 5:
            rows.append([f, 0, 2, 0.5, 0.0, 1.5])
        if f == 7:
            rows.append([f, 0, 9, 2.0, 2.0, 2.0])  # far from everything: a false positive
    ev = evaluate(np.array(rows, float), truth, gate=0.1)
    assert ev.misses == 5 and ev.false_positives == 1 and ev.id_switches == 1
    assert ev.mota == pytest.approx(1 - (5 + 1 + 1) / 40)
    # MOTP in mm over matches: 20 matches at 30 mm and 15 at 0 mm.
    assert ev.motp_mm == pytest.approx(1e3 * (20 * 0.03) / 35, rel=1e-6)
    assert ev.p95_error_mm == pytest.approx(30.0, rel=1e-6)
