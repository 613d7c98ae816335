"""Fuzzing every file format and every command's options (hypothesis; see tests/fuzzing.py).

For any input the command exits 0, or exits 2 with one line on stderr; no
traceback; no file changed unless it is the command's own output and the
command succeeded; within 30 s. A few dozen examples per property run here
(derandomized, so CI is repeatable); ``benchmarks/fuzz.py`` runs thousands.
"""

import os
import shutil

import pytest
from fuzzing import build_fixture, check, csv_documents, make_workspace, option_values, run_cli, yaml_documents
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

EXAMPLES = int(os.environ.get("STEREOTRACK_FUZZ_EXAMPLES", "8"))
fuzz_settings = settings(
    max_examples=EXAMPLES,
    deadline=None,
    derandomize=not os.environ.get("STEREOTRACK_FUZZ_RANDOM"),  # the suite is repeatable; benchmarks/fuzz.py explores
    database=None,
    suppress_health_check=[
        HealthCheck.too_slow,
        HealthCheck.function_scoped_fixture,
        HealthCheck.data_too_large,
        HealthCheck.filter_too_much,
    ],
)
ROI = "44,38,6,6"  # around a ball in frame 0 of the fixture's cam0

# format -> (file it replaces, how it is broken, the command that reads it, the outputs the command may write)
TRACK = ["track", "rec", "--quiet", "--out", "out.csv"]
FILES = {
    "calibration": ("calib.yaml", "yaml", ["track", "rec", "--calib", "calib.yaml", "--quiet", "--out", "out.csv"], ("out.csv",)),
    "config": ("config.yaml", "yaml", ["track", "rec", "--config", "config.yaml", "--quiet", "--out", "out.csv"], ("out.csv",)),
    "meta.yaml": ("rec/meta.yaml", "yaml", TRACK, ("out.csv",)),
    "targets file": (
        "rec/config.yaml",
        "yaml",
        ["colour", "learn", "rec", "--roi", ROI, "--name", "pink"],
        ("rec/config.yaml", "rec/pink.colour-model.yaml"),
    ),  # fmt: skip
    "frames.csv": ("rec/frames.csv", "csv", TRACK, ("out.csv",)),
    "truth.csv": ("truth.csv", "csv", ["eval", "tracks.csv", "truth.csv"], ()),
    "recording truth.csv": ("rec/truth.csv", "csv", TRACK, ("out.csv",)),
    "tracks.csv": ("tracks.csv", "csv", ["eval", "tracks.csv", "truth.csv"], ()),
    "board": ("board.yaml", "yaml", ["board", "board.yaml", "--out", "b.png", "--dpi", "60"], ("b.png",)),
    "scene": ("scene.yaml", "yaml", ["synth", "scene.yaml", "--out", "new", "--frames", "2", "--no-progress"], ("new/*",)),
    "image": (
        "left/left01.jpg",
        "bytes",
        ["calibrate", "--images", "left", "right", "--board", "chess.yaml", "--out", "out/rig.yaml", "--no-progress"],
        ("out/*",),
    ),
    "video": ("rec/cam0.avi", "bytes", TRACK, ("out.csv",)),
}


@pytest.fixture(scope="module")
def fixture(tmp_path_factory):
    return build_fixture(tmp_path_factory.mktemp("fuzz") / "fixture")


@st.composite
def broken_bytes(draw, valid: bytes) -> bytes:
    how = draw(st.sampled_from(["random", "truncate", "flip", "empty"]))
    if how == "random":
        return draw(st.binary(max_size=4000))
    if how == "truncate":
        return valid[: draw(st.integers(0, len(valid)))]
    if how == "empty":
        return b""
    data = bytearray(valid)
    for _ in range(draw(st.integers(1, 16))):
        data[draw(st.integers(0, len(data) - 1))] = draw(st.integers(0, 255))
    return bytes(data)


@pytest.mark.parametrize("name", list(FILES))
@fuzz_settings
@given(data=st.data())
def test_any_file_content_exits_0_or_one_line(fixture, name, data):
    rel, kind, argv, outputs = FILES[name]
    work = make_workspace(fixture)
    try:
        valid = (work / rel).read_bytes()
        if kind == "yaml":
            content = data.draw(yaml_documents(valid.decode()), label=rel)
        elif kind == "csv":
            content = data.draw(csv_documents(valid.decode()), label=rel)
        else:
            content = data.draw(broken_bytes(valid), label=rel)
        (work / rel).write_bytes(content)
        check(run_cli(argv, work, f"file {name}"), outputs)
    finally:
        shutil.rmtree(work.parent, ignore_errors=True)


