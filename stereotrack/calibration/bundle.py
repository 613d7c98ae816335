"""Joint refinement (bundle adjustment): every camera's intrinsics and pose and every board pose at once.

The world is camera 0's frame. The unknowns: per camera the intrinsics its
lens model leaves free (fx, fy, cx, cy and distortion terms), per camera
c >= 1 its pose (world -> camera: rotation vector, translation), per view the
board pose (board -> world). The residuals: every corner every camera
detected, reprojected minus detected, in pixels. A view seen by one camera
only still constrains that camera's intrinsics.

Solved with ``scipy.optimize.least_squares`` (trust region, Huber loss so that
a few bad corners cannot pull the solution) and an exact Jacobian from
OpenCV's own ``projectPoints`` and ``composeRT``: the model is OpenCV's, the
same ``Camera`` projects with. Measured against OpenCV 5's
``calibrateMultiview`` (which refines the poses only and keeps each camera's
separately calibrated intrinsics) and against finite differences over the
sparse Jacobian (hundreds of evaluations): see BENCHMARKS.md.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from scipy.optimize import least_squares

# One camera's intrinsics as a vector, in OpenCV's order: fx, fy, cx, cy, k1, k2, p1, p2, k3, k4, k5, k6
N_INTR = 12
FX, FY, CX, CY, K1, K2, P1, P2, K3, K4, K5, K6 = range(N_INTR)
# The rational model's denominator k4..k6 has a weak prior: 0 +- 1, weighted like one corner's 0.3 px of
# noise. Its numerator and denominator can grow together along a nearly flat valley that leaves the
# projection unchanged but, at its far end, trades the focal length with k1 / k4 (an ordinary lens
# fitted with --rational: 58 % off after 6 minutes). Data that need k4..k6 (a wide lens) outweigh it.
RATIONAL_PRIOR_PX = 0.3


@dataclass(frozen=True)
class LensModel:
    """Which intrinsics are free: OpenCV's calibration flags as a mask."""

    rational: bool = False  # k4, k5, k6 free (8 coefficients)
    fix_k3: bool = False
    zero_tangent: bool = False
    fix_aspect: bool = False  # fy / fx stays at its starting value

    def free(self) -> np.ndarray:
        free = np.ones(N_INTR, bool)
        free[[K4, K5, K6]] = self.rational
        free[K3] &= not self.fix_k3
        free[[P1, P2]] = not self.zero_tangent
        free[FY] = not self.fix_aspect  # then fy follows fx
        return free

    @property
    def n_dist(self) -> int:
        return 8 if self.rational else 5


@dataclass(frozen=True, eq=False)
class Corners:
    """Every detected corner: its view, camera, board point and pixel (one row each)."""

    view: np.ndarray  # (N,) int
    cam: np.ndarray  # (N,) int
    obj: np.ndarray  # (N, 3) board frame, metres
    px: np.ndarray  # (N, 2) detected pixel


@dataclass(frozen=True, eq=False)
class BundleResult:
    intrinsics: np.ndarray  # (cameras, 12): fx, fy, cx, cy, k1..k6
    cam_poses: np.ndarray  # (cameras, 6): world -> camera, rotation vector and translation; camera 0 is zero
    board_poses: np.ndarray  # (views, 6): board -> world
    residuals: np.ndarray  # (N, 2) reprojected minus detected pixels, one row per corner
    covariance: np.ndarray  # of the packed unknowns (Problem.pack), from the Jacobian and the residual variance
    problem: Problem

    def sd_intrinsic(self, c: int, k: int) -> float:
        """Standard deviation of camera c's intrinsic k (FX, CX, ...); 0 if the model fixes it."""
        p = self.problem
        if not p.free[k]:
            return 0.0
        i = c * p.n_free + int(np.count_nonzero(p.free[:k]))
        return float(np.sqrt(max(0.0, self.covariance[i, i])))

    def sd_of(self, quantity, step: float = 1e-7) -> float:
        """Standard deviation of a function of the camera poses (e.g. a baseline), by first-order propagation."""
        p = self.problem
        x = p.pack(self.intrinsics, self.cam_poses, self.board_poses)
        span = slice(p.i_cams, p.i_views)
        grad = np.zeros(p.n_unknowns)
        for j in range(span.start, span.stop):
            dx = np.zeros_like(x)
            dx[j] = step
            grad[j] = (quantity(p.unpack(x + dx)[1]) - quantity(p.unpack(x - dx)[1])) / (2 * step)
        return float(np.sqrt(max(0.0, grad @ self.covariance @ grad)))


