"""Draw docs/evidence.png: what the observation model keeps of a target's HSV range, on the `clutter` preset.

Runs the tracker with its default settings over the first frames of the
preset and, at one frame, puts side by side for camera 0: the image (tracks
circled), the pixels in the target's HSV range (before), and the pixels the
observation model counts (after: colour likelier on the ball than in the
room, or moving). The same two layers are logged to the viewer as
``world/cameras/<cam>/mask`` and ``.../evidence`` with ``--viz-masks``.

    .venv/bin/python docs/evidence.py
"""

from __future__ import annotations

import sys
from pathlib import Path

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

FRAME = 60  # two seconds in: the background and colour models have learnt the room


def main() -> int:
    from stereotrack.pipeline.tracker import Tracker
    from stereotrack.simulation.presets import make_preset
    from stereotrack.simulation.render import SceneRenderer

    spec = make_preset("clutter", n_frames=FRAME + 1)
    renderer = SceneRenderer(spec)
    config = spec.config()
    tracker = Tracker(renderer.rig, config)
    for i in range(FRAME + 1):
        result = tracker.step(renderer.pair(i))
    cam = renderer.rig.cameras[0]
    image = result.frame.images[0].copy()
    for track in result.confirmed:
        uv, front, depth = cam.view(track.position[None])
        if front[0]:
            r = int(cam.apparent_radius(np.array([0.035]), depth)[0]) + 6
            cv2.circle(image, (int(uv[0, 0]), int(uv[0, 1])), r, (255, 255, 0), 2)
    before = np.zeros_like(image)
    after = np.zeros_like(image)
    for target in config.targets:
        colour = (255, 255, 255)
        before[result.masks[(target.name, cam.name)] > 0] = colour
        after[result.evidence[(target.name, cam.name)] > 0] = colour
    tiles = []
    for tile, label in ((image, "camera 0 (tracks circled)"), (before, "in the HSV range"), (after, "kept: colour of the ball, or moving")):
        tile = tile.copy()
        cv2.putText(tile, label, (10, 24), cv2.FONT_HERSHEY_SIMPLEX, 0.7, (0, 200, 255), 2, cv2.LINE_AA)
        tiles.append(tile)
    out = np.hstack(tiles)
    out = cv2.resize(out, None, fx=0.6, fy=0.6, interpolation=cv2.INTER_AREA)
    path = ROOT / "docs" / "evidence.png"
    cv2.imwrite(str(path), out)
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
