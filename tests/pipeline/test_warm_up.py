"""The derived warm-up: a real run compiles nothing the warm-up did not."""

import json
import subprocess
import sys

STEP_AFTER_WARM_UP = """
import json
import numpy as np
import stereotrack.objects.discs as discs
from stereotrack.pipeline import Tracker
from stereotrack.pipeline.tracker import compiled_kernels
from stereotrack.recording import FramePair
from stereotrack.simulation import SceneRenderer, make_preset

spec = make_preset("pendulum4", n_frames=150)  # balls merge into shared blobs: every kernel runs
renderer = SceneRenderer(spec)
tracker = Tracker(renderer.rig, spec.config())  # warms the kernels up
before = compiled_kernels()
fits = []
fit = discs.ball_union_mismatch
discs.ball_union_mismatch = lambda *args: fits.append(1) or fit(*args)
for i in range(150):
    images, _ = renderer.render(i)
    tracker.step(FramePair(i, tuple(images), (renderer.time(i),) * 2))
after = compiled_kernels()
print(json.dumps({"before": before, "after": after, "disc_fits": len(fits)}))
"""


def test_warm_up_compiles_the_signatures_a_tracker_step_uses():
    """A kernel called at run time with other argument types than the warm-up's would compile again, in the
    middle of a frame. In a fresh interpreter, tracking must add no signature to any kernel."""
    out = subprocess.run([sys.executable, "-c", STEP_AFTER_WARM_UP], capture_output=True, text=True, timeout=300, check=True)
    counts = json.loads(out.stdout.strip().splitlines()[-1])
    assert len(counts["before"]) >= 30  # every stage's kernels are registered
    # (a kernel only ever called from inside another kernel shows no signature of its own when loaded from the cache)
    assert counts["after"] == counts["before"]
    assert counts["disc_fits"] > 0  # the disc fit ran too
    assert counts["before"]["stereotrack.evidence.kernels.straight_runs"] == 1  # a white target's, though the run has none
