"""The classic pipeline, as most users would write it with OpenCV: the particle tracker's peer.

Per frame and target: HSV colour mask per camera -> connected-component blob
centroids -> pair the blobs of the first two cameras by epipolar distance
(fundamental matrix from the rig, Hungarian assignment, a pixel gate) ->
``cv2.triangulatePoints`` on undistorted points -> the same persistent tracks
as the particle tracker (``tracks.TrackManager``: constant-velocity Kalman,
gated Hungarian association, lifecycle in seconds).

It returns the same ``FrameResult`` as the particle ``Tracker``, so both run
through ``stereotrack track`` and ``stereotrack eval`` on equal terms. Its
known weakness is the honest one of the method: two balls of one colour on
(nearly) the same epipolar line cannot be told apart from two images, so the
pairing may swap them and triangulate ghosts. Cameras beyond the first two
are not used.
"""

from __future__ import annotations

import time as _time
from collections.abc import Mapping, Sequence

import cv2
import numpy as np
from scipy.optimize import linear_sum_assignment

from ..camera import Camera, Rig, triangulate_with_covariance
from ..config import Config
from ..errors import StereotrackError
from ..evidence.blobs import find_blobs
from ..evidence.colour import camera_masks
from ..frames import FramePair
from ..results import FrameResult, Object3D, Rays
from ..tracks.manager import TrackManager


def fundamental_matrix(cam_a: Camera, cam_b: Camera) -> np.ndarray:
    """F (3x3) with ``x_b^T F x_a = 0`` for undistorted pixels (``ideal_pixels``) of a point seen by both cameras."""
    R = cam_b.R @ cam_a.R.T  # camera a -> camera b
    t = cam_b.t - R @ cam_a.t
    tx = np.array([[0, -t[2], t[1]], [t[2], 0, -t[0]], [-t[1], t[0], 0]])
    F = np.linalg.inv(cam_b.K).T @ (tx @ R) @ np.linalg.inv(cam_a.K)
    return F / np.linalg.norm(F)


def ideal_pixels(cam: Camera, pixels: np.ndarray) -> np.ndarray:
    """Distorted pixels (N x 2) -> the pixels an undistorted pinhole camera with the same K would see."""
    xn = cam.undistort_pixels(pixels)
    return np.hstack([xn, np.ones((len(xn), 1))]) @ cam.K.T[:, :2]


def epipolar_distances(F: np.ndarray, pa: np.ndarray, pb: np.ndarray) -> np.ndarray:
    """Symmetric epipolar distance in pixels (Ma x Mb): mean distance of each point to the other's epipolar line."""
    ha = np.hstack([pa, np.ones((len(pa), 1))])
    hb = np.hstack([pb, np.ones((len(pb), 1))])
    lb = ha @ F.T  # lines in image b, one per point of a
    la = hb @ F  # lines in image a, one per point of b
    alg = hb @ F @ ha.T  # Mb x Ma: x_b^T F x_a
    db = np.abs(alg) / np.linalg.norm(lb[:, :2], axis=1)[None, :]
    da = np.abs(alg) / np.linalg.norm(la[:, :2], axis=1)[:, None]
    return (0.5 * (da + db)).T


def match_epipolar(F: np.ndarray, pa: np.ndarray, pb: np.ndarray, max_px: float) -> tuple[np.ndarray, np.ndarray]:
    """Pair points of two images (ideal pixels) one-to-one: Hungarian on epipolar distance, pairs over ``max_px`` dropped.

    Returns index arrays (ia, ib) of equal length.
    """
    if len(pa) == 0 or len(pb) == 0:
        return np.zeros(0, int), np.zeros(0, int)
    d = epipolar_distances(F, pa, pb)
    ok = d <= max_px
    ia, ib = linear_sum_assignment(np.where(ok, d, 1e6 + d))
    keep = ok[ia, ib]
    return ia[keep], ib[keep]


def triangulate_pairs(cam_a: Camera, cam_b: Camera, pa: np.ndarray, pb: np.ndarray) -> np.ndarray:
    """``cv2.triangulatePoints`` on undistorted normalised coordinates: pixel pairs (N x 2 each) -> N x 3 world points."""
    if len(pa) == 0:
        return np.zeros((0, 3))
    xa = cam_a.undistort_pixels(pa)
    xb = cam_b.undistort_pixels(pb)
    Pa = np.hstack([cam_a.R, cam_a.t[:, None]])
    Pb = np.hstack([cam_b.R, cam_b.t[:, None]])
    Xh = cv2.triangulatePoints(Pa, Pb, xa.T.astype(np.float64), xb.T.astype(np.float64))
    return (Xh[:3] / Xh[3]).T


