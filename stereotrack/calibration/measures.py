"""What solving and reporting share: the options, one camera's intrinsics, board points and poses, residuals, angles, the per-view fit."""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from ..camera import Camera
from .boards import MIN_CORNERS, Board, Detection
from .bundle import LensModel


@dataclass(frozen=True)
class CalibrationOptions:
    fix_aspect: bool = False  # fx / fy fixed at 1 (square pixels)
    zero_tangent: bool = False  # no tangential distortion (p1 = p2 = 0)
    fix_k3: bool = False  # no 6th-order radial term (steadier with few views)
    rational: bool = False  # 8-coefficient rational model (wide-angle lenses)
    joint: bool = True  # refine every camera and board pose at once (bundle.py); False: the pairwise starts only, to compare
    drop_worst: int = 0  # drop this many worst views and calibrate again
    world_view: str | None = None  # name of a view whose board pose is the world (z up); None: first camera

    def lens_model(self) -> LensModel:
        return LensModel(rational=self.rational, fix_k3=self.fix_k3, zero_tangent=self.zero_tangent, fix_aspect=self.fix_aspect)

    def flags(self) -> int:
        f = 0
        if self.fix_aspect:
            f |= cv2.CALIB_FIX_ASPECT_RATIO
        if self.zero_tangent:
            f |= cv2.CALIB_ZERO_TANGENT_DIST
        if self.fix_k3:
            f |= cv2.CALIB_FIX_K3
        if self.rational:
            f |= cv2.CALIB_RATIONAL_MODEL
        return f


@dataclass(frozen=True, eq=False)
class Intrinsics:
    K: np.ndarray
    dist: np.ndarray
    rms: float
    std_f: float  # standard deviation of fx from the calibration, pixels
    views: list[int]  # view indices used


def _points(board: Board, det: Detection) -> tuple[np.ndarray, np.ndarray]:
    obj = board.object_points()[det.ids].astype(np.float32).reshape(-1, 1, 3)
    return obj, det.corners.astype(np.float32).reshape(-1, 1, 2)


def _pose(board: Board, det: Detection, K: np.ndarray, dist: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Board -> camera (R, t) from one detection."""
    obj, img = _points(board, det)
    ok, rvec, tvec = cv2.solvePnP(obj, img, K, dist, flags=cv2.SOLVEPNP_ITERATIVE)
    return cv2.Rodrigues(rvec)[0], tvec.ravel()


def _reprojection(board: Board, det: Detection, K, dist) -> np.ndarray:
    """Per-corner reprojection error (pixels) with the board pose fitted to this view."""
    obj, img = _points(board, det)
    ok, rvec, tvec = cv2.solvePnP(obj, img, K, dist, flags=cv2.SOLVEPNP_ITERATIVE)
    proj, _ = cv2.projectPoints(obj, rvec, tvec, K, dist)
    return np.linalg.norm(proj.reshape(-1, 2) - img.reshape(-1, 2), axis=1)


def _angle_deg(R: np.ndarray) -> float:
    return math.degrees(math.acos(np.clip((np.trace(R) - 1) / 2, -1.0, 1.0)))


def _common(a: Detection, b: Detection) -> tuple[Detection, Detection] | None:
    common, ia, ib = np.intersect1d(a.ids, b.ids, return_indices=True)
    if len(common) < MIN_CORNERS:
        return None
    return Detection(common, a.corners[ia]), Detection(common, b.corners[ib])


def epipolar_errors(cam_i: Camera, cam_j: Camera, px_i: np.ndarray, px_j: np.ndarray) -> np.ndarray:
    """Symmetric distance (pixels) of matched points to each other's epipolar lines, after undistortion."""
    R = cam_j.R @ cam_i.R.T
    T = cam_j.t - R @ cam_i.t
    Tx = np.array([[0, -T[2], T[1]], [T[2], 0, -T[0]], [-T[1], T[0], 0]])
    E = Tx @ R
    xi = np.column_stack([cam_i.undistort_pixels(px_i), np.ones(len(px_i))])
    xj = np.column_stack([cam_j.undistort_pixels(px_j), np.ones(len(px_j))])
    F = np.linalg.inv(cam_j.K).T @ E @ np.linalg.inv(cam_i.K)
    ui = xi @ cam_i.K.T  # undistorted pixel coordinates
    uj = xj @ cam_j.K.T
    lj = ui @ F.T  # lines in image j
    li = uj @ F  # lines in image i
    dj = np.abs(np.sum(lj * uj, axis=1)) / np.hypot(lj[:, 0], lj[:, 1])
    di = np.abs(np.sum(li * ui, axis=1)) / np.hypot(li[:, 0], li[:, 1])
    return (di + dj) / 2


@dataclass(frozen=True, eq=False)
class ViewFit:
    """What the fit says about every view: the detections it used (chessboards relabelled to agree
    between cameras), where it puts each detected corner, the residuals and the board poses."""

    detections: tuple[tuple[Detection | None, ...], ...]
    reprojected: tuple[tuple[np.ndarray | None, ...], ...]  # pixels, one row per detected corner
    board_R: np.ndarray  # (views, 3, 3) board -> world, in the rig's world
    board_t: np.ndarray  # (views, 3)

    def residuals(self, v: int, c: int) -> np.ndarray | None:
        """Per corner: reprojected minus detected pixels (n x 2), or None if camera c did not see view v."""
        d = self.detections[v][c]
        return None if d is None else self.reprojected[v][c] - d.corners
