"""Writing a rendered scene as a recording folder (videos, frames.csv, calib.yaml, truth.csv, config.yaml)."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

from ..config import config_to_dict
from ..errors import StereotrackError
from .render import SceneRenderer
from .spec import WORLD_UP, SceneSpec


def render_scene(spec: SceneSpec, out_folder: str | Path, progress: bool = True, codec: str = "mjpg", overwrite: bool = False) -> Path:
    """Render a scene into a recording folder (videos, frames.csv, calib.yaml, truth.csv, config.yaml)."""
    from ..console import Progress
    from ..recording import RecordingWriter

    renderer = SceneRenderer(spec)
    rig = renderer.rig
    out = Path(out_folder)
    writer = RecordingWriter(
        out,
        rig.names,
        (spec.rig.width, spec.rig.height),
        spec.fps,
        rig=rig,
        codec=codec,
        source=f"synthetic: {spec.name} (seed {spec.seed})",
        targets=config_to_dict(spec.config()),
        extra_meta={"up": list(WORLD_UP)},
        overwrite=overwrite,
        truth_fields=("visible", "clear"),
    )
    bar = Progress(spec.n_frames, label=f"rendering {spec.name}", enabled=progress)
    try:
        for i in range(spec.n_frames):
            images, truth = renderer.render(i)
            t = renderer.time(i)
            writer.write(images, [t] * len(images))
            writer.write_truth(i, truth)
            bar.update(1)
    finally:
        writer.close()
        bar.close()
    return out


def ensure_demo_recording(root: str | Path, codec: str = "mjpg") -> Path:
    """``root/recordings/demo``: rendered from ``pendulum4`` (10 s at 30 fps) unless already complete.

    Renders into a temporary folder and renames it into place, so an
    interrupted render never leaves a half demo behind. MJPG by default, like
    a webcam: 9 MB instead of 250 MB of lossless FFV1 (sensor noise does not
    compress), and the target colours still cover 99% of the ball pixels.
    """
    from .presets import make_preset

    root = Path(root)
    demo = root / "recordings" / "demo"
    spec = make_preset("pendulum4", fps=30.0, n_frames=300)
    if _is_complete(demo, spec.n_frames):
        return demo
    tmp = root / "recordings" / f".demo-partial-{os.getpid()}"
    if tmp.exists():
        shutil.rmtree(tmp)
    render_scene(spec, tmp, progress=True, codec=codec)
    if demo.exists():
        shutil.rmtree(demo)
    os.replace(tmp, demo)
    return demo


def _is_complete(folder: Path, n_frames: int) -> bool:
    from ..recording import open_recording

    if not (folder / "meta.yaml").is_file() or not (folder / "truth.csv").is_file():
        return False
    try:
        return open_recording(folder).n_frames == n_frames
    except StereotrackError:
        return False
