"""Solid shapes for synthetic scenes beyond balls: ellipsoids, boxes, cylinders and textured walls.

Every shape is a frozen, declarative dataclass (so a scene spec hashes and
compares by value); ``intersect`` finds, for a grid of viewing rays, the
distance along each ray to the shape's visible surface and the surface
normal there. Ellipsoids also give an analytic edge coverage (anti-aliased
edges, like the balls) so they can move (hands, arms); the rest are static
scenery, rendered once per camera with supersampling by ``stage.py``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

IDENTITY = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
# What a pixel shows (Material.tag; SceneRenderer.stage_tags): for tests that check a scene holds what it claims.
TAG_SCENERY, TAG_TARGET_COLOURED, TAG_SKIN = 0, 1, 2


def rotation(yaw: float = 0.0, pitch: float = 0.0, roll: float = 0.0) -> tuple[float, ...]:
    """Row-major 3 x 3 body-to-world rotation from degrees: roll about x, then pitch about y, then yaw about z."""
    a, b, c = np.radians([yaw, pitch, roll])
    rz = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    ry = np.array([[np.cos(b), 0, np.sin(b)], [0, 1, 0], [-np.sin(b), 0, np.cos(b)]])
    rx = np.array([[1, 0, 0], [0, np.cos(c), -np.sin(c)], [0, np.sin(c), np.cos(c)]])
    return tuple(float(x) for x in (rz @ ry @ rx).ravel())


def frame_from_axis(axis: Sequence[float], up_hint: Sequence[float] = (0.0, 0.0, 1.0)) -> tuple[float, ...]:
    """A rotation whose body z axis points along ``axis`` (for shapes stretched along a direction)."""
    z = np.asarray(axis, float)
    z = z / np.linalg.norm(z)
    hint = np.asarray(up_hint, float)
    if abs(float(z @ hint)) > 0.95 * np.linalg.norm(hint):
        hint = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(hint, z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    return tuple(float(v) for v in np.column_stack([x, y, z]).ravel())


def _matrix(rot: Sequence[float]) -> np.ndarray:
    return np.asarray(rot, np.float32).reshape(3, 3)


@dataclass(frozen=True)
class Material:
    colour: tuple[float, float, float]  # BGR albedo, 0..255
    specular: float = 0.05  # highlight strength (0 = matte)
    shininess: float = 10.0
    tag: int = TAG_SCENERY  # what the pixels show: TAG_SCENERY, TAG_TARGET_COLOURED (a distractor), TAG_SKIN


@dataclass(frozen=True)
class Ellipsoid:
    centre: tuple[float, float, float]
    axes: tuple[float, float, float]  # semi-axes along the body x, y, z, metres
    material: Material
    rot: tuple[float, ...] = IDENTITY  # row-major body -> world rotation

    @property
    def bound(self) -> float:
        return float(max(self.axes))

    def intersect(self, origin: np.ndarray, dirs: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per ray (... x 3 unit directions): (distance, normalised miss m: the surface is m = 1, normal).

        Rays that miss get the distance and normal of their closest approach,
        so edges can be anti-aliased from m; m < 1 means a hit.
        """
        R = _matrix(self.rot)
        scale = 1.0 / np.asarray(self.axes, np.float32)
        M = (R * scale[None, :]).T  # world offset -> unit-sphere space: diag(1/a) R^T
        a0 = M @ (origin.astype(np.float32) - np.asarray(self.centre, np.float32))
        b = dirs @ M.T
        bb = np.einsum("...i,...i->...", b, b)
        ab = b @ a0
        aa = float(a0 @ a0)
        m2 = np.maximum(aa - ab * ab / bb, 0.0)
        t = (-ab - np.sqrt(np.maximum(ab * ab - bb * (aa - 1.0), 0.0))) / bb
        q = a0 + t[..., None] * b  # hit (or closest) point in unit-sphere space
        n = (q * scale[None, :].ravel()) @ R.T  # gradient of the quadric: R diag(1/a) q
        n /= np.linalg.norm(n, axis=-1, keepdims=True) + 1e-12
        return t, np.sqrt(m2), n


