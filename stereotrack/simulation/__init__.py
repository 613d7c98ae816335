"""Synthetic scenes with exact ground truth: the project's measuring instrument.

- ``spec.py``: what a scene is (rig, balls, occluders, lighting, noise).
- ``presets.py``: named scenes and scene YAML files.
- ``trajectories.py``, ``mocap.py``: how balls move (analytic paths, real motion capture).
- ``render.py``: ``SceneRenderer``, any frame on its own.
- ``write.py``: a scene rendered into a recording folder.
- ``boards.py``: calibration boards rendered into camera views.
- ``stage.py``, ``shapes.py``, ``hands.py``: 3D rooms, props and a juggler's hands, for scenes beyond flat backdrops.
- ``stress.py`` (with ``placing.py``, ``rooms.py``): random stress scenes, one per (category, seed).
"""

from .presets import load_scene_yaml, make_preset
from .render import SceneRenderer, make_background
from .spec import COLOURS, WORLD_UP, BallSpec, Lighting, Occluder, RigSpec, SceneSpec, colour_bgr, target_for_colour
from .write import ensure_demo_recording, render_scene

__all__ = [
    "COLOURS", "WORLD_UP", "BallSpec", "Lighting", "Occluder", "RigSpec", "SceneRenderer", "SceneSpec", "colour_bgr",
    "ensure_demo_recording", "load_scene_yaml", "make_background", "make_preset", "render_scene", "target_for_colour",
]  # fmt: skip