def triangulation_covariance(cam_a: Camera, cam_b: Camera, pa: np.ndarray, pb: np.ndarray, pixel_sigma: float) -> np.ndarray:
    """Position covariance (N x 3 x 3) of triangulated points for isotropic pixel noise (see
    ``camera.triangulate_with_covariance``)."""
    return triangulate_with_covariance([cam_a, cam_b], [pa, pb], pixel_sigma)[1]


class BaselineTracker:
    """The classic OpenCV tracker with the particle ``Tracker``'s interface: ``step(frame_pair) -> FrameResult``."""

    def __init__(self, rig: Rig, config: Config):
        if not config.targets:
            raise StereotrackError("no targets to track: the config has an empty 'targets' list (see 'stereotrack colour learn')")
        self.rig = rig
        self.config = config
        self.cam_a, self.cam_b = rig.cameras[0], rig.cameras[1]
        self.F = fundamental_matrix(self.cam_a, self.cam_b)
        self.tracks = TrackManager(config.tracks, rig)

    def step(self, frame: FramePair) -> FrameResult:
        self.rig.check_images(frame.images)
        timings: dict[str, float] = {}
        t0 = _time.perf_counter()
        targets = self.config.targets
        masks = {}
        for cam, image in zip(self.rig.cameras[:2], frame.images[:2]):
            cm = camera_masks(cam.name, image, targets, integrals=False)  # blobs only: no summed-area tables
            for name, mask in cm.masks.items():
                masks[(name, cam.name)] = mask
        t1 = _time.perf_counter()
        centres: dict[str, tuple[np.ndarray, np.ndarray]] = {}
        s = self.config.tracker
        for target in targets:
            blobs = [find_blobs(masks[(target.name, cam.name)], "components", s.min_blob_area) for cam in (self.cam_a, self.cam_b)]
            centres[target.name] = (blobs[0].centres, blobs[1].centres)
        t2 = _time.perf_counter()
        objects, rays = self.detections_to_objects(centres)
        t3 = _time.perf_counter()
        tracks = self.tracks.update(objects, frame.time)
        t4 = _time.perf_counter()
        timings.update(masks=1e3 * (t1 - t0), blobs=1e3 * (t2 - t1), matching=1e3 * (t3 - t2), tracks=1e3 * (t4 - t3), step=1e3 * (t4 - t0))
        return FrameResult(frame=frame, objects=objects, tracks=tracks, rays=rays, masks=masks, timings_ms=timings)

    def detections_to_objects(self, centres: Mapping[str, Sequence[np.ndarray]]) -> tuple[tuple[Object3D, ...], tuple[Rays, ...]]:
        """Blob centroids per target ({target: (pixels in camera a, pixels in camera b)}) -> 3D objects and display rays."""
        s, b = self.config.tracker, self.config.baseline
        objects: list[Object3D] = []
        rays: list[Rays] = []
        for target, (pa, pb) in centres.items():
            pa = np.asarray(pa, float).reshape(-1, 2)
            pb = np.asarray(pb, float).reshape(-1, 2)
            for cam, px in ((self.cam_a, pa), (self.cam_b, pb)):
                if len(px):
                    o, d = cam.rays(px)
                    rays.append(Rays(target=target, camera=cam.name, origins=o, directions=d, pixels=px))
            ia, ib = match_epipolar(self.F, ideal_pixels(self.cam_a, pa), ideal_pixels(self.cam_b, pb), b.max_epipolar_px)
            X = triangulate_pairs(self.cam_a, self.cam_b, pa[ia], pb[ib])
            # A pair is kept only if its point lies in front of both cameras within the tracker's depth range.
            da, db = self.cam_a.depth(X), self.cam_b.depth(X)
            keep = (da >= s.d_min) & (da <= s.d_max) & (db >= s.d_min) & (db <= s.d_max)
            X, ia, ib = X[keep], ia[keep], ib[keep]
            cov = triangulation_covariance(self.cam_a, self.cam_b, pa[ia], pb[ib], b.pixel_sigma)
            for k in range(len(X)):
                objects.append(Object3D(target=target, position=X[k], covariance=cov[k], mass=1.0 / len(X), n_particles=0))
        return tuple(objects), tuple(rays)
