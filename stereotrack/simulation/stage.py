"""Static scenery in 3D: textured walls, floor and ceiling, furniture and props, rendered once per camera.

A ``Stage`` is the room the balls fly in, the same room for every camera
(unlike the flat per-camera backgrounds of the presets), so a poster or a
box is where stereo says it is. ``render_stage`` ray-casts it once per
camera (``supersample`` x ``supersample`` rays per pixel, then a slight lens
blur) and returns the lit colour, the depth along each pixel's ray (the
z-buffer that moving things are drawn against), the id of the nearest
thing and a tag per pixel (what the pixel shows, for tests: a
target-coloured distractor, skin).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import cv2
import numpy as np

from .shapes import Box, Cylinder, Decal, Ellipsoid, Wall

TEXTURE_PX_PER_M = 160.0
MAX_TEXTURE_SIDE = 2048


@dataclass(frozen=True)
class Stage:
    walls: tuple[Wall, ...] = ()
    props: tuple[Ellipsoid | Box | Cylinder, ...] = ()
    supersample: int = 1  # rays per pixel along each axis
    optics_blur: float = 0.6  # Gaussian sigma in pixels: the lens's softness, which also smooths the edges


@dataclass(frozen=True, eq=False)
class StageImage:
    colour: np.ndarray  # H x W x 3 float32 BGR, lit (before the frame's brightness gain)
    depth: np.ndarray  # H x W float32 distance along the pixel's ray; inf where nothing
    ids: np.ndarray  # H x W int16: -1 walls, -1000 - k prop k
    tags: np.ndarray  # H x W uint8: a material tag where every sample of the pixel carries it, else 0


def _smooth(rng: np.random.Generator, w: int, h: int, cell: float) -> np.ndarray:
    small = rng.uniform(-1, 1, (max(2, int(h / cell) + 2), max(2, int(w / cell) + 2))).astype(np.float32)
    return cv2.resize(small, (w, h), interpolation=cv2.INTER_CUBIC)


@functools.lru_cache(maxsize=16)
def wall_texture(wall: Wall) -> tuple[np.ndarray, np.ndarray, float]:
    """(BGR albedo float32, tag uint8, pixels per metre) of a wall, v up (row 0 is the top edge)."""
    ppm = min(TEXTURE_PX_PER_M, MAX_TEXTURE_SIDE / max(wall.extent))
    w, h = max(2, int(wall.extent[0] * ppm)), max(2, int(wall.extent[1] * ppm))
    rng = np.random.default_rng(wall.seed)
    lum = 1.0 + wall.variation * _smooth(rng, w, h, 0.8 * ppm) + 0.3 * wall.variation * _smooth(rng, w, h, 0.15 * ppm)
    if wall.pattern == "wood":  # planks along u with their own tone, grain stretched along them, dark seams
        plank = max(3, int(rng.uniform(0.1, 0.2) * ppm))
        rows = np.arange(h) // plank
        tone = rng.uniform(-0.1, 0.1, rows.max() + 1)[rows]
        grain = cv2.resize(rng.uniform(-1, 1, (h, max(2, w // 40))).astype(np.float32), (w, h), interpolation=cv2.INTER_LINEAR)
        lum = lum + tone[:, None] + 0.06 * grain
        lum[np.arange(h) % plank == 0] *= 0.75
    elif wall.pattern == "tiles":
        tile = max(4, int(rng.uniform(0.25, 0.6) * ppm))
        yy, xx = np.mgrid[0:h, 0:w]
        lum = lum + 0.03 * rng.uniform(-1, 1, ((h // tile) + 1, (w // tile) + 1))[yy // tile, xx // tile]
        lum[(yy % tile < 2) | (xx % tile < 2)] *= 0.85
    elif wall.pattern == "carpet":
        lum = lum + 0.08 * (rng.random((h, w), dtype=np.float32) * 2 - 1)
    tex = np.asarray(wall.colour, np.float32)[None, None, :] * lum[:, :, None].astype(np.float32)
    tex += 1.5 * rng.standard_normal(tex.shape, dtype=np.float32)  # fine grain of paint, plaster, fabric
    tags = np.full((h, w), wall.tag, np.uint8)
    for d in wall.decals:
        _draw_decal(tex, tags, d, ppm, h)
    return np.clip(tex, 0, 255), tags, ppm


def _draw_decal(tex: np.ndarray, tags: np.ndarray, d: Decal, ppm: float, h: int) -> None:
    cx, cy = d.centre[0] * ppm, h - d.centre[1] * ppm  # texture rows grow downwards
    hw, hh = 0.5 * d.size[0] * ppm, 0.5 * d.size[1] * ppm
    # Work in the decal's bounding window of the texture.
    reach = float(np.hypot(hw, hh)) * (max(1.0, float(np.abs(np.asarray(d.points)).max())) if d.points else 1.0) + 2
    x0, y0 = max(0, int(cx - reach)), max(0, int(cy - reach))
    x1, y1 = min(tags.shape[1], int(cx + reach) + 2), min(tags.shape[0], int(cy + reach) + 2)
    if x0 >= x1 or y0 >= y1:
        return
    tex, tags = tex[y0:y1, x0:x1], tags[y0:y1, x0:x1]
    cx, cy = cx - x0, cy - y0
    shift = 4
    s = float(1 << shift)
    mask = np.zeros(tags.shape, np.uint8)
    ang = np.radians(d.angle)
    rot = np.array([[np.cos(ang), np.sin(ang)], [-np.sin(ang), np.cos(ang)]])  # v up -> rows down
    if d.kind in ("rect", "curtain"):
        pts = np.array([[-hw, -hh], [hw, -hh], [hw, hh], [-hw, hh]]) @ rot.T + [cx, cy]
        cv2.fillConvexPoly(mask, np.round(pts * s).astype(np.int32), 1, cv2.LINE_8, shift)
    elif d.kind == "ellipse":
        cv2.ellipse(
            mask,
            (int(round(cx * s)), int(round(cy * s))),
            (int(round(hw * s)), int(round(hh * s))),
            -d.angle,
            0,
            360,
            1,
            -1,
            cv2.LINE_8,
            shift,
        )
    elif d.kind == "polygon":
        pts = (np.asarray(d.points, float) * [hw, -hh]) @ rot.T + [cx, cy]
        cv2.fillPoly(mask, [np.round(pts * s).astype(np.int32)], 1, cv2.LINE_8, shift)
    else:
        raise ValueError(f"unknown decal kind {d.kind!r}")
    m = mask.astype(bool)
    if not m.any():
        return
    paint = np.broadcast_to(np.asarray(d.colour, np.float32), (int(m.sum()), 3))
    if d.kind == "curtain":  # vertical folds: brightness waves across the width
        fold = max(3.0, 0.12 * ppm)
        xx = (np.nonzero(m)[1] + x0).astype(np.float32)
        paint = paint * (0.8 + 0.2 * np.cos(2 * np.pi * xx / fold))[:, None]
    # Keep a little of the wall's texture under the paint (print on paper, fabric weave).
    base = tex[m]
    rel = base / (np.median(base, axis=0, keepdims=True) + 1e-3)
    tex[m] = paint * np.clip(0.85 + 0.15 * rel, 0.7, 1.3)
    tags[m] = d.tag


def _sample(image: np.ndarray, x: np.ndarray, y: np.ndarray, interpolation: int) -> np.ndarray:
    """``image`` at N sub-pixel points (cv2.remap, which takes maps of at most 32767 rows or columns)."""
    n = len(x)
    cols = 4096
    rows = -(-n // cols)
    mx = np.zeros(rows * cols, np.float32)
    my = np.zeros(rows * cols, np.float32)
    mx[:n], my[:n] = x, y
    out = cv2.remap(image, mx.reshape(rows, cols), my.reshape(rows, cols), interpolation, borderMode=cv2.BORDER_REFLECT)
    return out.reshape(rows * cols, *image.shape[2:])[:n]


def pixel_rays(camera, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Unit world ray directions (float32, shape of u + (3,)) through pixels (u, v), lens distortion undone.

    The camera model's own ``rays`` solves each pixel to 1e-14 with up to 100
    iterations of OpenCV's undistortPoints (seconds for a frame's pixels);
    here every pixel is solved at once, vectorised, by Newton steps on the
    same distortion model until it reprojects within 1e-7 pixels.
    """
    K = camera.K
    y = (v - K[1, 2]) / K[1, 1]
    x = (u - K[0, 2] - K[0, 1] * y) / K[0, 0]
    dist = np.asarray(camera.dist, float).ravel()
    if dist.size > 5 and np.any(dist[5:]):  # rational or thin-prism models: OpenCV's solver
        xn = camera.undistort_pixels(np.column_stack([u.ravel(), v.ravel()]))
        x, y = xn[:, 0].reshape(u.shape), xn[:, 1].reshape(u.shape)
    elif np.any(dist):
        d = np.zeros(5)
        d[: dist.size] = dist
        k1, k2, p1, p2, k3 = d
        xd, yd = x, y
        for _ in range(50):
            r2 = x * x + y * y
            radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
            dr = k1 + r2 * (2 * k2 + 3 * k3 * r2)  # d radial / d r2
            fx = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x) - xd
            fy = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y - yd
            if max(float(np.abs(fx).max()), float(np.abs(fy).max())) * K[0, 0] < 1e-7:
                break
            a = radial + 2 * x * x * dr + 2 * p1 * y + 6 * p2 * x
            b = 2 * x * y * dr + 2 * p1 * x + 2 * p2 * y
            e = radial + 2 * y * y * dr + 6 * p1 * y + 2 * p2 * x
            det = a * e - b * b
            x, y = x - (e * fx - b * fy) / det, y - (a * fy - b * fx) / det
    cam_dirs = np.stack([x, y, np.ones_like(x)], axis=-1)
    cam_dirs /= np.linalg.norm(cam_dirs, axis=-1, keepdims=True)
    return (cam_dirs @ camera.R).astype(np.float32)  # camera -> world: R^T d, as rows


