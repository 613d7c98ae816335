"""`stereotrack stress`: scores every category, reuses its renders and scores, writes its table where it says,
refuses what it must, and stops its workers on Ctrl-C."""

import os
import signal
import subprocess
import sys
import time

import pytest

from stereotrack.cli import main as cli_main
from stereotrack.commands.stress import Job, markdown_table, scene_key, summarise
from stereotrack.files import read_section, replace_section
from stereotrack.simulation.stress import CATEGORIES


def test_summary_takes_median_and_worst_and_marks_the_goal():
    def res(cat, seed, mota, err=5.0):
        m = {"mota": mota, "id_switches": seed % 2, "mean_error_mm": err, "recall": 1.0, "precision": 1.0}
        return {"category": cat, "seed": seed, "methods": {"particles": m}}

    rows = summarise([res("a", 0, 0.99), res("a", 1, 0.96), res("a", 2, 0.90), res("b", 0, 0.97), res("b", 1, 0.5)], ["particles"])
    assert [r["mota_median"] for r in rows] == [0.96, pytest.approx(0.735)]
    assert rows[0]["mota_worst"] == 0.90 and rows[0]["worst_seed"] == 2 and rows[0]["id_switches_max"] == 1
    table = markdown_table(rows)
    assert "| a | particles | 3 | 0.960 | 0.900 (2) |" in table and table.count("| yes |") == 1


def test_replace_section_keeps_the_rest_of_the_file(tmp_path):
    doc = tmp_path / "evaluation.md"
    doc.write_text("# Title\n\nkept text\n")
    replace_section(doc, "stress", "table one")
    replace_section(doc, "stress", "table two")
    text = doc.read_text()
    assert text.startswith("# Title\n\nkept text\n") and text.count("<!-- section: stress -->") == 1
    assert read_section(doc, "stress") == "table two" and read_section(doc, "other") is None


def test_the_command_scores_every_category_then_reuses_its_work(tmp_path, capsys):
    args = ["stress", "--seeds", "1", "--frames", "6", "--scale", "0.25", "--jobs", "1", "--cache", str(tmp_path / "cache"), "--quiet"]
    assert cli_main(args) == 0
    out, err = capsys.readouterr()
    rows = [line for line in out.splitlines() if line.startswith("| ") and "category" not in line]
    assert len(rows) == 2 * len(CATEGORIES)
    assert "(10 rendered" in err
    per_seed = (tmp_path / "cache" / "tune-results.csv").read_text().splitlines()
    assert len(per_seed) == 1 + 2 * len(CATEGORIES) and per_seed[1].startswith("hue_wall,0,particles,")
    scores = sorted((tmp_path / "cache").rglob("score_*.json"))
    assert len(scores) == 2 * len(CATEGORIES)
    stamps = [p.stat().st_mtime_ns for p in scores]
    assert cli_main(args) == 0
    out2, err2 = capsys.readouterr()
    assert out2 == out and "(0 rendered" in err2  # nothing rendered or tracked again
    assert [p.stat().st_mtime_ns for p in scores] == stamps
    job = Job("hands", 0, str(tmp_path / "cache"), frames=6, scale=0.25)
    assert (job.folder / "truth.csv").is_file() and (job.folder / "scene.key").read_text().strip() == scene_key(job.spec())


def test_docs_take_only_the_report_set_and_bad_arguments_are_one_line(tmp_path, capsys):
    doc = tmp_path / "evaluation.md"
    doc.write_text("# Evaluation\n")
    assert cli_main(["stress", "--set", "tune", "--seeds", "1", "--docs", str(doc)]) == 2
    assert cli_main(["stress", "--set", "report", "--seeds", "1", "--frames", "5", "--docs", str(doc)]) == 2
    assert cli_main(["stress", "--categories", "nope"]) == 2
    err = capsys.readouterr().err
    assert err.count("error:") == 3 and "--set report" in err and "unknown stress category 'nope'" in err
    assert doc.read_text() == "# Evaluation\n"


def test_list_names_every_category(capsys):
    assert cli_main(["stress", "--list"]) == 0
    out = capsys.readouterr().out
    assert [line.split()[0] for line in out.splitlines()] == list(CATEGORIES)


def _ctrl_c_enabled() -> None:
    """In the child: Ctrl-C (SIGINT) at its default, even if this test run inherited it ignored."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _children(pid: int) -> list[int]:
    out = subprocess.run(["ps", "-o", "pid=", "--ppid", str(pid)], capture_output=True, text=True).stdout
    return [int(x) for x in out.split()]


def test_ctrl_c_stops_the_workers_at_once_and_leaves_the_docs_as_they_were(tmp_path):
    doc = tmp_path / "evaluation.md"
    doc.write_text("# Evaluation\n")
    cache = tmp_path / "cache"
    cmd = [sys.executable, "-m", "stereotrack", "stress", "--set", "report", "--seeds", "3", "--jobs", "2", "--cache", str(cache)]
    proc = subprocess.Popen(
        [*cmd, "--docs", str(doc)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, preexec_fn=_ctrl_c_enabled
    )
    try:
        deadline = time.monotonic() + 120
        while not list(cache.glob("*/.*.partial-*")) and time.monotonic() < deadline:  # both workers are rendering
            time.sleep(0.2)
        workers = _children(proc.pid)
        assert len(workers) >= 2 and proc.poll() is None
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=20)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130 and err.strip().splitlines()[-1] == "interrupted"
    time.sleep(0.5)
    assert not [w for w in workers if os.path.exists(f"/proc/{w}") and open(f"/proc/{w}/stat").read().split()[2] != "Z"]
    assert doc.read_text() == "# Evaluation\n"
    assert not list(cache.glob("*/0*/scene.key"))  # nothing half-rendered took a scene's place