small_counts = st.one_of(st.sampled_from(["0", "-1", "nan", "inf", "1e9", "abc", ""]), st.integers(-3, 3).map(str))
small_dpi = st.one_of(st.sampled_from(["0", "-1", "nan", "inf", "49", "2401", "1e9", "abc", "", "--"]), st.integers(50, 200).map(str))
small_seconds = st.one_of(
    st.sampled_from(["0", "-1", "nan", "inf", "-inf", "1e-9", "abc", ""]), st.floats(0.05, 0.6).map(lambda x: f"{x:.2f}")
)

# command -> (base argv, {option: values}, outputs). Options that mean more work when valid draw small values.
OPTIONS = {
    "track": (
        ["track", "rec", "--quiet", "--out", "out.csv", "--rrd", "out.rrd"],
        {
            "--start": option_values,
            "--frames": small_counts,
            "--viz-every": option_values,
            "--viz-max-particles": option_values,
            "--viz-jpeg-quality": option_values,
            "--viz-image-scale": option_values,
            "--viz-trail": option_values,
        },
        ("out.csv", "out.rrd"),
    ),
    "eval": (["eval", "tracks.csv", "truth.csv"], {"--gate": option_values}, ()),
    "colour learn": (
        ["colour", "learn", "rec", "--name", "pink", "--config", "new.yaml", "--model", "m.yaml", "--roi", ROI],
        {"--frame": option_values, "--roi": option_values, "--radius": option_values, "--camera": option_values, "--name": option_values},
        ("new.yaml", "m.yaml"),
    ),
    "synth": (
        ["synth", "pendulum4", "--out", "new", "--no-progress", "--frames", "1", "--width", "64", "--height", "48"],
        {
            "--fps": option_values,
            "--seed": option_values,
            "--cameras": st.sampled_from(["1", "2", "3", "0", "-2", "9", "nan", "x"]),
            "--baseline": option_values,
            "--width": small_counts,
            "--height": small_counts,
            "--frames": small_counts,
        },
        ("new/*",),
    ),
    "board": (["board", "board.yaml", "--out", "b.png"], {"--dpi": small_dpi}, ("b.png",)),
    "calibrate": (
        ["calibrate", "--images", "left", "right", "--board", "chess.yaml", "--out", "out/rig.yaml", "--no-progress"],
        {"--max-views": option_values, "--subpix": option_values, "--drop-worst": option_values},
        ("out/*",),
    ),
    "record": (
        ["record", "--cam0", "sim:dots", "--cam1", "sim:dots", "--out", "new", "--seconds", "0.3"],
        {
            "--seconds": small_seconds,
            "--fps": option_values,
            "--width": small_counts,
            "--height": small_counts,
            "--stall-timeout": small_seconds,
            "--exposure": option_values,
            "--gain": option_values,
            "--fourcc": option_values,
        },
        ("new/*",),
    ),
    "live": (
        [
            "live",
            "--cam0",
            "sim:pendulum4",
            "--cam1",
            "sim:pendulum4",
            "--width",
            "160",
            "--height",
            "120",
            "--seconds",
            "0.3",
            "--quiet",
            "--out",
            "out.csv",
            "--rrd",
            "out.rrd",
        ],
        {
            "--seconds": small_seconds,
            "--stall-timeout": small_seconds,
            "--viz-every": option_values,
            "--viz-image-scale": option_values,
            "--viz-trail": option_values,
        },
        ("out.csv", "out.rrd"),
    ),
    "cameras": (["cameras", "--cam0", "sim:dots", "--cam1", "sim:dots", "--seconds", "0.3"], {"--seconds": small_seconds}, ()),
    "bench": (["bench", "--quick"], {"--frames": st.sampled_from(["0", "-1", "10", "nan", "inf", "1e9", "abc", str(10**9)])}, ()),
}


@pytest.mark.parametrize("command", list(OPTIONS))
@fuzz_settings
@given(data=st.data())
def test_any_option_value_exits_0_or_one_line(fixture, command, data):
    base, options, outputs = OPTIONS[command]
    chosen = data.draw(st.lists(st.sampled_from(sorted(options)), min_size=1, max_size=3, unique=True), label="options")
    argv = list(base)
    for flag in chosen:
        value = data.draw(options[flag], label=flag)
        argv.append(f"{flag}={value}")  # '=' so a value that starts with '-' stays a value
    work = make_workspace(fixture)
    try:
        check(run_cli(argv, work, f"options {command}"), outputs)
    finally:
        shutil.rmtree(work.parent, ignore_errors=True)


SIM_OPTIONS = st.sampled_from(["view", "jitter", "drop", "stop", "seed", "loop", "bogus"])


