"""Compiled inner loops (numba): how every kernel is compiled and cached, and the camera kernels.

The tracker step works on a few thousand particles and a few hundred EM
points per frame; as numpy expressions that is hundreds of small array calls
whose fixed cost is most of the time (BENCHMARKS.md). So the per-particle and
per-point arithmetic is plain loops compiled by numba, each stage's in a
``kernels.py`` beside it (``evidence/``, ``particles/``, ``objects/``,
``tracks/``); this file holds what they share: the ``kernel`` decorator, small
inline helpers and the camera model's projection and triangulation.

``cache=True`` keeps each kernel's machine code beside its file, so only the
first run on a machine pays the compile (``pipeline.tracker.warm_up``).
Callers keep their numpy-facing signatures; the kernels take plain float64
arrays.

Stale caches: numba keys a cached kernel on its own file's time stamp only,
so a kernel that calls a kernel of another file would keep the callee's old
machine code after the callee's file changed (numba issue 1833). On import,
when any kernel file's content differs from the last import's, every kernel
file's time stamp is renewed, which makes numba recompile them all.
"""

from __future__ import annotations

import hashlib
import math
import os
import time
from pathlib import Path

import numpy as np

# A parallel kernel's OpenMP threads sleep when it ends instead of spinning for a while: spinning took the step's CPU
# time from 8 to 13 ms a frame at 640x480 (the cores the cameras' evidence threads and the capture need) for a few
# tenths of the step / floor ratio (BENCHMARKS.md). Read when numba first loads OpenMP, so set before any kernel runs;
# a user's own setting wins.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

from numba import njit  # noqa: E402 (after the OpenMP setting above)

KERNELS: list = []  # every kernel of the package called from Python (the warm-up must compile each: tests/test_kernels.py)


def kernel(fn=None, **options):
    """``numba.njit`` as every kernel uses it: cached on disk, releasing the GIL, and dividing
    like numpy (x / 0 is inf or nan, not an exception)."""
    options = {"cache": True, "nogil": True, "error_model": "numpy", **options}

    def compiled(f):
        dispatcher = njit(**options)(f)
        if options.get("inline") != "always":  # an inlined helper is compiled into its callers only
            KERNELS.append(dispatcher)
        return dispatcher

    return compiled if fn is None else compiled(fn)


def kernel_files() -> list[Path]:
    """This file and every stage's ``kernels.py`` (and ``*_kernels.py``: evidence/blob_kernels.py)."""
    here = Path(__file__).resolve()
    return [here, *sorted(here.parent.glob("*/*kernels.py"))]


def _renew_stale_caches() -> None:
    """When any kernel file changed since the last import, renew every kernel file's time stamp (see above)."""
    files = kernel_files()
    digest = hashlib.sha256(b"".join(f.read_bytes() for f in files)).hexdigest()
    stamp = files[0].parent / "__pycache__" / "kernels.sources.sha256"
    try:
        if stamp.is_file() and stamp.read_text() == digest:
            return
        now = time.time()
        for f in files:
            os.utime(f, (now, now))
        stamp.parent.mkdir(exist_ok=True)
        stamp.write_text(digest)
    except OSError:
        pass  # a read-only install: its kernel files do not change under it either


_renew_stale_caches()


# Inside the kernels, arithmetic on rows (points[i] - c) would allocate a small array per
# iteration: distances and sums are spelled out on scalars instead.


# --------------------------------------------------------------------------- Cameras


@kernel(inline="always")
def _sqdist(A, i, B, j):
    """Squared distance between row i of A and row j of B (3-D)."""
    return (A[i, 0] - B[j, 0]) ** 2 + (A[i, 1] - B[j, 1]) ** 2 + (A[i, 2] - B[j, 2]) ** 2


@kernel
def _inverse_logdet(c):
    """Inverse (3 x 3) and log-determinant of one symmetric positive-definite 3 x 3 matrix."""
    a, b, cc, d, e, f = c[0, 0], c[0, 1], c[0, 2], c[1, 1], c[1, 2], c[2, 2]
    A = d * f - e * e
    B = cc * e - b * f
    C = b * e - cc * d
    D = a * f - cc * cc
    E = b * cc - a * e
    F = a * d - b * b
    det = a * A + b * B + cc * C
    inv = np.empty((3, 3))
    inv[0, 0], inv[0, 1], inv[0, 2] = A / det, B / det, C / det
    inv[1, 0], inv[1, 1], inv[1, 2] = B / det, D / det, E / det
    inv[2, 0], inv[2, 1], inv[2, 2] = C / det, E / det, F / det
    return inv, math.log(det)


