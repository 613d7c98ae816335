"""Every case of issue 16 (user errors, hostile files, outputs), as a user meets it: one line, exit 2, nothing harmed.

Each case breaks one thing in a fresh copy of a small recording, runs the
command in this process (tests/fuzzing.run_cli: stdout and stderr captured at
the descriptor level, a 30 s alarm) and checks the fuzzing invariant plus the
message. The network and viewer cases run real processes: test_viewer_failures.py.
"""

import os
import shutil
import stat
import subprocess
import sys

import numpy as np
import pytest
import yaml
from fuzzing import build_fixture, check, make_workspace, run_cli

from stereotrack.recording import open_recording

ALIAS_BOMB = (
    "[" + ", ".join(["&a [x,x,x,x,x,x,x,x,x]"] + [f"&{c} [" + ",".join([f"*{p}"] * 9) + "]" for p, c in zip("abcdefgh", "bcdefghi")]) + "]"
)
ROI = "44,38,6,6"


@pytest.fixture(scope="module")
def fixture(tmp_path_factory):
    return build_fixture(tmp_path_factory.mktemp("errors") / "fixture")


@pytest.fixture
def work(fixture):
    w = make_workspace(fixture)
    yield w
    shutil.rmtree(w.parent, ignore_errors=True)


def edit_yaml(path, change):
    data = yaml.safe_load(path.read_text())
    change(data)
    path.write_text(yaml.safe_dump(data, sort_keys=False))


def refused(work, argv, *fragments):
    """The command exits 2 with one line holding every fragment, and changes nothing."""
    outcome = run_cli(argv, work)
    check(outcome)
    assert outcome.rc == 2, outcome.describe()
    line = outcome.err_lines[-1]
    for fragment in fragments:
        assert fragment in line, outcome.describe()
    return line


TRACK = ["track", "rec", "--quiet"]


# ------------------------------------------------------------------ internal errors (exit 3) that are user errors


@pytest.mark.parametrize(
    "rel, argv",
    [
        ("calib.yaml", [*TRACK, "--calib", "calib.yaml"]),
        ("config.yaml", [*TRACK, "--config", "config.yaml"]),
        ("rec/meta.yaml", TRACK),
        ("rec/frames.csv", TRACK),
    ],
)
def test_random_bytes_as_a_file_are_one_line(work, rel, argv):
    (work / rel).write_bytes(np.random.default_rng(16).integers(0, 256, 4096, dtype=np.uint8).tobytes())
    refused(work, argv, str(rel).split("/")[-1], "not UTF-8")


def test_an_unreadable_file_is_one_line(work, tmp_path):
    (work / "config.yaml").chmod(0)
    if os.geteuid() == 0:  # root reads anything: read as nobody in a real process
        shutil.chown(work.parent, "nobody")
        for p in [work.parent, *work.rglob("*")]:
            shutil.chown(p, "nobody")
        r = subprocess.run(
            [sys.executable, "-m", "stereotrack", *TRACK, "--config", "config.yaml"],
            cwd=work,
            capture_output=True,
            text=True,
            timeout=60,
            user="nobody",
            env=dict(os.environ, PYTHONDONTWRITEBYTECODE="1", NUMBA_CACHE_DIR=str(work.parent / "numba")),  # nobody cannot write ours
        )
        assert r.returncode == 2 and r.stderr.strip().count("\n") == 0 and "permission denied" in r.stderr.lower(), r.stderr
    else:
        refused(work, [*TRACK, "--config", "config.yaml"], "config.yaml", "Permission denied")


@pytest.mark.parametrize(
    "text, fragment",
    [
        ("targets:\n- {name: pink, hsv_min: [.inf, 103, 48], hsv_max: [174, 255, 255]}\n", "hsv_min"),
        ("tracker: {particles: .inf}\n", "particles"),
        ("targets:\n- {name: pink, hsv_min: [150, 103, 48], hsv_max: [174, 255, 255]}\ntracker: {seed: -1}\n", "seed"),
    ],
)
def test_non_finite_or_negative_settings_are_one_line(work, text, fragment):
    (work / "config.yaml").write_text(text)
    refused(work, [*TRACK, "--config", "config.yaml"], "config.yaml", fragment)


@pytest.mark.parametrize("field, value", [("fps", "fast"), ("image_size", [320])])
def test_meta_yaml_of_the_wrong_kind_is_one_line(work, field, value):
    edit_yaml(work / "rec/meta.yaml", lambda m: m.__setitem__(field, value))
    refused(work, TRACK, "meta.yaml", field)


def test_rrd_where_nothing_can_be_written_is_one_line_and_keeps_tracks(work):
    before = (work / "rec/tracks.csv").read_bytes()
    refused(work, [*TRACK, "--rrd", "/proc/nope.rrd"], "--rrd")
    assert (work / "rec/tracks.csv").read_bytes() == before


