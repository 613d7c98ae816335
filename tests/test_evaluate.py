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


def test_a_ball_fewer_than_two_cameras_see_is_optional():
    """Hidden in every view (or seen by one): not a miss when untracked, not a false positive when a track stands on it."""
    truth = truth_rows(20)
    views = np.where((truth[:, 1] == 1) & (truth[:, 0] >= 10), 0, 2)  # ball 1 goes behind a wall at frame 10
    views[(truth[:, 1] == 1) & (truth[:, 0] == 15)] = 1  # and shows in one camera at frame 15
    untracked = np.array([[r[0], 0, r[1] + 1, *r[2:5]] for r in truth if r[1] == 0 or r[0] < 10], float)
    coasting = np.array([[r[0], 0, r[1] + 1, *r[2:5]] for r in truth], float)
    strict = evaluate(untracked, truth)
    assert strict.misses == 10 and strict.mota == pytest.approx(0.75)
    for tracks in (untracked, coasting):
        ev = evaluate(tracks, truth, views=views)
        assert ev.misses == 0 and ev.false_positives == 0 and ev.id_switches == 0
        assert ev.truth_objects == 30 and ev.matches == 30 and ev.mota == pytest.approx(1.0)
        assert ev.optional_objects == 10 and "optional ball-frames: 10 (" in ev.table()  # said, not hidden
    assert strict.optional_objects == 0
    assert evaluate(untracked, truth, frames=np.arange(12), views=views).optional_objects == 2  # within the frames scored
    # A track elsewhere while the ball is hidden is still a false positive; the hidden ball claims one track only.
    stray = np.vstack([coasting, [[12, 0, 7, 2.0, 2.0, 2.0], [12, 0, 8, 0.52, 0.0, 1.5]]])
    ev = evaluate(stray, truth, views=views)
    assert ev.false_positives == 2  # the far one, and the second track on the hidden ball


def test_with_no_ball_two_cameras_see_mota_and_recall_are_undefined_not_zero():
    """0 / 0: a recording whose balls no two cameras see (props hide them) scored MOTA 0.000, as a tracker that lost every
    ball would. It has no MOTA or recall (NaN, "n/a" in the table); its false positives still count."""
    truth = truth_rows(10)
    views = np.ones(len(truth), int)  # every ball in one camera only: optional
    stray = np.array([[f, 0, 7, 2.0, 2.0, 2.0] for f in range(3)], float)
    for tracks, false_positives in ((np.zeros((0, 6)), 0), (stray, 3)):
        ev = evaluate(tracks, truth, views=views)
        assert ev.truth_objects == 0 and ev.false_positives == false_positives
        assert np.isnan(ev.mota) and np.isnan(ev.recall)
        assert "MOTA: n/a (no ball seen by two cameras)" in ev.table()
    assert evaluate(stray, truth).mota == pytest.approx(1 - (20 + 3) / 20)  # every ball required: a score as before


def test_with_nothing_matched_motp_is_undefined_and_with_no_track_precision_too():
    """A tracker that found no ball scored MOTP 0.0 mm, as a perfect one does, and precision 0.000 with no track to be
    precise about. Both are 0 / 0: NaN, "n/a" in the table; recall and MOTA still charge every miss."""
    truth = truth_rows(10)
    far = np.array([[f, 0, 7, 2.0, 2.0, 2.0] for f in range(3)], float)  # tracks, none on a ball
    for tracks, precision in ((np.zeros((0, 6)), None), (far, 0.0)):
        ev = evaluate(tracks, truth)
        assert ev.matches == 0 and np.isnan(ev.motp_mm) and "MOTP: n/a" in ev.table()
        assert ev.recall == 0.0 and ev.mota == pytest.approx(1 - (20 + len(tracks)) / 20)
        if precision is None:
            assert np.isnan(ev.precision) and "precision: n/a" in ev.table()
        else:
            assert ev.precision == precision


def test_error_events_are_what_evaluate_counts_frame_by_frame():
    from stereotrack.evaluate import FALSE, MATCH, MISS, SWITCH, error_events

    truth = truth_rows(20)
    rows = []
    for f in range(20):
        rows.append([f, 0, 1 if f < 10 else 5, 0.03, 0.0, 1.0])  # ball 0: switches from track 1 to 5 at frame 10
        if f >= 5:
            rows.append([f, 0, 2, 0.5, 0.0, 1.5])  # ball 1 missed in frames 0-4
        if f == 7:
            rows.append([f, 0, 9, 2.0, 2.0, 2.0])  # a false positive
    tracks = np.array(rows, float)
    events = error_events(tracks, truth, gate=0.1)
    ev = evaluate(tracks, truth, gate=0.1)
    kind = events[:, 1]
    assert (kind == MISS).sum() == ev.misses == 5 and (kind == FALSE).sum() == ev.false_positives == 1
    assert (kind == SWITCH).sum() == ev.id_switches == 1 and (kind == MATCH).sum() == ev.matches  # (motmetrics counts a switch apart)
    assert sorted(events[kind == MISS, 0].tolist()) == [0, 1, 2, 3, 4] and set(events[kind == MISS, 2].tolist()) == {1}
    assert events[kind == MISS, 3].tolist() == [-1] * 5  # a miss has no track ...
    assert events[kind == FALSE].tolist() == [[7, FALSE, -1, 9]]  # ... a false positive no ball
    assert events[kind == SWITCH].tolist() == [[10, SWITCH, 0, 5]]


def test_error_events_leave_balls_fewer_than_two_cameras_see_out():
    from stereotrack.evaluate import FALSE, MISS, error_events

    truth = truth_rows(4)
    views = np.where(truth[:, 1] == 1, 1, 2)  # ball 1: one camera only, optional
    tracks = np.array([[f, 0, 1, 0.0, 0.0, 1.0] for f in range(4)] + [[2, 0, 7, 0.5, 0.0, 1.5]], float)  # one on ball 1 in frame 2
    events = error_events(tracks, truth, views=views)
    assert not ((events[:, 1] == MISS) | (events[:, 1] == FALSE)).any()  # neither the untracked optional ball nor the track on it