def _sample_rays(camera, s: int) -> np.ndarray:
    """H x s x W x s x 3 unit ray directions through a regular sub-pixel grid."""
    w, h = camera.width, camera.height
    offs = (np.arange(s) + 0.5) / s - 0.5
    uu = (np.arange(w)[:, None] + offs[None, :]).ravel()
    vv = (np.arange(h)[:, None] + offs[None, :]).ravel()
    gu, gv = np.meshgrid(uu, vv)
    return pixel_rays(camera, gu, gv).reshape(h, s, w, s, 3)


def _shade(
    normals: np.ndarray, dirs: np.ndarray, lighting, specular: float, shininess: float, gamma: float = 1.0
) -> tuple[np.ndarray, np.ndarray]:
    L = np.asarray(lighting.direction, np.float32)
    L /= np.linalg.norm(L)
    n = np.where((np.sum(normals * dirs, axis=-1) > 0)[..., None], -normals, normals)  # the side facing the camera
    lam = np.clip(n @ L, 0.0, None)
    diffuse = lighting.ambient + lighting.diffuse * lam
    if gamma != 1.0:  # through the camera's tone curve (see spec.CameraResponse)
        diffuse = diffuse ** (1.0 / gamma)
    if specular <= 0:
        return diffuse, np.zeros_like(diffuse)
    half = L - dirs
    half /= np.linalg.norm(half, axis=-1, keepdims=True)
    return diffuse, specular * 255.0 * np.clip(np.sum(n * half, axis=-1), 0, None) ** shininess