@pytest.mark.parametrize(
    "argv, fragment",
    [
        (["synth", "pendulum4", "--out", "new", "--fps", "nan"], "--fps"),
        (["synth", "pendulum4", "--out", "new", "--width", "30000", "--height", "30000"], "--width"),
        (["bench", "--frames", "-1"], "--frames"),
        (["eval", "tracks.csv", "truth.csv", "--gate", "nan"], "--gate"),
        (["colour", "learn", "rec", "--roi", ROI, "--name", "pink", "--radius", "-1"], "--radius"),
        (["colour", "learn", "rec", "--roi", ROI, "--name", "pink", "--radius", "nan"], "--radius"),
        ([*TRACK, "--frames", "0"], "--frames"),
    ],
)
def test_numbers_out_of_range_are_refused_before_anything_runs(work, argv, fragment):
    refused(work, argv, fragment)


def test_a_yaml_alias_bomb_is_refused_at_once(work):
    (work / "config.yaml").write_text(f"tracker: {{particles: {ALIAS_BOMB}}}\n")
    outcome = run_cli([*TRACK, "--config", "config.yaml"], work)
    check(outcome)
    assert outcome.rc == 2 and "alias" in outcome.err and outcome.seconds < 5, outcome.describe()


# ------------------------------------------------------------------ user files destroyed


@pytest.mark.parametrize(
    "flag, rel", [("--out", "rec/frames.csv"), ("--rrd", "rec/cam0.avi"), ("--out", "rec/meta.yaml"), ("--out", "rec/config.yaml")]
)
def test_outputs_never_replace_a_recordings_own_files(work, flag, rel):
    refused(work, [*TRACK, flag, rel], flag, rel)


@pytest.mark.parametrize("command", ["synth", "record"])
def test_overwrite_never_empties_a_folder_that_is_not_a_recording(work, command):
    (work / "docs/sub").mkdir(parents=True)
    (work / "docs/thesis.txt").write_text("a user's file\n")
    source = ["synth", "pendulum4"] if command == "synth" else ["record", "--cam0", "sim:dots", "--cam1", "sim:dots", "--seconds", "1"]
    refused(work, [*source, "--out", "docs", "--overwrite"], "--out docs", "not a recording")
    assert (work / "docs/thesis.txt").read_text() == "a user's file\n" and (work / "docs/sub").is_dir()


def test_overwrite_replaces_an_earlier_recording(work):
    outcome = run_cli(["synth", "pendulum4", "--frames", "2", "--width", "64", "--height", "48", "--out", "rec", "--overwrite"], work)
    check(outcome, ("rec/*",))
    assert outcome.rc == 0 and open_recording(work / "rec").n_frames == 2


def test_a_recording_that_got_no_pair_is_one_line(work):
    refused(work, ["record", "--cam0", "sim:dots", "--cam1", "sim:dots", "--fps", "1", "--seconds", "0.3", "--out", "new"], "no frame pair")


def test_a_failing_track_leaves_the_previous_tracks_file(work):
    before = (work / "rec/tracks.csv").read_bytes()
    (work / "dir.rrd").mkdir()
    refused(work, [*TRACK, "--rrd", "dir.rrd"], "--rrd", "folder")
    assert (work / "rec/tracks.csv").read_bytes() == before


def test_a_symlinked_output_is_not_followed(work):
    victim = work / "victim.txt"
    victim.write_text("a user's file\n")
    (work / "rec/tracks.csv").unlink()
    (work / "rec/tracks.csv").symlink_to(victim)
    refused(work, TRACK, "symbolic link")
    assert victim.read_text() == "a user's file\n"


def test_an_output_replaces_only_an_earlier_output_of_its_kind(work):
    (work / "notes.csv").write_text("my notes\n")
    refused(work, [*TRACK, "--out", "notes.csv"], "not a tracks CSV")
    outcome = run_cli([*TRACK, "--out", "tracks.csv"], work)  # an earlier tracks file: a re-run replaces it
    check(outcome, ("tracks.csv",))
    assert outcome.rc == 0 and (work / "tracks.csv").read_text().startswith("frame,time,track_id")


def test_ctrl_c_keeps_what_was_tracked_and_a_failure_keeps_the_old_file(work, monkeypatch):
    from stereotrack.sinks.tracks_csv import TracksCsvSink

    out = work / "t.csv"
    out.write_text("frame,time,track_id,x,y,z\n0,0,1,0,0,1\n")
    sink = TracksCsvSink(out)
    try:
        raise ValueError("a failure in the middle of a run")
    except ValueError:
        sink.close()
    assert out.read_text() == "frame,time,track_id,x,y,z\n0,0,1,0,0,1\n" and not list(work.glob(".t.csv.*"))
    sink = TracksCsvSink(out)
    try:
        raise KeyboardInterrupt
    except KeyboardInterrupt:
        sink.close()
    assert out.read_text().startswith("frame,time,track_id,x,y,z,sx") and not list(work.glob(".t.csv.*"))


# ------------------------------------------------------------------ bad values stored or accepted silently


def test_colour_learn_stores_no_bad_radius(work):
    before = (work / "rec/config.yaml").read_bytes()
    refused(work, ["colour", "learn", "rec", "--roi", ROI, "--name", "pink", "--radius", "-1"], "--radius")
    assert (work / "rec/config.yaml").read_bytes() == before


