"""What the viewer looks like: display colours, the default blueprint, rotations as quaternions."""

from __future__ import annotations

from typing import Any

import numpy as np

from ...camera import Rig
from ...config import Target

APPLICATION_ID = "stereotrack"


# Cluster colours (matplotlib's tab10, RGB): particles, objects and their 2D windows share them.
PALETTE = np.array(
    [
        [31, 119, 180],
        [255, 127, 14],
        [44, 160, 44],
        [214, 39, 40],
        [148, 103, 189],
        [140, 86, 75],
        [227, 119, 194],
        [188, 189, 34],
        [23, 190, 207],
        [127, 127, 127],
    ],
    dtype=np.uint8,
)


UNCLUSTERED = np.array([150, 150, 150], dtype=np.uint8)


def packed_rgba(rgb: np.ndarray) -> np.ndarray:
    """RGB colours (N x 3 or 3, uint8) -> rerun's packed 0xRRGGBBAA (N, uint32), opaque."""
    rgb = np.asarray(rgb, dtype=np.uint32).reshape(-1, 3)
    return (rgb[:, 0] << 24) | (rgb[:, 1] << 16) | (rgb[:, 2] << 8) | np.uint32(0xFF)


PALETTE_RGBA = packed_rgba(PALETTE)


# Particles by shade: the palette, then unclustered; then the same lighter for abductive particles.
PARTICLE_RGBA = packed_rgba(np.vstack([PALETTE, UNCLUSTERED, (np.vstack([PALETTE, UNCLUSTERED]).astype(np.uint16) + 255) // 2]))


SEQUENTIAL, ABDUCTIVE = 0, 1  # particle class ids


def target_colour(target: Target) -> np.ndarray:
    """A vivid RGB display colour in the middle of the target's hue range."""
    import cv2

    lo, hi = target.hsv_min[0], target.hsv_max[0]
    hue = ((lo + hi + 180) / 2) % 180 if target.wraps else (lo + hi) / 2
    hsv = np.array([[[round(hue), 220, 255]]], dtype=np.uint8)
    return cv2.cvtColor(hsv, cv2.COLOR_HSV2RGB)[0, 0]


def with_alpha(rgb: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """RGB colours (N x 3 or 3) with per-item alpha (N, 0..1) -> N x 4 uint8."""
    alpha = np.asarray(alpha, dtype=float)
    rgb = np.broadcast_to(np.asarray(rgb, dtype=np.uint8), (len(alpha), 3))
    return np.hstack([rgb, np.clip(255 * alpha, 0, 255).astype(np.uint8)[:, None]])


def default_blueprint(rig: Rig, with_truth: bool = False) -> Any:
    """3D view with the cameras, one 2D view per camera, and the time-series panels."""
    import rerun.blueprint as rrb

    # Look over the cameras' shoulders at the space in front of them.
    centre = np.mean([c.centre for c in rig.cameras], axis=0)
    forward = np.mean([c.R[2] for c in rig.cameras], axis=0)
    up = -np.mean([c.R[1] for c in rig.cameras], axis=0)
    forward, up = forward / np.linalg.norm(forward), up / np.linalg.norm(up)
    right = np.cross(forward, up)  # OpenCV camera axes: x right = y down x z forward = forward x up
    eye = rrb.EyeControls3D(position=centre - 0.6 * forward + 0.5 * up + 0.8 * right, look_target=centre + 1.5 * forward, eye_up=up)
    cams = [rrb.Spatial2DView(origin=f"world/cameras/{c.name}", name=c.name) for c in rig.cameras]
    series = [
        rrb.TimeSeriesView(origin="stats/counts/particles", name="particles per track"),
        rrb.TimeSeriesView(
            origin="stats/counts/objects",
            contents=["$origin/**", "stats/counts/confirmed_tracks"],
            name="objects in view, confirmed tracks",
        ),
        rrb.TimeSeriesView(origin="stats/timing_ms", name="per-stage ms"),
        rrb.TimeSeriesView(origin="stats/rate", name="frames/s, latency ms"),
    ]
    if with_truth:
        series.append(rrb.TimeSeriesView(origin="stats/error_mm", name="3D error vs truth, mm"))
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Vertical(
                rrb.Spatial3DView(origin="world", name="3D: cameras, particles, tracks", eye_controls=eye),
                rrb.Horizontal(*cams),
                row_shares=[3, 2],
            ),
            rrb.Vertical(*series),
            column_shares=[3, 1],
        ),
        collapse_panels=True,
    )


def quaternions_xyzw(R: np.ndarray) -> np.ndarray:
    """Rotation matrices (N x 3 x 3) -> unit quaternions (N x 4, x y z w), vectorised.

    Shepperd's method: each matrix uses the formula built on its largest of
    w, x, y, z, so no division by a small number (scipy's Rotation does the
    same, at ~20x the cost for a handful of matrices).
    """
    R = np.asarray(R, dtype=float).reshape(-1, 3, 3)
    m00, m11, m22 = R[:, 0, 0], R[:, 1, 1], R[:, 2, 2]
    d21, d02, d10 = R[:, 2, 1] - R[:, 1, 2], R[:, 0, 2] - R[:, 2, 0], R[:, 1, 0] - R[:, 0, 1]
    s01, s02, s12 = R[:, 0, 1] + R[:, 1, 0], R[:, 0, 2] + R[:, 2, 0], R[:, 1, 2] + R[:, 2, 1]
    diag = np.stack([m00 + m11 + m22, m00 - m11 - m22, m11 - m00 - m22, m22 - m00 - m11], axis=1)
    case = diag.argmax(axis=1)
    s = 2.0 * np.sqrt(np.maximum(1.0 + diag[np.arange(len(R)), case], 1e-300))  # 4 x the largest component
    candidates = np.stack(
        [
            np.stack([d21, d02, d10, s * s / 4], axis=1),  # w largest
            np.stack([s * s / 4, s01, s02, d21], axis=1),  # x largest
            np.stack([s01, s * s / 4, s12, d02], axis=1),  # y largest
            np.stack([s02, s12, s * s / 4, d10], axis=1),  # z largest
        ],
        axis=1,
    )
    q = candidates[np.arange(len(R)), case] / s[:, None]
    q *= np.where(q[:, 3:4] < 0, -1.0, 1.0)  # w >= 0, one of the two equal quaternions
    return q


class TargetStyle:
    """Each target's display colour and ball radius, looked up by target name (unknown names: grey, a default radius)."""

    def __init__(self, targets) -> None:
        self.targets = {t.name: t for t in targets}
        self.colours = {t.name: target_colour(t) for t in targets}
        self._packed_colours: dict[str, int] = {}

    def packed(self, name: str) -> int:
        """A target's display colour as rerun's packed 0xRRGGBBAA."""
        if name not in self._packed_colours:
            self._packed_colours[name] = int(packed_rgba(self.colour(name))[0])
        return self._packed_colours[name]

    def target(self, name: str) -> Target:
        return self.targets.get(name) or Target(name, (0, 0, 0), (179, 255, 255))

    def radius(self, name: str) -> float:
        return self.target(name).radius

    def colour(self, name: str) -> np.ndarray:
        return self.colours.get(name, UNCLUSTERED)
