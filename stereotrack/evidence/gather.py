"""One target's evidence in one camera, built once per frame and read by every later stage.

``CameraEvidence`` holds the camera, the target's mask and its integral
image, the colour blobs and each blob's viewing ray: the population weighs
particles with the integral image and places abductive ones on the rays,
explain-away looks the blobs up, the viewer draws the rays.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from ..camera import Camera
from .blobs import Blobs, ball_like, find_blobs
from .colour import integral_image


@dataclass(frozen=True, eq=False)
class Seeds:
    """Where abductive particles start in one camera: blobs that could be a ball, and their viewing rays."""

    centres: np.ndarray  # M x 2 pixels
    radii: np.ndarray  # M apparent radii, pixels (half the blob's larger side)
    origins: np.ndarray  # M x 3
    directions: np.ndarray  # M x 3 unit

    def __len__(self) -> int:
        return len(self.centres)


@dataclass(frozen=True, eq=False)
class CameraEvidence:
    """What one camera's image says about one target this frame."""

    camera: Camera
    mask: np.ndarray  # H x W uint8, 1 where a pixel has the target's colour
    integral: np.ndarray  # (H+1) x (W+1) int32 summed-area table of the mask: any window's count in O(1)
    blobs: Blobs
    origins: np.ndarray  # M x 3: each blob's viewing ray starts at the camera centre ...
    directions: np.ndarray  # M x 3: ... and runs along this unit vector through the blob's centroid
    moving: np.ndarray | None = None  # H x W uint8, 1 where a pixel has the colour and moves (evidence/motion.py); None: no motion
    moving_integral: np.ndarray | None = None  # its summed-area table
    seeds: Seeds | None = None  # the blobs abductive particles start from (None: every blob of the mask)
    soft_integral: np.ndarray | None = None  # summed-area table of p(ball | colour) x 255 inside the range (colour_model.py)

    def proposal_seeds(self) -> Seeds:
        """The seeds, or every blob of the mask when none were chosen."""
        return self.seeds if self.seeds is not None else Seeds(self.blobs.centres, self.blobs.radii, self.origins, self.directions)

    @property
    def rays(self) -> tuple[np.ndarray, np.ndarray]:
        return self.origins, self.directions

    @classmethod
    def from_mask(
        cls,
        camera: Camera,
        mask: np.ndarray,
        integral: np.ndarray | None = None,
        blob_method: str = "components",
        min_blob_area: int = 6,
        foreground: np.ndarray | None = None,
        ball: tuple[float, float, float] | None = None,
        probability: np.ndarray | None = None,
    ) -> CameraEvidence:
        """Blobs and rays of a mask (its integral image too, unless given). With the camera's ``foreground``,
        the moving part of the mask is a second map, and its blobs seed particles too. With ``ball``
        (radius, d_min, d_max), only blobs that could be such a ball seed particles (``blobs.ball_like``). With
        the colour model's ``probability`` (uint8, p(ball | colour) x 255), the mask keeps the pixels likelier
        on the ball than on the background, and a soft map (the probability inside the range) is kept too;
        the moving map still takes the whole range (a ball moving in front of its own colour)."""
        soft_integral = None
        in_range = mask
        if probability is not None:
            soft = cv2.bitwise_and(probability, probability, mask=mask)
            soft_integral = integral_image(soft)
            mask = cv2.threshold(soft, 127, 1, cv2.THRESH_BINARY)[1]
            integral = None
        blobs = find_blobs(mask, blob_method, min_blob_area)
        origins, directions = camera.rays(blobs.centres)
        moving = moving_integral = None
        if foreground is not None:
            moving = cv2.bitwise_and(in_range, foreground)
            moving_integral = integral_image(moving)
        seeds = None
        if ball is not None or moving is not None:
            seeds = _seeds(camera, blobs, origins, directions, moving, blob_method, min_blob_area, ball)
        integral = integral_image(mask) if integral is None else integral
        return cls(camera, mask, integral, blobs, origins, directions, moving, moving_integral, seeds, soft_integral)


DUPLICATE_PX = 2.0  # a moving blob whose centroid is this close to a colour blob's, and about its size, is that blob


def _seeds(camera, blobs, origins, directions, moving, blob_method, min_blob_area, ball) -> Seeds:
    """Ball-like blobs of the colour mask, then those of its moving part that are not the same blob again
    (a ball moving in front of a wall of its colour is a blob of its own only in the moving part)."""
    keep = ball_like(blobs, camera.focal_px, *ball) if ball is not None else np.ones(len(blobs), bool)
    centres, radii, o, d = [blobs.centres[keep]], [blobs.radii[keep]], [origins[keep]], [directions[keep]]
    if moving is not None:
        mb = find_blobs(moving, blob_method, min_blob_area)
        new = ball_like(mb, camera.focal_px, *ball) if ball is not None else np.ones(len(mb), bool)
        if len(blobs) and len(mb):
            dist = np.linalg.norm(mb.centres[:, None] - blobs.centres[None], axis=2)
            same = (dist < DUPLICATE_PX) & (mb.areas[:, None] > 0.7 * blobs.areas[None])
            new &= ~same.any(axis=1)
        if new.any():
            mo, md = camera.rays(mb.centres[new])
            centres.append(mb.centres[new])
            radii.append(mb.radii[new])
            o.append(mo)
            d.append(md)
    return Seeds(np.vstack(centres).reshape(-1, 2), np.concatenate(radii), np.vstack(o).reshape(-1, 3), np.vstack(d).reshape(-1, 3))