def _window(camera, corners: np.ndarray, s: int) -> tuple[slice, slice] | None:
    """Sub-pixel rows and columns inside the projection of a thing's corners (all of them if one is behind the camera)."""
    uv, front = camera.project(corners)
    if not front.all():
        return slice(None), slice(None)
    x0, y0 = np.floor(uv.min(axis=0)).astype(int) - 2
    x1, y1 = np.ceil(uv.max(axis=0)).astype(int) + 3
    x0, y0, x1, y1 = max(x0, 0), max(y0, 0), min(x1, camera.width), min(y1, camera.height)
    if x0 >= x1 or y0 >= y1:
        return None
    return slice(y0 * s, y1 * s), slice(x0 * s, x1 * s)


def _prop_corners(prop) -> np.ndarray:
    if isinstance(prop, Box):
        half = 0.5 * np.asarray(prop.size, float)
    elif isinstance(prop, Cylinder):
        half = np.array([prop.radius, prop.radius, 0.5 * prop.height])
    else:
        half = np.asarray(prop.axes, float)
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * half * 1.02
    return np.asarray(prop.centre, float) + corners @ np.asarray(prop.rot, float).reshape(3, 3).T


def _draw_wall(wall: Wall, origin, dirs, colour, depth, ids, tags, lighting, gamma) -> None:
    n = wall.normal.astype(np.float32)
    o = np.asarray(wall.origin, np.float32)
    denom = dirs @ n
    with np.errstate(divide="ignore", invalid="ignore"):
        t = ((o - origin) @ n) / denom
    p = origin + np.where(np.isfinite(t), t, 0)[..., None] * dirs - o
    u, v = p @ np.asarray(wall.u, np.float32), p @ np.asarray(wall.v, np.float32)
    hit = (t > 0) & (u >= 0) & (u <= wall.extent[0]) & (v >= 0) & (v <= wall.extent[1]) & (t < depth)
    if not hit.any():
        return
    tex, tex_tags, ppm = wall_texture(wall)
    mu = (u[hit] * ppm - 0.5).astype(np.float32)
    mv = (tex.shape[0] - v[hit] * ppm - 0.5).astype(np.float32)
    diffuse, _ = _shade(np.broadcast_to(n, (int(hit.sum()), 3)), dirs[hit], lighting, 0.0, 1.0, gamma)
    colour[hit] = _sample(tex, mu, mv, cv2.INTER_LINEAR) * diffuse[:, None]
    depth[hit] = t[hit]
    ids[hit] = -1
    tags[hit] = _sample(tex_tags, mu, mv, cv2.INTER_NEAREST)