@kernel
def project_points(points, R, t, K, k, tilt):
    """World points (N x 3) -> distorted pixels (N x 2), in-front flags and depths (camera z), with
    OpenCV's model: 12 coefficients ``k`` (k1 k2 p1 p2 k3 k4 k5 k6 s1 s2 s3 s4, zero-padded) and
    the tilted-sensor matrix ``tilt`` (identity unless 14 coefficients). Points behind the camera
    get NaN pixels."""
    n = points.shape[0]
    uv = np.empty((n, 2))
    front = np.empty(n, np.bool_)
    depth = np.empty(n)
    k1, k2, p1, p2, k3, k4, k5, k6, s1, s2, s3, s4 = k[0], k[1], k[2], k[3], k[4], k[5], k[6], k[7], k[8], k[9], k[10], k[11]
    for i in range(n):
        X, Y, Z = points[i, 0], points[i, 1], points[i, 2]
        xc = R[0, 0] * X + R[0, 1] * Y + R[0, 2] * Z + t[0]
        yc = R[1, 0] * X + R[1, 1] * Y + R[1, 2] * Z + t[1]
        zc = R[2, 0] * X + R[2, 1] * Y + R[2, 2] * Z + t[2]
        depth[i] = zc
        if not zc > 1e-9:
            uv[i, 0] = np.nan
            uv[i, 1] = np.nan
            front[i] = False
            continue
        x = xc / zc
        y = yc / zc
        r2 = x * x + y * y
        r4 = r2 * r2
        r6 = r4 * r2
        radial = (1.0 + k1 * r2 + k2 * r4 + k3 * r6) / (1.0 + k4 * r2 + k5 * r4 + k6 * r6)
        xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x) + s1 * r2 + s2 * r4
        yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y + s3 * r2 + s4 * r4
        tx = tilt[0, 0] * xd + tilt[0, 1] * yd + tilt[0, 2]
        ty = tilt[1, 0] * xd + tilt[1, 1] * yd + tilt[1, 2]
        tz = tilt[2, 0] * xd + tilt[2, 1] * yd + tilt[2, 2]
        inv = 1.0 / tz if tz != 0.0 else 1.0
        xd, yd = tx * inv, ty * inv
        uv[i, 0] = K[0, 0] * xd + K[0, 1] * yd + K[0, 2]
        uv[i, 1] = K[1, 1] * yd + K[1, 2]
        front[i] = True
    return uv, front, depth


@kernel
def unproject_pinhole(px, K):
    """Pixels (N x 2) of a camera without distortion -> normalised coordinates (N x 2)."""
    out = np.empty((px.shape[0], 2))
    for i in range(px.shape[0]):
        out[i, 1] = (px[i, 1] - K[1, 2]) / K[1, 1]
        out[i, 0] = (px[i, 0] - K[0, 2] - K[0, 1] * out[i, 1]) / K[0, 0]
    return out


@kernel
def rays_from_normalised(xn, R, t):
    """Normalised coordinates (N x 2) -> world rays of a camera (x_cam = R X + t): origins (its centre,
    N x 3) and unit directions (N x 3)."""
    n = xn.shape[0]
    origins = np.empty((n, 3))
    dirs = np.empty((n, 3))
    for a in range(3):  # centre = -R' t
        c = -(R[0, a] * t[0] + R[1, a] * t[1] + R[2, a] * t[2])
        for i in range(n):
            origins[i, a] = c
    for i in range(n):
        x, y = xn[i, 0], xn[i, 1]
        d0 = R[0, 0] * x + R[1, 0] * y + R[2, 0]
        d1 = R[0, 1] * x + R[1, 1] * y + R[2, 1]
        d2 = R[0, 2] * x + R[1, 2] * y + R[2, 2]
        norm = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        dirs[i, 0], dirs[i, 1], dirs[i, 2] = d0 / norm, d1 / norm, d2 / norm
    return origins, dirs


@kernel
def triangulate_dlt(xn, P):
    """Linear (DLT) triangulation of M points seen by C cameras: normalised undistorted coordinates
    ``xn`` (C x M x 2) and normalised projection matrices [R | t] ``P`` (C x 3 x 4) -> M x 3.

    Each camera gives two linear equations in the point (x P3 - P1, y P3 - P2);
    the least-squares point solves their 3 x 3 normal equations (for rays that
    meet, exactly the homogeneous SVD solution; a 4 x 4 SVD per point costs
    far more than the geometry needs).
    """
    c, m = xn.shape[0], xn.shape[1]
    out = np.empty((m, 3))
    for i in range(m):
        AtA = np.zeros((3, 3))
        Atb = np.zeros(3)
        for j in range(c):
            for row in range(2):
                a0 = xn[j, i, row] * P[j, 2, 0] - P[j, row, 0]
                a1 = xn[j, i, row] * P[j, 2, 1] - P[j, row, 1]
                a2 = xn[j, i, row] * P[j, 2, 2] - P[j, row, 2]
                rhs = -(xn[j, i, row] * P[j, 2, 3] - P[j, row, 3])
                AtA[0, 0] += a0 * a0
                AtA[0, 1] += a0 * a1
                AtA[0, 2] += a0 * a2
                AtA[1, 1] += a1 * a1
                AtA[1, 2] += a1 * a2
                AtA[2, 2] += a2 * a2
                Atb[0] += a0 * rhs
                Atb[1] += a1 * rhs
                Atb[2] += a2 * rhs
        AtA[1, 0], AtA[2, 0], AtA[2, 1] = AtA[0, 1], AtA[0, 2], AtA[1, 2]
        inv, _ = _inverse_logdet(AtA)
        for a in range(3):
            out[i, a] = inv[a, 0] * Atb[0] + inv[a, 1] * Atb[1] + inv[a, 2] * Atb[2]
    return out


# --------------------------------------------------------------------------- Blobs (abduction.py)


# --------------------------------------------------------------------------- Particles (likelihood.py, population.py, pipeline.py)


# --------------------------------------------------------------------------- Clustering (clustering.py)


# --------------------------------------------------------------------------- Explain-away (explain.py, discs.py)


# --------------------------------------------------------------------------- Tracks (tracks.py)
