"""Old import paths keep working: ``stereotrack.viz``, ``stereotrack.synth``, ... name the modules that hold that code now.

Until the package was split into sub-packages every module sat flat in
``stereotrack/``; user scripts may import those names. A finder on
``sys.meta_path`` answers each old name with the module (or package) that
holds its code now, so ``from stereotrack.synth import SceneRenderer`` keeps
working. New code imports from the new places.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import importlib.util
import sys
import types

# old module -> the new module(s) holding its public names, searched in order
MOVED: dict[str, tuple[str, ...]] = {
    "abduction": ("particles.proposal", "evidence.blobs"),
    "baseline": ("pipeline.baseline",),
    "boards": ("calibration.boards",),
    "boardsynth": ("simulation.boards",),
    "calibrate": ("calibration",),
    "clustering": ("objects.clustering", "particles.resampling"),
    "colour": ("evidence.colour",),
    "csvfile": ("files",),
    "devices": ("capture.devices",),
    "discs": ("objects.discs",),
    "explain": ("objects.explain",),
    "likelihood": ("particles.likelihoods.colour_window",),
    "mocap": ("simulation.mocap",),
    "population": ("particles.population", "results"),
    "scenes": ("simulation.presets",),
    "sources": ("capture",),
    "synth": ("simulation",),
    "trackfile": ("sinks.tracks_csv",),
    "trajectories": ("simulation.trajectories",),
    "viz": ("sinks.viewer",),
    "yamlfile": ("files",),
}

# names that left a module that stayed: module -> {name: new module}
MOVED_NAMES: dict[str, dict[str, str]] = {
    "recording": {"RecordingSink": "sinks.recorder"},
}


def moved_name(module: str, name: str):
    """The object an old ``from stereotrack.<module> import <name>`` meant (for that module's ``__getattr__``)."""
    new = MOVED_NAMES.get(module.partition(".")[2], {}).get(name)
    if new is None:
        raise AttributeError(f"module {module!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f"{__package__}.{new}"), name)


class _OldPaths(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    def __init__(self) -> None:
        self._own_spec: dict[str, importlib.machinery.ModuleSpec] = {}

    def find_spec(self, fullname, path=None, target=None):
        package, _, old = fullname.partition(".")
        if package == __package__ and old in MOVED:
            return importlib.util.spec_from_loader(fullname, self)
        return None

    def create_module(self, spec):
        targets = [importlib.import_module(f"{__package__}.{new}") for new in MOVED[spec.name.partition(".")[2]]]
        if len(targets) == 1:
            self._own_spec[spec.name] = targets[0].__spec__  # importlib stamps the alias's spec on it: put it back after
            return targets[0]  # the very module: its functions, classes and state are shared
        merged = types.ModuleType(spec.name, f"Old path; its names now live in {', '.join(t.__name__ for t in targets)}.")

        def __getattr__(name):
            for module in targets:
                if hasattr(module, name):
                    return getattr(module, name)
            raise AttributeError(f"module {spec.name!r} has no attribute {name!r}")

        merged.__getattr__ = __getattr__
        return merged

    def exec_module(self, module):
        own = self._own_spec.pop(module.__spec__.name, None)
        if own is not None:
            module.__spec__ = own


def install() -> None:
    if not any(isinstance(f, _OldPaths) for f in sys.meta_path):
        sys.meta_path.insert(0, _OldPaths())  # before any finder that might still see a stale flat module
