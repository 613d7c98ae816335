"""run_pipeline: a recording's colour masks made ahead, in another thread, give the same tracks."""

from __future__ import annotations

import threading

import numpy as np

from stereotrack.frames import FramePair
from stereotrack.pipeline.run import run_pipeline
from stereotrack.pipeline.tracker import Tracker
from stereotrack.simulation.presets import make_preset
from stereotrack.simulation.render import SceneRenderer


class Rows:
    def __init__(self):
        self.rows = []

    def write(self, result):
        self.rows += [(result.frame.index, t.track_id, *t.position) for t in result.tracks]

    def close(self):
        pass


class Watched(Tracker):
    """A tracker that notes which threads made colour masks and how many steps got them made ahead."""

    def __init__(self, *args):
        super().__init__(*args)
        self.threads, self.given = set(), 0

    def colours(self, images):
        self.threads.add(threading.current_thread().name)
        return super().colours(images)

    def step(self, pair, colours=None):
        self.given += colours is not None
        return super().step(pair, colours)


def test_colour_masks_made_ahead_give_the_same_tracks():
    spec = make_preset("pendulum4", n_frames=12)
    renderer = SceneRenderer(spec)
    pairs = [FramePair(i, tuple(renderer.render(i)[0]), (renderer.time(i),) * 2) for i in range(spec.n_frames)]
    runs = {}
    for ahead in (False, True):
        tracker, rows = Watched(renderer.rig, spec.config()), Rows()
        summary = run_pipeline(iter(pairs), tracker, [rows], progress=False, ahead=ahead)
        assert summary.frames == 12
        runs[ahead] = (np.array(rows.rows), tracker)
    assert len(runs[True][0]) and np.array_equal(runs[True][0], runs[False][0])
    assert runs[False][1].given == 0 and runs[False][1].threads == set()
    assert runs[True][1].given == 12 and runs[True][1].threads == {"colours_0"}
