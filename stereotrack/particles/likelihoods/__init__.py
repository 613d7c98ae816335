"""Likelihood models, p(z | x): how well each particle's position matches this frame's evidence.

A model is one class in one file of this folder, named by the file
(``tracker.likelihood: colour_window`` picks ``colour_window.py``):

    class Model:
        @classmethod
        def from_settings(cls, settings: TrackerSettings, target: Target) -> Model: ...
        def __call__(self, positions, views, occluders) -> np.ndarray: ...

``positions`` are N x 3 world points, ``views`` the target's
``CameraEvidence`` per camera, ``occluders`` the tracked balls of other
colours that may hide a particle (or None); it returns N likelihoods, 1 for
a perfect match. Its own settings go in ``config.TrackerSettings``.
"""

from __future__ import annotations

import importlib
import pkgutil
from collections.abc import Sequence
from typing import Protocol

import numpy as np

from ...config import Target, TrackerSettings
from ...errors import StereotrackError
from ...evidence.gather import CameraEvidence
from ...results import TrackedBalls


class Likelihood(Protocol):
    def __call__(self, positions: np.ndarray, views: Sequence[CameraEvidence], occluders: TrackedBalls | None) -> np.ndarray: ...


def available() -> list[str]:
    """The model names: one per file of this folder."""
    return sorted(m.name for m in pkgutil.iter_modules(__path__) if not m.name.startswith("_"))


def make_likelihood(settings: TrackerSettings, target: Target) -> Likelihood:
    """The model ``settings.likelihood`` names, set up for ``target``."""
    if settings.likelihood not in available():
        raise StereotrackError(f"tracker.likelihood: unknown model {settings.likelihood!r} (available: {', '.join(available())})")
    module = importlib.import_module(f"{__name__}.{settings.likelihood}")
    return module.Model.from_settings(settings, target)
