"""`stereotrack bench --docs`: the table, how it was made and the speed targets go into the file's tracker-bench
section, nested in BENCHMARKS.md's tracker section, and nothing else changes; bad use is one line and changes nothing."""

import re
import shutil
from pathlib import Path

import pytest

from stereotrack.cli import main as cli_main
from stereotrack.files import read_section, replace_section

ROOT = Path(__file__).resolve().parents[2]
INNER = ("<!-- section: tracker-bench -->", "<!-- /section: tracker-bench -->")
TARGET_LINE = r"- {size}: measured \d+\.\dx \(target <= {target}x\): (met|not met)"


def _outside(data: bytes) -> tuple[bytes, bytes]:
    """The bytes before the tracker-bench section's opening marker and after its closing one (each marker once)."""
    head, rest = data.split(INNER[0].encode())
    _, tail = rest.split(INNER[1].encode())
    return head, tail


def test_replace_section_finds_a_section_nested_in_another_and_keeps_the_outer_one(tmp_path):
    def nested(inner: str) -> str:
        return f"# B\n<!-- section: tracker -->\nprose\n{INNER[0]}\n{inner}\n{INNER[1]}\nmore prose\n<!-- /section: tracker -->\nend\n"

    doc = tmp_path / "BENCHMARKS.md"
    doc.write_text(nested("old"))
    replace_section(doc, "tracker-bench", "new table")
    assert doc.read_text() == nested("new table")
    assert read_section(doc, "tracker") == f"prose\n{INNER[0]}\nnew table\n{INNER[1]}\nmore prose"


def test_docs_writes_the_command_date_machine_table_and_target_into_benchmarks_md(tmp_path, capsys):
    doc = tmp_path / "BENCHMARKS.md"
    shutil.copyfile(ROOT / "BENCHMARKS.md", doc)  # the real file: its markers nested in the tracker section, text around
    before = doc.read_bytes()
    assert cli_main(["bench", "--quick", "--frames", "12", "--docs", str(doc)]) == 0
    out = capsys.readouterr().out
    assert out.splitlines()[-1].startswith("| 640x480 | 2000 | 0.2 |")  # stdout still ends on the table (`| tail -1`)
    after = doc.read_bytes()
    assert _outside(after) == _outside(before)  # byte for byte outside the section
    section = read_section(doc, "tracker-bench")
    assert section != read_section(ROOT / "BENCHMARKS.md", "tracker-bench")
    assert INNER[0] in read_section(doc, "tracker")  # still inside the tracker section
    assert re.match(
        rf"Produced by `stereotrack bench --quick --frames 12 --docs {re.escape(str(doc))}` on \d{{4}}-\d\d-\d\d \(UTC\)", section
    )
    assert re.search(r"\d+ cores \(CPU: [^)]+\)", section) and "12 frames per case" in section
    assert "| size | N | alpha | step ms | floor ms | step / floor |" in section and "\n| 640x480 | 2000 | 0.2 | " in section
    assert re.search("^" + TARGET_LINE.format(size="640x480", target=5) + "$", section, re.M)
    assert "1280x720" not in section  # --quick measures 640x480 only: no line for the other target


def test_docs_judges_every_target_as_printed_and_a_failed_run_leaves_the_file_as_it_was(tmp_path, capsys, monkeypatch):
    """Every case (its timing replaced: the full benchmark takes minutes): both target lines, judged on the figure the
    reader sees. A case that fails after others were measured writes nothing."""
    import stereotrack.pipeline.bench as bench

    ratios = {(640, 2000, 0.2): 5.04, (1280, 2000, 0.2): 3.06}

    def timed(frames, rig, config):
        ratio = ratios.get((rig[0].width, config.tracker.particles, config.tracker.alpha), 2.0)
        return dict.fromkeys(("step", "floor", "masks", "blobs", "particles", "clusters", "tracks"), 1.0) | {"ratio": ratio}

    doc = tmp_path / "notes.md"
    doc.write_text("# Notes\n\nkept\n")
    monkeypatch.setattr(bench, "bench_case", timed)
    assert cli_main(["bench", "--frames", "11", "--docs", str(doc)]) == 0
    section = read_section(doc, "tracker-bench")
    assert doc.read_text().startswith("# Notes\n\nkept\n\n" + INNER[0])  # a file without the section gets it at its end
    assert section.startswith(f"Produced by `stereotrack bench --frames 11 --docs {doc}` on ")
    assert section.count("\n| 640x480 | ") == 9 and section.count("\n| 1280x720 | ") == 9
    assert section.endswith("- 640x480: measured 5.0x (target <= 5x): met\n- 1280x720: measured 3.1x (target <= 3x): not met")
    written = doc.read_bytes()

    def fails_on_the_last_case(frames, rig, config):
        if rig[0].width == 1280 and config.tracker.particles == 5000 and config.tracker.alpha == 1.0:
            raise RuntimeError("the machine went away")
        return timed(frames, rig, config)

    monkeypatch.setattr(bench, "bench_case", fails_on_the_last_case)
    assert cli_main(["bench", "--frames", "11", "--docs", str(doc)]) == 3
    assert doc.read_bytes() == written and sorted(p.name for p in tmp_path.iterdir()) == ["notes.md"]


@pytest.mark.parametrize(
    "argv, says",
    [
        (["bench", "--quick", "--frames", "12", "--docs", "missing.md"], "missing.md: no such file (point --docs at BENCHMARKS.md)"),
        (["bench", "--quick", "--frames", "12", "--em", "sklearn", "--docs", "BENCHMARKS.md"], "drop --em sklearn"),
    ],
)
def test_bad_docs_use_is_one_line_exit_2_and_changes_nothing(tmp_path, monkeypatch, capsys, argv, says):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "BENCHMARKS.md").write_text("# Benchmarks\n")
    assert cli_main(argv) == 2
    out, err = capsys.readouterr()
    assert out == "" and len(err.strip().splitlines()) == 1 and err.startswith("error: ") and says in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["BENCHMARKS.md"] and (tmp_path / "BENCHMARKS.md").read_text() == "# Benchmarks\n"
