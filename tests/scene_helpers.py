"""Small drawn scenes for unit tests: a default rig and ball masks drawn as discs (no renderer)."""

import cv2
import numpy as np

from stereotrack.camera import Camera, Rig, intrinsics_from_fov, look_at
from stereotrack.evidence.colour import integral_image

RADIUS = 0.035


def default_rig(width=640, height=480) -> Rig:
    """The tracker issue's default rig: 60 deg HFOV, 0.3 m baseline, aimed at a point 1.5 m ahead (z-up world, y forward)."""
    K = intrinsics_from_fov(width, height, 60.0)
    cams = []
    for i, x in enumerate((-0.15, 0.15)):
        R, t = look_at((x, 0.0, 0.0), (0.0, 1.5, 0.0), up=(0.0, 0.0, 1.0))
        cams.append(Camera(f"cam{i}", (width, height), K, np.zeros(5), R, t))
    return Rig(tuple(cams), world="custom")


def disc_masks(rig: Rig, balls: np.ndarray, radius: float = RADIUS):
    """Per camera: a 0/1 mask with each ball drawn as its projected disc, and its integral image."""
    masks = []
    for cam in rig.cameras:
        m = np.zeros((cam.height, cam.width), np.uint8)
        uv, ok = cam.project(balls)
        z = cam.depth(balls)
        for (u, v), good, depth in zip(uv, ok, z):
            if good:
                r = cam.K[0, 0] * radius / depth
                cv2.circle(m, (int(round(u * 16)), int(round(v * 16))), int(round(r * 16)), 1, -1, shift=4)
        masks.append(m)
    return masks, [integral_image(m) for m in masks]
