"""`stereotrack colour learn` as a user runs it (in this process, tests/fuzzing.run_cli): several regions, --auto,
the colour model file beside the config, and every refusal leaving the user's config as it was."""

import re
import shutil
import subprocess
import sys

import numpy as np
import pytest
import yaml
from fuzzing import check, run_cli

from stereotrack.evidence.colour_model import load_colour_model
from stereotrack.recording import open_recording, read_truth
from stereotrack.simulation.presets import make_preset
from stereotrack.simulation.write import render_scene

SEPARATION = re.compile(
    r"separates the ball from the rest of the range by (-?[\d.]+) on the images it learnt from(, (-?[\d.]+) on images it did not)?"
)


@pytest.fixture(scope="module")
def scenes(tmp_path_factory):
    root = tmp_path_factory.mktemp("colour")
    render_scene(make_preset("pendulum4", n_frames=24, width=320, height=240), root / "swing", progress=False)
    render_scene(make_preset("static2", n_frames=8, width=320, height=240), root / "still", progress=False)
    return root


@pytest.fixture
def work(scenes, tmp_path):
    shutil.copytree(scenes, tmp_path / "w")
    return tmp_path / "w"


def ball_box(rec_folder, camera: int, frame: int, ball: int = 0, scale: float = 1.3) -> str:
    """CAMERA:FRAME:x,y,w,h of a box ``scale`` times a ball's apparent diameter, from the scene's truth."""
    rec = open_recording(rec_folder)
    truth = read_truth(rec_folder / "truth.csv")
    cam = rec.rig[camera]
    (u, v), _, depth = (a[0] for a in cam.view(truth[truth[:, 0] == frame][ball : ball + 1, 2:5]))
    half = scale * float(cam.apparent_radius(0.035, depth))
    return f"{cam.name}:{frame}:{int(u - half)},{int(v - half)},{int(2 * half)},{int(2 * half)}"


def test_several_regions_write_a_target_and_its_colour_model_beside_the_config(work):
    regions = [ball_box(work / "swing", 0, 0), ball_box(work / "swing", 1, 10, 1), ball_box(work / "swing", 0, 20, 2)]
    argv = ["colour", "learn", "swing", "--name", "pinkish", *(a for r in regions for a in ("--region", r))]
    outcome = run_cli(argv, work)
    check(outcome, ("swing/config.yaml", "swing/pinkish.colour-model.yaml"))
    assert outcome.rc == 0, outcome.describe()
    inside, _, held_out = SEPARATION.search(outcome.err).groups()
    assert held_out is not None and -1 <= float(held_out) <= 1  # three images: a held-out figure
    target = next(t for t in yaml.safe_load((work / "swing/config.yaml").read_text())["targets"] if t["name"] == "pinkish")
    assert target["colour_model"] == "pinkish.colour-model.yaml"  # beside the config, named relative to it
    assert load_colour_model(work / "swing" / target["colour_model"]).shape == (45, 32)  # the tracker's loader reads it


def test_auto_finds_the_swinging_balls_measures_their_radius_and_proposes_a_target(work):
    before = (work / "swing/config.yaml").read_text()
    outcome = run_cli(["colour", "learn", "swing", "--auto", "--config", "auto.yaml"], work)
    check(outcome, ("auto.yaml", "pink.colour-model.yaml"))
    assert outcome.rc == 0, outcome.describe()
    snippet = yaml.safe_load(outcome.out)["targets"]
    written = yaml.safe_load((work / "auto.yaml").read_text())["targets"]
    assert snippet == written and [t["name"] for t in written] == ["pink"]  # one colour, named by its hue
    t = written[0]
    assert t["hsv_min"][0] <= 165 <= t["hsv_max"][0] and abs(t["radius"] - 0.035) < 0.0035 and "(measured)" in outcome.err
    assert t["colour_model"] == "pink.colour-model.yaml" and SEPARATION.search(outcome.err).group(3) is not None
    assert (work / "swing/config.yaml").read_text() == before
    # A real process (no in-process time limit: a busy machine may still be loading the tracker's kernels).
    tracked = subprocess.run([sys.executable, "-m", "stereotrack", "track", "swing", "--config", "auto.yaml", "--quiet", "--out", "t.csv"],
                             cwd=work, capture_output=True, text=True, timeout=300)  # fmt: skip
    assert tracked.returncode == 0 and float(re.search(r"MOTA (-?[\d.]+)", tracked.stderr).group(1)) > 0.75, tracked.stderr