def test_calibration_with_nan_distortion_is_refused(work):
    edit_yaml(work / "calib.yaml", lambda c: c["cameras"][0].__setitem__("dist", [float("nan"), 0, 0, 0, 0]))
    refused(work, [*TRACK, "--calib", "calib.yaml"], "calib.yaml", "dist")


def test_cameras_are_matched_by_name_not_by_position(work):
    base = run_cli([*TRACK, "--out", "base.csv"], work)
    edit_yaml(work / "rec/meta.yaml", lambda m: m.__setitem__("cameras", ["cam1", "cam0"]))
    lines = (work / "rec/frames.csv").read_text().splitlines()
    swapped = ["frame,t_cam1,t_cam0"] + [",".join([r.split(",")[0], r.split(",")[2], r.split(",")[1]]) for r in lines[1:]]
    (work / "rec/frames.csv").write_text("\n".join(swapped) + "\n")
    outcome = run_cli([*TRACK, "--out", "swapped.csv"], work)
    check(outcome, ("swapped.csv",))
    assert (work / "swapped.csv").read_text() == (work / "base.csv").read_text(), (base.err, outcome.err)


def test_calibration_of_other_cameras_is_refused(work):
    edit_yaml(work / "calib.yaml", lambda c: [cam.__setitem__("name", n) for cam, n in zip(c["cameras"], ["left", "right"])])
    refused(work, [*TRACK, "--calib", "calib.yaml"], "left, right", "cam0, cam1")


@pytest.mark.parametrize(
    "row, fragment", [(3, "3,0.010000,0.010000"), (3, "3,nan,0.1"), (3, "3,abc,0.1")], ids=["backwards", "nan", "garbage"]
)
def test_bad_frames_csv_rows_are_refused_with_their_line(work, row, fragment):
    path = work / "rec/frames.csv"
    lines = path.read_text().splitlines()
    lines[row + 1] = fragment
    path.write_text("\n".join(lines) + "\n")
    refused(work, TRACK, "frames.csv", f"line {row + 2}")


def test_a_cut_last_line_of_frames_csv_is_still_read(work):
    path = work / "rec/frames.csv"
    path.write_text(path.read_text() + "6,0.2")
    outcome = run_cli([*TRACK, "--out", "t.csv"], work)
    check(outcome, ("t.csv",))
    assert outcome.rc == 0


# ------------------------------------------------------------------ paths outside the folder


@pytest.mark.parametrize("value", ["../outside.yaml", "/tmp/stereotrack-outside.yaml"])
def test_targets_outside_the_recording_are_refused(work, value):
    edit_yaml(work / "rec/meta.yaml", lambda m: m.__setitem__("targets", value))
    refused(work, ["colour", "learn", "rec", "--roi", ROI, "--name", "pink"], "targets", "outside the recording")
    assert not (work.parent / "outside.yaml").exists() and not os.path.exists("/tmp/stereotrack-outside.yaml")


def test_absolute_video_paths_are_refused(work):
    edit_yaml(work / "rec/meta.yaml", lambda m: m["videos"].__setitem__("cam0", str(work / "rec" / "cam0.avi")))
    refused(work, TRACK, "videos.cam0", "outside the recording")


# ------------------------------------------------------------------ smaller


def test_calibration_report_keys_stay_strings(tmp_path):
    from stereotrack.calibration.report import save_report

    save_report({"worst views": {"08": 0.3, "12": 0.2}}, tmp_path / "r.report.yaml")
    text = (tmp_path / "r.report.yaml").read_text()
    assert "'08':" in text and "'12':" in text


def test_a_target_that_matches_nothing_warns_without_a_python_warning(work):
    (work / "config.yaml").write_text("targets:\n- {name: none, hsv_min: [90, 254, 254], hsv_max: [91, 255, 255]}\n")
    outcome = run_cli([*TRACK, "--config", "config.yaml", "--out", "t.csv"], work)
    check(outcome, ("t.csv",))
    assert "matched nothing" in outcome.err and "Warning:" not in outcome.err


def test_colour_learn_takes_debug_and_there_is_a_version(work):
    outcome = run_cli(["colour", "learn", "rec", "--roi", ROI, "--name", "pink", "--debug"], work)
    check(outcome, ("rec/config.yaml", "rec/pink.colour-model.yaml"))
    assert outcome.rc == 0
    outcome = run_cli(["--version"], work)
    assert outcome.rc == 0 and "stereotrack 0." in outcome.out


def test_a_usage_error_is_one_line(work):
    line = refused(work, ["track", "rec", "--start", "abc"], "--start", "'abc'", "stereotrack track --help")
    assert line.startswith("error: --start: expected a whole number")


def test_a_message_stays_one_line_whatever_the_names_hold(work):
    refused(work, ["track", "no\nsuch\nfolder"], "no\\nsuch\\nfolder")


def test_output_files_are_written_whole_with_their_mode(work):
    (work / "rec/tracks.csv").chmod(0o640)
    outcome = run_cli(TRACK, work)
    check(outcome, ("rec/tracks.csv",))
    assert stat.S_IMODE((work / "rec/tracks.csv").stat().st_mode) == 0o640 and not list((work / "rec").glob(".tracks.csv.*"))