class Problem:
    """Packs the unknowns into one vector and gives residuals and their exact Jacobian."""

    def __init__(self, corners: Corners, n_cams: int, n_views: int, model: LensModel, intrinsics0: np.ndarray):
        self.corners, self.n_cams, self.n_views, self.model = corners, n_cams, n_views, model
        self.free = model.free()
        self.fixed = intrinsics0.copy()  # the values of what the model keeps fixed
        self.aspect = intrinsics0[:, FY] / intrinsics0[:, FX]
        self.n_free = int(self.free.sum())
        self.i_cams = n_cams * self.n_free  # where the camera poses start in the vector
        self.i_views = self.i_cams + 6 * (n_cams - 1)  # where the board poses start
        self.n_unknowns = self.i_views + 6 * n_views
        # where each camera's k4..k6 sit in the vector (none unless the model is rational)
        slot = np.cumsum(self.free) - 1
        self.prior = np.array([c * self.n_free + slot[k] for c in range(n_cams) for k in (K4, K5, K6) if self.free[k]], int)
        # one block per (view, camera): the rows of its corners, for one projectPoints call each
        key = corners.view * n_cams + corners.cam
        order = np.argsort(key, kind="stable")
        keys, starts = np.unique(key[order], return_index=True)
        ends = np.append(starts[1:], len(order))
        self.blocks = [(int(k // n_cams), int(k % n_cams), order[a:b]) for k, a, b in zip(keys, starts, ends)]

    def pack(self, intrinsics: np.ndarray, cam_poses: np.ndarray, board_poses: np.ndarray) -> np.ndarray:
        return np.concatenate([intrinsics[:, self.free].ravel(), cam_poses[1:].ravel(), board_poses.ravel()])

    def unpack(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        intrinsics = self.fixed.copy()
        intrinsics[:, self.free] = x[: self.i_cams].reshape(self.n_cams, self.n_free)
        if self.model.fix_aspect:
            intrinsics[:, FY] = intrinsics[:, FX] * self.aspect
        cam_poses = np.zeros((self.n_cams, 6))
        cam_poses[1:] = x[self.i_cams : self.i_views].reshape(-1, 6)
        return intrinsics, cam_poses, x[self.i_views :].reshape(self.n_views, 6)

    def _project(self, x: np.ndarray, jacobian: bool):
        """Per block: (view, camera, rows, pixels, projectPoints' Jacobian, composeRT's derivatives)."""
        intrinsics, cam_poses, board_poses = self.unpack(x)
        for v, c, rows in self.blocks:
            # board -> world -> camera in one pose, with the derivatives of the composition
            composed = cv2.composeRT(board_poses[v, :3], board_poses[v, 3:], cam_poses[c, :3], cam_poses[c, 3:])
            fx, fy, cx, cy = intrinsics[c, :4]
            K = np.array([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])
            uv, J = cv2.projectPoints(self.corners.obj[rows], composed[0], composed[1], K, intrinsics[c, 4:])
            yield v, c, rows, uv.reshape(-1, 2), (J if jacobian else None), composed[2:]

    def residuals(self, x: np.ndarray) -> np.ndarray:
        r = np.empty((len(self.corners.view), 2))
        for _, _, rows, uv, _, _ in self._project(x, False):
            r[rows] = uv - self.corners.px[rows]
        return r.ravel()

    def objective(self, x: np.ndarray) -> np.ndarray:
        """What the solver minimises: the corners' residuals, then the prior's rows."""
        return np.concatenate([self.residuals(x), RATIONAL_PRIOR_PX * x[self.prior]])

    def objective_jacobian(self, x: np.ndarray) -> np.ndarray:
        prior = np.zeros((len(self.prior), self.n_unknowns))
        prior[np.arange(len(self.prior)), self.prior] = RATIONAL_PRIOR_PX
        return np.vstack([self.jacobian(x), prior])

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """Dense: a few thousand rows by a few hundred unknowns; exact, from OpenCV's derivatives."""
        out = np.zeros((2 * len(self.corners.view), self.n_unknowns))
        free = np.flatnonzero(self.free)
        for v, c, rows, _, J, d in self._project(x, True):
            dr3dr1, dr3dt1, dr3dr2, dr3dt2, dt3dr1, dt3dt1, dt3dr2, dt3dt2 = d
            Jr, Jt = J[:, 0:3], J[:, 3:6]  # pixels by the composed rotation and translation
            r = np.column_stack([2 * rows, 2 * rows + 1]).ravel()  # u and v rows of these corners
            board = self.i_views + 6 * v
            out[r, board : board + 6] = np.hstack([Jr @ dr3dr1 + Jt @ dt3dr1, Jr @ dr3dt1 + Jt @ dt3dt1])
            if c > 0:
                cam = self.i_cams + 6 * (c - 1)
                out[r, cam : cam + 6] = np.hstack([Jr @ dr3dr2 + Jt @ dt3dr2, Jr @ dr3dt2 + Jt @ dt3dt2])
            Ji = J[:, 6 : 6 + N_INTR].copy()  # fx, fy, cx, cy, k1..k6
            if self.model.fix_aspect:
                Ji[:, FX] += self.aspect[c] * Ji[:, FY]
            out[r, c * self.n_free : (c + 1) * self.n_free] = Ji[:, free]
        return out


def robust_scale(residuals: np.ndarray) -> float:
    """Huber's threshold (pixels): 3 robust standard deviations of the starting residuals, at least 0.5 px.

    Corners within it count fully (least squares); those beyond count less and less.
    """
    sigma = 1.4826 * float(np.median(np.abs(residuals)))
    return max(0.5, 3.0 * sigma)


def refine(
    corners: Corners, n_cams: int, n_views: int, model: LensModel, intrinsics0: np.ndarray, cam_poses0: np.ndarray, board_poses0: np.ndarray
) -> BundleResult:
    """The joint least-squares fit from a starting point close to it (per-camera and pairwise calibrations)."""
    problem = Problem(corners, n_cams, n_views, model, intrinsics0)
    x0 = problem.pack(intrinsics0, cam_poses0, board_poses0)
    scale = robust_scale(problem.residuals(x0))
    with _one_thread():
        fit = least_squares(
            problem.objective,
            x0,
            jac=problem.objective_jacobian,
            method="trf",
            tr_solver="exact",
            loss="huber",
            f_scale=scale,
            x_scale="jac",
        )
        J = fit.jac  # robust-weighted at the solution
        dof = max(1, J.shape[0] - J.shape[1])
        covariance = np.linalg.pinv(J.T @ J) * (2 * fit.cost / dof)  # cost is half the sum of squares
    intrinsics, cam_poses, board_poses = problem.unpack(fit.x)
    return BundleResult(intrinsics, cam_poses, board_poses, problem.residuals(fit.x).reshape(-1, 2), covariance, problem)


def _one_thread():
    """BLAS on one thread for the dense algebra: on the shared 2-core machine the threads fighting over
    the cores made a 3-camera solve 6.6x slower (30.1 s against 4.5 s, BENCHMARKS.md)."""
    from threadpoolctl import threadpool_limits

    return threadpool_limits(1)
