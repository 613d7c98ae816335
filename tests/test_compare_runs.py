"""benchmarks/compare_runs.py: two versions on the same stress scenes, paired per tracker seed."""

import math

import numpy as np
import pytest
from benchmark_scripts import load

from stereotrack.commands.stress import write_results_csv

cr = load("compare_runs")


def _results(path, motas: dict[tuple[str, int], float | None]):
    """A results CSV as ``stereotrack stress`` writes it: None is a run that failed."""
    rows = [
        {"category": c, "seed": s, "methods": {"particles": {"error": "boom"} if m is None else {"mota": m, "misses": 0}}}
        for (c, s), m in motas.items()
    ]
    return write_results_csv(rows, path)


def test_runs_are_paired_per_tracker_seed_and_luck_is_their_spread(tmp_path):
    rng = np.random.default_rng(3)
    scenes = [("hands", s) for s in range(10)]
    base, new = [], []
    for t in range(4):  # each tracker seed draws every scene anew: a common luck, and a gain of 0.05 a scene in the new version
        luck = rng.normal(0.0, 0.01, len(scenes))
        base.append(_results(tmp_path / f"base{t}.csv", {k: 0.9 + x for k, x in zip(scenes, luck)}))
        new.append(_results(tmp_path / f"new{t}.csv", {k: 0.95 + x + 0.001 * t for k, x in zip(scenes, luck)}))
    (row,) = cr.compare([cr.read_scores(p) for p in base], [cr.read_scores(p) for p in new])
    assert row.scenes == 10 and row.dropped == 0
    assert np.allclose(row.differences, [0.5, 0.51, 0.52, 0.53], atol=1e-3)  # 10 scenes x (0.05 + 0.001 t), up to the CSV's 4 digits
    assert row.mean == pytest.approx(0.515, abs=1e-3)
    assert row.standard_error == pytest.approx(np.std([0.5, 0.51, 0.52, 0.53], ddof=1) / 2, abs=1e-3)
    assert row.verdict == "better" and (row.better, row.worse) == (10, 0)
    assert (row.base_under, row.new_under) == (0, 0)
    # the same versions swapped lose as much; one tracker seed alone says nothing of luck
    (back,) = cr.compare([cr.read_scores(p) for p in new], [cr.read_scores(p) for p in base])
    assert back.verdict == "worse" and back.mean == pytest.approx(-row.mean)
    (one,) = cr.compare([cr.read_scores(base[0])], [cr.read_scores(new[0])])
    assert math.isnan(one.standard_error) and one.verdict == "one tracker seed: luck unknown"


def test_a_gain_that_luck_can_give_is_called_so(tmp_path):
    # seed 0 of the new version loses 3 on one scene, the others gain a little: the mean is within twice its standard error
    sums = {0: -3.0, 1: 0.1, 2: 0.3, 3: 0.4}
    base = [_results(tmp_path / f"b{t}.csv", {("hue_wall", s): 1.0 if s else 0.5 for s in range(5)}) for t in sums]
    new = [
        _results(tmp_path / f"n{t}.csv", {("hue_wall", s): (1.0 if s else 0.5) + (d if s == 0 else 0.0) for s in range(5)})
        for t, d in sums.items()
    ]
    (row,) = cr.compare([cr.read_scores(p) for p in base], [cr.read_scores(p) for p in new])
    assert row.verdict == "within luck"
    assert (row.base_under, row.new_under) == (4, 3)  # scene 0 under 0.85 in every run but the new one of tracker seed 3 (0.9)
    assert row.better == 0 and row.worse == 1  # scene 0's mean: 0.5 -> 0.5 - 0.55


def test_a_failed_run_leaves_its_scene_out_of_both_versions(tmp_path):
    base = [_results(tmp_path / "b.csv", {("mjpg", 0): 0.9, ("mjpg", 1): 0.8, ("lighting", 0): 1.0})]
    new = [_results(tmp_path / "n.csv", {("mjpg", 0): 0.95, ("mjpg", 1): None, ("lighting", 0): 1.0})]
    rows = {r.category: r for r in cr.compare([cr.read_scores(p) for p in base], [cr.read_scores(p) for p in new])}
    assert rows["mjpg"].scenes == 1 and rows["mjpg"].dropped == 1
    assert rows["mjpg"].base_sums == pytest.approx((0.9,)) and rows["mjpg"].new_sums == pytest.approx((0.95,))
    assert rows["lighting"].differences.tolist() == [0.0]


def test_the_command_prints_a_table_or_one_line_and_exit_2(tmp_path, capsys):
    b = _results(tmp_path / "b.csv", {("hands", 0): 0.9})
    n = _results(tmp_path / "n.csv", {("hands", 0): 0.7})
    assert cr.main(["--base", str(b), "--new", str(n)]) == 0
    out = capsys.readouterr().out
    assert "| hands | 1 | 1 | 0.90 | 0.70 | -0.20 | -0.20 | 0 -> 1 of 1 | 0 / 1 | one tracker seed: luck unknown |" in out
    for argv, says in (
        (["--base", str(b), str(b), "--new", str(n)], "as many --new files as --base files"),
        (["--base", str(tmp_path / "none.csv"), "--new", str(n)], "no such results CSV"),
        (["--base", str(b), "--new", str(n), "--method", "baseline"], "no rows of method 'baseline'"),
    ):
        assert cr.main(argv) == 2
        err = capsys.readouterr().err
        assert says in err and len(err.strip().splitlines()) == 1