@fuzz_settings
@given(options=st.lists(st.tuples(SIM_OPTIONS, option_values), max_size=3))
def test_any_simulated_camera_spec_exits_0_or_one_line(fixture, options):
    spec = "sim:dots" + "".join(f",{k}={v}" for k, v in options)
    work = make_workspace(fixture)
    try:
        check(run_cli(["record", "--cam0", spec, "--cam1", "sim:dots", "--out", "new", "--seconds", "0.3"], work, "sim camera"), ("new/*",))
    finally:
        shutil.rmtree(work.parent, ignore_errors=True)


# command -> (argv before its output flag's value, the user files it may change when it succeeds besides the output)
OUTPUT_COMMANDS = {
    "track --out": (["track", "rec", "--quiet", "--out"], ()),
    "track --rrd": (["track", "rec", "--quiet", "--frames", "2", "--out", "o.csv", "--rrd"], ("o.csv",)),
    "synth --out": (["synth", "pendulum4", "--no-progress", "--frames", "1", "--width", "64", "--height", "48", "--out"], ()),
    "record --out": (["record", "--cam0", "sim:dots", "--cam1", "sim:dots", "--seconds", "0.3", "--out"], ()),
    "board --out": (["board", "board.yaml", "--dpi", "60", "--out"], ()),
    "calibrate --out": (["calibrate", "--images", "left", "right", "--board", "chess.yaml", "--no-progress", "--out"], ()),
    "calibrate --rrd": (
        ["calibrate", "--images", "left", "right", "--board", "chess.yaml", "--no-progress", "--out", "o.yaml", "--rrd"],
        ("o.yaml", "o.report.yaml"),
    ),
    "colour learn --config": (["colour", "learn", "rec", "--name", "pink", "--roi", ROI, "--model", "m.yaml", "--config"], ("m.yaml",)),
}
# Where an output may point: a recording's own files, a user's files, folders, a link, inputs, nonsense, new places.
OUTPUT_PATHS = [
    *("rec/frames.csv", "rec/meta.yaml", "rec/cam0.avi", "rec/calib.yaml", "rec/truth.csv", "rec/config.yaml", "rec/tracks.csv"),
    *("rec", ".", "left", "left/left01.jpg", "docs", "docs/thesis.txt", "notes.txt", "link.txt", "dangling.csv"),
    *("calib.yaml", "config.yaml", "truth.csv", "tracks.csv", "board.yaml", "chess.yaml"),
    *("", " ", "/proc/nope/out", "new/deeper/out.csv", "new.png", "new.yaml", "out.rrd"),
]
FOLDER_PATHS = ["rec", ".", "left", "docs", "docs/sub", "notes.txt", "link.txt", "rec/frames.csv", "", "/proc/nope/out", "new/deeper"]
# What a successful run may replace when the output names it: an earlier output of the command's kind.
REPLACEABLE = {
    "track --out": {"rec/tracks.csv", "tracks.csv"},
    "colour learn --config": {"rec/config.yaml", "config.yaml"},
    "synth --out": {"rec"},  # with --overwrite: an earlier recording
    "record --out": {"rec"},
}


@pytest.mark.parametrize("command", list(OUTPUT_COMMANDS))
@fuzz_settings
@given(data=st.data())
def test_any_output_path_harms_no_user_file(fixture, command, data):
    """An output named anywhere: a new place or an earlier output of its kind is written; anything else is refused
    in one line and left as it was (a recording's files, a user's files and folders, a link, the run's inputs)."""
    base, others = OUTPUT_COMMANDS[command]
    folder = command in ("synth --out", "record --out")
    target = data.draw(st.sampled_from(FOLDER_PATHS if folder else OUTPUT_PATHS), label="output")
    argv = [*base, target]
    if folder and data.draw(st.booleans(), label="--overwrite"):
        argv.append("--overwrite")
    work = make_workspace(fixture)
    try:
        (work / "docs/sub").mkdir(parents=True)
        (work / "docs/thesis.txt").write_text("a user's file\n")
        (work / "notes.txt").write_text("a user's notes\n")
        (work / "link.txt").symlink_to("notes.txt")
        (work / "dangling.csv").symlink_to("nowhere.csv")
        path = work / target
        existing = os.path.lexists(path) and not (path.is_dir() and not any(path.iterdir())) if target.strip() else True
        may_replace = not existing or target in REPLACEABLE.get(command, ())
        outputs = (*others, target, f"{target}/*") if may_replace else others
        check(run_cli(argv, work, f"output {command}"), outputs)
    finally:
        shutil.rmtree(work.parent, ignore_errors=True)
