"""One target's evidence in one camera, built once per frame and read by every later stage.

``CameraEvidence`` holds the camera, the target's mask and its integral
image, the colour blobs and each blob's viewing ray: the population weighs
particles with the integral image and places abductive ones on the rays,
explain-away looks the blobs up, the viewer draws the rays.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..camera import Camera
from .blobs import Blobs, find_blobs
from .colour import integral_image


@dataclass(frozen=True, eq=False)
class CameraEvidence:
    """What one camera's image says about one target this frame."""

    camera: Camera
    mask: np.ndarray  # H x W uint8, 1 where a pixel has the target's colour
    integral: np.ndarray  # (H+1) x (W+1) int32 summed-area table of the mask: any window's count in O(1)
    blobs: Blobs
    origins: np.ndarray  # M x 3: each blob's viewing ray starts at the camera centre ...
    directions: np.ndarray  # M x 3: ... and runs along this unit vector through the blob's centroid

    @property
    def rays(self) -> tuple[np.ndarray, np.ndarray]:
        return self.origins, self.directions

    @classmethod
    def from_mask(
        cls, camera: Camera, mask: np.ndarray, integral: np.ndarray | None = None, blob_method: str = "components", min_blob_area: int = 6
    ) -> CameraEvidence:
        """Blobs and rays of a mask (its integral image too, unless given)."""
        blobs = find_blobs(mask, blob_method, min_blob_area)
        origins, directions = camera.rays(blobs.centres)
        return cls(camera, mask, integral_image(mask) if integral is None else integral, blobs, origins, directions)


def cameras_of(views: Sequence[CameraEvidence]) -> list[Camera]:
    return [v.camera for v in views]