def render_stage(stage: Stage, camera, lighting, gamma: float = 1.0) -> StageImage:
    s = max(1, int(stage.supersample))
    h, w = camera.height, camera.width
    dirs = _sample_rays(camera, s).reshape(h * s, w * s, 3)
    origin = camera.centre.astype(np.float32)
    colour = np.zeros((h * s, w * s, 3), np.float32)
    depth = np.full((h * s, w * s), np.inf, np.float32)
    ids = np.full((h * s, w * s), -1, np.int16)
    tags = np.zeros((h * s, w * s), np.uint8)
    for wall in stage.walls:
        eu, ev = np.asarray(wall.u, float) * wall.extent[0], np.asarray(wall.v, float) * wall.extent[1]
        win = _window(camera, np.asarray(wall.origin, float) + np.array([0 * eu, eu, ev, eu + ev]), s)
        if win is not None:
            _draw_wall(wall, origin, dirs[win], colour[win], depth[win], ids[win], tags[win], lighting, gamma)
    for k, prop in enumerate(stage.props):
        win = _window(camera, _prop_corners(prop), s)
        if win is None:
            continue
        d = dirs[win]
        if isinstance(prop, Ellipsoid):
            t, m, n = prop.intersect(origin, d)
            t = np.where(m <= 1.0, t, np.inf)
        else:
            t, n = prop.intersect(origin, d)
        hit = (t > 0) & (t < depth[win])
        if not hit.any():
            continue
        mat = prop.material
        diffuse, spec = _shade(n[hit], d[hit], lighting, mat.specular, mat.shininess, gamma)
        colour[win][hit] = np.asarray(mat.colour, np.float32) * diffuse[:, None] + spec[:, None]
        depth[win][hit] = t[hit]
        ids[win][hit] = -1000 - k
        tags[win][hit] = mat.tag
    # Down to pixels: mean colour, nearest depth (a moving ball hides behind any part of an edge pixel).
    blocks = lambda a: a.reshape(h, s, w, s, *a.shape[2:]).swapaxes(1, 2).reshape(h, w, s * s, *a.shape[2:])  # noqa: E731
    cb, db, ib, tb = blocks(colour), blocks(depth), blocks(ids), blocks(tags)
    nearest = db.argmin(axis=2)[..., None]
    col = cb.mean(axis=2).astype(np.float32)
    if stage.optics_blur > 0:
        col = cv2.GaussianBlur(col, (0, 0), stage.optics_blur)
    return StageImage(
        colour=col,
        depth=db.min(axis=2),
        ids=np.take_along_axis(ib, nearest, axis=2)[..., 0],
        tags=tb.min(axis=2),
    )