@dataclass(frozen=True)
class Box:
    centre: tuple[float, float, float]
    size: tuple[float, float, float]  # full extent along the body x, y, z
    material: Material
    rot: tuple[float, ...] = IDENTITY

    @property
    def bound(self) -> float:
        return 0.5 * float(np.linalg.norm(self.size))

    def intersect(self, origin: np.ndarray, dirs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Per ray: (distance to the surface or inf, world normal)."""
        R = _matrix(self.rot)
        o = (origin.astype(np.float32) - np.asarray(self.centre, np.float32)) @ R
        d = dirs @ R
        half = 0.5 * np.asarray(self.size, np.float32)
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = 1.0 / d
            ta = (-half - o) * inv
            tb = (half - o) * inv
        tmin = np.nan_to_num(np.minimum(ta, tb), nan=-np.inf)
        tmax = np.nan_to_num(np.maximum(ta, tb), nan=np.inf)
        near, face = tmin.max(axis=-1), tmin.argmax(axis=-1)
        far = tmax.min(axis=-1)
        hit = (near <= far) & (near > 0)
        t = np.where(hit, near, np.inf).astype(np.float32)
        nb = np.zeros(d.shape, np.float32)
        np.put_along_axis(nb, face[..., None], -np.sign(np.take_along_axis(d, face[..., None], axis=-1)), axis=-1)
        return t, nb @ R.T


@dataclass(frozen=True)
class Cylinder:
    """A closed cylinder (a can, a bin, a lamp): ``radius`` around the body z axis, ``height`` along it."""

    centre: tuple[float, float, float]
    radius: float
    height: float
    material: Material
    rot: tuple[float, ...] = IDENTITY

    @property
    def bound(self) -> float:
        return float(np.hypot(self.radius, self.height / 2))

    def intersect(self, origin: np.ndarray, dirs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        R = _matrix(self.rot)
        o = (origin.astype(np.float32) - np.asarray(self.centre, np.float32)) @ R
        d = dirs @ R
        h = np.float32(self.height / 2)
        r2 = np.float32(self.radius**2)
        a = d[..., 0] ** 2 + d[..., 1] ** 2
        b = 2 * (o[0] * d[..., 0] + o[1] * d[..., 1])
        c = o[0] ** 2 + o[1] ** 2 - r2
        disc = b * b - 4 * a * c
        with np.errstate(divide="ignore", invalid="ignore"):
            ts = (-b - np.sqrt(np.maximum(disc, 0))) / (2 * a)
            side_ok = (disc >= 0) & (ts > 0) & (np.abs(o[2] + ts * d[..., 2]) <= h)
            tcap = np.minimum((h - o[2]) / d[..., 2], (-h - o[2]) / d[..., 2])
            tcap = np.where(np.abs(o[2]) > h, tcap, np.inf)  # seen from outside only
            px, py = o[0] + tcap * d[..., 0], o[1] + tcap * d[..., 1]
            cap_ok = (tcap > 0) & (px * px + py * py <= r2)
        t_side = np.where(side_ok, ts, np.inf)
        t_cap = np.where(cap_ok, tcap, np.inf)
        t = np.minimum(t_side, t_cap).astype(np.float32)
        p = o + np.where(np.isfinite(t), t, 0)[..., None] * d
        n = np.zeros(d.shape, np.float32)
        side = t_side <= t_cap
        n[..., 0] = np.where(side, p[..., 0], 0)
        n[..., 1] = np.where(side, p[..., 1], 0)
        n[..., 2] = np.where(side, 0, np.sign(p[..., 2]))
        n /= np.linalg.norm(n, axis=-1, keepdims=True) + 1e-12
        return t, n @ R.T


@dataclass(frozen=True)
class Decal:
    """A shape painted on a wall: in the wall's (u, v) metres, v up."""

    kind: str  # "rect", "ellipse", "polygon" (points relative to the centre), "curtain" (rect with folds)
    centre: tuple[float, float]
    size: tuple[float, float]  # full width and height (polygon: a scale for the points)
    colour: tuple[float, float, float]  # BGR
    angle: float = 0.0  # degrees, counter-clockwise
    points: tuple[tuple[float, float], ...] = ()  # polygon vertices, in units of size / 2
    tag: int = 0


@dataclass(frozen=True)
class Wall:
    """A textured rectangle: ``origin`` is its lower-left corner, ``u`` and ``v`` unit edge directions."""

    origin: tuple[float, float, float]
    u: tuple[float, float, float]
    v: tuple[float, float, float]
    extent: tuple[float, float]  # length along u and v, metres
    colour: tuple[float, float, float]  # base BGR albedo
    pattern: str = "paint"  # "paint", "wood" (planks along u), "tiles", "carpet"
    variation: float = 0.06  # relative low-frequency brightness variation
    decals: tuple[Decal, ...] = ()
    seed: int = 0  # texture noise
    tag: int = 0

    @property
    def normal(self) -> np.ndarray:
        n = np.cross(self.u, self.v)
        return n / np.linalg.norm(n)
