import numpy as np
import pytest

from stereotrack.errors import StereotrackError
from stereotrack.simulation.mocap import JUGGLING_5, find_real_data, link_balls, link_points, load_juggling, read_qualisys_tsv


@pytest.fixture(scope="module")
def juggling():
    return load_juggling()


def test_reads_the_qualisys_export():
    cap = read_qualisys_tsv(find_real_data(JUGGLING_5))
    assert cap.frequency == 300 and cap.points.shape == (4967, 24, 3)
    assert cap.names[:5] == ("base_1", "base_2", "base_3", "base_4", "base_5") and cap.unnamed.shape[1] == 19
    assert cap.times[1] == pytest.approx(1 / 300, abs=1e-5)
    # Millimetres -> metres; "0 0 0" -> not seen.
    assert np.allclose(cap.points[0, 0], [0.228117, -0.404129, -0.672697])
    seen = np.isfinite(cap.unnamed[..., 0]).sum(axis=1)
    assert (seen == 5).mean() > 0.9 and seen.max() == 6  # a ghost marker now and then


def test_juggling_replay_gives_five_balls_with_the_captures_speeds(juggling):
    assert juggling.n_balls == 5
    present = juggling.present
    assert present.mean(axis=0).min() > 0.95  # every lane is a ball for nearly the whole capture
    assert present.all(axis=1).mean() > 0.9
    speeds = juggling.speeds()
    # The capture's measured ball speeds: median 2.2 m/s, 99th percentile 4.0 m/s.
    assert np.median(speeds) == pytest.approx(2.2, abs=0.1)
    assert np.percentile(speeds, 99) == pytest.approx(4.0, abs=0.25)
    # No identity jumps: at 300 Hz a ball moves less than 2 cm between frames.
    step = np.linalg.norm(np.diff(juggling.positions, axis=0), axis=2)
    assert np.nanmax(step) < 0.03
    z = juggling.positions[..., 2][present]
    assert 0.2 < z.min() and z.max() < 2.0  # a juggler's volume, z up, metres


def test_resampling_keeps_the_motion(juggling):
    at30 = juggling.resample(30.0)
    assert len(at30.times) == int(juggling.times[-1] * 30) + 1
    k = 150  # 5.0 s is capture frame 1500
    assert np.allclose(at30.positions[k][juggling.present[1500]], juggling.positions[1500][juggling.present[1500]], atol=1e-6)
    assert np.median(at30.speeds()) == pytest.approx(np.median(juggling.speeds()), rel=0.1)


def test_linking_swapped_columns_and_bridging_a_gap():
    # Two balls whose columns swap every frame, one unseen for 10 frames: linking must restore both.
    t = np.arange(200) / 300
    a = np.column_stack([0.5 * t, np.zeros_like(t), 1.0 + 3.0 * t - 4.905 * t**2])
    b = np.column_stack([-0.5 * t, 0.3 + 0 * t, 1.2 - 1.0 * t])
    pts = np.stack([a, b], axis=1)
    pts[1::2] = pts[1::2, ::-1]
    pts[50:60, 0] = np.nan  # whichever ball is in column 0 there is lost for a while
    pts[50:60, 1] = np.where(np.arange(50, 60)[:, None] % 2 == 1, a[50:60], b[50:60])
    tracks = link_points(pts, 300.0)
    assert len(tracks) == 2
    got = sorted(tracks, key=lambda tr: tr[0, 1])
    assert np.allclose(got[0], a, atol=1e-3) and np.allclose(got[1], b, atol=1e-3)


def test_not_a_capture_is_a_clear_error(tmp_path):
    bad = tmp_path / "x.tsv"
    bad.write_text("hello\tworld\n1\t2\n")
    with pytest.raises(StereotrackError, match="not a Qualisys TSV"):
        read_qualisys_tsv(bad)
    with pytest.raises(StereotrackError, match="not found"):
        read_qualisys_tsv(tmp_path / "missing.tsv")


def test_single_ball_capture():
    from stereotrack.simulation.mocap import THROWS_6

    throws = link_balls(read_qualisys_tsv(find_real_data(THROWS_6)), n_balls=1)
    assert throws.n_balls == 1 and 0.5 < throws.present.mean() < 0.8
    assert np.percentile(throws.speeds(), 99) > 4.0  # real throws are fast
