"""Settings: declared once with their default, meaning and valid values; the loader and the README read them."""

from __future__ import annotations

import dataclasses
import math
import subprocess
import sys
from pathlib import Path

import pytest

from stereotrack.config import SECTIONS, TrackerSettings, config_from_dict, settings_table
from stereotrack.errors import StereotrackError
from stereotrack.objects.clustering import ClusterSettings
from stereotrack.objects.explain import ExplainSettings

README = Path(__file__).resolve().parents[1] / "README.md"


def test_the_readme_settings_table_is_the_generated_one():
    text = README.read_text()
    section = text.split("<!-- section: settings -->\n")[1].split("\n<!-- /section: settings -->")[0]
    assert section == settings_table(), "regenerate it: python -m stereotrack.config, pasted between the settings markers"


def test_the_module_prints_the_table():
    out = subprocess.run([sys.executable, "-m", "stereotrack.config"], capture_output=True, text=True, check=True, timeout=60)
    assert out.stdout.strip() == settings_table()


def test_every_setting_is_documented_and_numbers_are_bounded():
    for cls in SECTIONS.values():
        for f in dataclasses.fields(cls):
            assert f.metadata.get("doc"), f.name
            if isinstance(f.default, (int, float)) and not isinstance(f.default, bool):
                assert f.metadata["low"] is not None and f.metadata["high"] is not None, f"{cls.__name__}.{f.name} has no range"
                assert f.metadata["low"] <= f.default <= f.metadata["high"], f.name


def test_stage_settings_take_the_trackers_values_and_defaults():
    s = TrackerSettings(cluster_min_mass=0.2, max_objects=3, refine=False, disc_fit=False)
    c, e = ClusterSettings.of(s, 0.04), ExplainSettings.of(s, 0.04)
    assert (c.radius, c.min_mass, c.max_objects, c.min_likelihood) == (0.04, 0.2, 3, s.cluster_min_likelihood)
    assert (e.radius, e.refine, e.disc_fit) == (0.04, False, False)
    assert ClusterSettings(radius=0.04) == ClusterSettings.of(TrackerSettings(), 0.04)  # one default, not two
    assert ExplainSettings(radius=0.04) == ExplainSettings.of(TrackerSettings(), 0.04)


@pytest.mark.parametrize(
    "tracker, words",
    [
        ({"alpha": math.nan}, "finite"),
        ({"alpha": math.inf}, "finite"),
        ({"particles": math.inf}, "expected a int"),
        ({"particles": 1e300}, "between"),
        ({"seed": -1}, "between"),
        ({"alpha": 1.5}, "between"),
        ({"window": 4}, "odd"),
        ({"d_min": 3.0, "d_max": 2.0}, "less than d_max"),
        ({"em": "torch"}, "one of numpy, sklearn"),
        ({"alpah": 0.1}, "did you mean 'alpha'"),
        ({"exclusion": "yes"}, "expected a bool"),
    ],
)
def test_bad_settings_are_refused_naming_file_and_key(tracker, words):
    with pytest.raises(StereotrackError) as err:
        config_from_dict({"tracker": tracker}, "my.yaml")
    assert str(err.value).startswith("my.yaml: 'tracker.") and words in str(err.value)


@pytest.mark.parametrize("named", ["pink.colour-model.yaml", "../models/pink.colour-model.yaml", "/abs/pink.colour-model.yaml"])
def test_a_saved_config_names_its_colour_model_as_the_user_did(tmp_path, monkeypatch, named):
    """The loader resolves colour_model from the config's folder; saving writes it back relative to that folder
    (an earlier version wrote the resolved path, which the next load resolved a second time)."""
    import os

    from stereotrack.config import load_config, save_config

    monkeypatch.chdir(tmp_path)
    os.makedirs("rec")
    path = Path("rec/config.yaml")  # a relative config path, as `colour learn rec` has it
    path.write_text(f"targets:\n- {{name: pink, hsv_min: [150, 80, 80], hsv_max: [170, 255, 255], colour_model: {named}}}\n")
    config = load_config(path)
    save_config(config, path)
    assert f"colour_model: {named}" in path.read_text()
    assert load_config(path).targets[0].colour_model == config.targets[0].colour_model
