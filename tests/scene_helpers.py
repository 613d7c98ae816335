"""Small drawn scenes for unit tests: a default rig and ball masks drawn as discs (no renderer)."""

import cv2
import numpy as np

from stereotrack.camera import Camera, Rig, intrinsics_from_fov, look_at
from stereotrack.config import Target
from stereotrack.evidence.colour import integral_image
from stereotrack.evidence.gather import CameraEvidence

RADIUS = 0.035
TARGET = Target("pink", (140, 60, 50), (175, 255, 255), RADIUS)


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


def evidence(rig: Rig, masks) -> tuple[CameraEvidence, ...]:
    """Each camera's evidence of drawn masks: blobs and their viewing rays, as the tracker builds them."""
    return tuple(CameraEvidence.from_mask(cam, m) for cam, m in zip(rig.cameras, masks))


def balls_at(centres, target: str | tuple[str, ...] = "pink", first_id: int = 1, radius: float = RADIUS, confirmed: bool = True):
    """Tracked balls at these centres, of one target (or of ``target``'s names, one a ball)."""
    from stereotrack.results import TrackedBalls

    centres = np.asarray(centres, float).reshape(-1, 3)
    n = len(centres)
    targets = tuple(target) if isinstance(target, tuple) else (target,) * n
    return TrackedBalls(centres, np.full(n, radius), np.arange(first_id, first_id + n), targets, np.full(n, confirmed))


def lit_ball(origins: np.ndarray, directions: np.ndarray, centre, radius: float = RADIUS) -> tuple[np.ndarray, np.ndarray]:
    """Which rays (N x 3 origins and unit directions) hit a ball at ``centre``, and for those how much light its surface
    takes there (0..1, lit from above and in front): a ray-traced ball's shading."""
    oc = origins - np.asarray(centre, float)
    b = np.einsum("ij,ij->i", oc, directions)
    disc = b * b - (np.einsum("ij,ij->i", oc, oc) - radius**2)
    on = disc > 0
    normal = (oc[on] + (-b[on] - np.sqrt(disc[on]))[:, None] * directions[on]) / radius
    light = np.array([0.3, -0.6, 0.75]) / np.linalg.norm([0.3, -0.6, 0.75])
    return on, np.clip(normal @ light, 0.0, 1.0)