@pytest.mark.parametrize(
    "argv, fragment",
    [
        (["still", "--auto"], "no moving, round ball of one hue found in 8 frames"),
        (["swing", "--region", "0:10,200,30,30", "--name", "pink"], "no ball in it"),
        (["swing", "--region", "cam1:3:300,200,40,40", "--name", "pink"], "is not inside the 320x240 image"),
        (["swing", "--region", "cam7:3:10,10,20,20", "--name", "pink"], "camera 'cam7'"),
        (["swing", "--region", "99:10,10,20,20", "--name", "pink"], "outside the recording's 24 frames"),
        (["swing", "--region", "10,10,20,20"], "--name"),
        (["swing", "--auto", "--region", "10,10,20,20"], "not both"),
    ],
    ids=["auto, nothing moves", "no ball", "outside the image", "no such camera", "no such frame", "no name", "auto and region"],
)
def test_bad_input_is_one_line_and_the_config_is_left_as_it_was(work, argv, fragment):
    outcome = run_cli(["colour", "learn", *argv], work)
    check(outcome)  # exit 2 with one line, nothing changed or left behind
    assert outcome.rc == 2 and fragment in outcome.err_lines[-1], outcome.describe()


def test_a_users_file_where_the_model_would_go_is_never_replaced(work):
    (work / "swing/pink.colour-model.yaml").write_text("my notes about the pink ball\n")
    outcome = run_cli(["colour", "learn", "swing", "--region", ball_box(work / "swing", 0, 0), "--name", "pink"], work)
    check(outcome)
    assert outcome.rc == 2 and "exists and is not a colour model" in outcome.err_lines[-1]
    # An earlier model is an output of the same kind: learning again replaces it.
    (work / "swing/pink.colour-model.yaml").unlink()
    for _ in range(2):
        again = run_cli(["colour", "learn", "swing", "--region", ball_box(work / "swing", 0, 0), "--name", "pink"], work)
        assert again.rc == 0, again.describe()


@pytest.mark.parametrize("damage", ["missing", "truncated", "other version"])
def test_a_damaged_colour_model_stops_the_tracker_with_one_line(work, damage):
    assert run_cli(["colour", "learn", "swing", "--region", ball_box(work / "swing", 0, 0), "--name", "pink"], work).rc == 0
    model = work / "swing/pink.colour-model.yaml"
    text = model.read_text()
    if damage == "missing":
        model.unlink()
    elif damage == "truncated":
        model.write_text(text[: len(text) // 3])
    else:
        model.write_text(text.replace("version: 1", "version: 7"))
    outcome = run_cli(["track", "swing", "--quiet", "--out", "t.csv"], work)
    check(outcome)
    assert outcome.rc == 2 and "pink.colour-model.yaml" in outcome.err_lines[-1] and "learn it again" in outcome.err_lines[-1]


def test_the_old_single_roi_command_line_still_works(work):
    box = ball_box(work / "swing", 0, 0).split(":")[-1]
    outcome = run_cli(["colour", "learn", "swing", "--frame", "0", "--camera", "cam0", "--roi", box, "--name", "pink"], work)
    check(outcome, ("swing/config.yaml", "swing/pink.colour-model.yaml"))
    assert outcome.rc == 0 and SEPARATION.search(outcome.err).group(3) is None  # one image: no held-out figure
    assert np.isfinite(float(SEPARATION.search(outcome.err).group(1)))
