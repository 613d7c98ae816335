"""Rendering a synthetic scene (``spec.py``): any frame on its own, with exact ground truth.

A scene is a rig of toed-in cameras, balls on trajectories, a textured
background (or a 3D stage), optional distractors, occluders and movers
(hands), lighting, noise, blur and compression. ``SceneRenderer`` renders
true spheres by per-pixel ray-sphere intersection through the camera model,
so perspective and lens distortion are exact; ``write.render_scene`` writes
a whole recording folder.

Per camera, everything static (the background or stage, the occluders) is
drawn once; each frame copies it and redraws only the part of the image
that balls and movers touch during the exposure, once per sub-frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from ..camera import Camera
from ..frames import FramePair
from .spec import CameraResponse, Occluder, SceneSpec
from .stage import pixel_rays, render_stage

# A camera shows a ball clearly (truth's ``clear``) when this share of its disc or more is in view: a sliver over a
# prop's edge, or a ball deep in a hand, is seen (``visible``) but gives no centre or size to triangulate (static_props
# tune seeds 57 and 65: a ball 1-3 per cent shown in one camera, required, for the whole scene)
CLEAR_SHARE = 0.25


def disc_shares(cameras, centres: np.ndarray, radii: np.ndarray, shown_px) -> np.ndarray:
    """Per camera and ball (C x B): the ball's pixels in the camera (``shown_px``, per camera a count per ball) against
    the whole disc a ball of its radius makes at its depth, f R / z pixels in radius (the stretch of a ball far off the
    axis, up to a fifth more area at the edge of a 70-degree view, aside): a ball half out of the image shows half of
    it. NaN where the ball is not in the scene (``centres`` NaN) or its disc lies wholly out of the image or behind the
    camera."""
    present = np.flatnonzero(~np.isnan(centres[:, 0]))
    out = np.full((len(cameras), len(centres)), np.nan)
    for j, (cam, counts) in enumerate(zip(cameras, shown_px)):
        uv, front, depth = cam.view(centres[present])
        for k, centre, ahead, r in zip(present, uv, front, cam.apparent_radius(radii[present], depth)):
            if ahead and disc_pixels(centre, float(r), cam.width, cam.height):
                out[j, k] = counts[k] / _whole_disc_pixels(centre, float(r))
    return out


def _whole_disc_pixels(centre: np.ndarray, radius: float) -> int:
    """``disc_pixels`` of the whole disc: on an image large enough to hold it, its centre as far from a pixel's."""
    reach = int(np.ceil(radius)) + 1
    shifted = np.asarray(centre, float) % 1.0 + reach
    return disc_pixels(shifted, radius, 2 * reach + 2, 2 * reach + 2)


def disc_pixels(centre: np.ndarray, radius: float, width: int, height: int) -> int:
    """Pixels of a width x height image whose centres lie within ``radius`` of ``centre``."""
    x0, x1 = max(int(np.floor(centre[0] - radius)), 0), min(int(np.ceil(centre[0] + radius)) + 1, width)
    y0, y1 = max(int(np.floor(centre[1] - radius)), 0), min(int(np.ceil(centre[1] + radius)) + 1, height)
    if x0 >= x1 or y0 >= y1:
        return 0
    ys, xs = np.ogrid[y0:y1, x0:x1]
    return int(((xs - centre[0]) ** 2 + (ys - centre[1]) ** 2 <= radius * radius).sum())


# --------------------------------------------------------------------------- rendering


def _smooth_noise(rng: np.random.Generator, w: int, h: int, cell: int) -> np.ndarray:
    small = rng.uniform(-1, 1, (max(2, h // cell + 2), max(2, w // cell + 2))).astype(np.float32)
    return cv2.resize(small, (w, h), interpolation=cv2.INTER_CUBIC)


def make_background(rng: np.random.Generator, w: int, h: int, distractors: int = 0, distractor_hue: int | None = None) -> np.ndarray:
    """A textured, mostly low-saturation background (float32 BGR): smooth noise, a gradient, shapes."""
    lum = 125 + 35 * _smooth_noise(rng, w, h, 160) + 18 * _smooth_noise(rng, w, h, 40) + 7 * _smooth_noise(rng, w, h, 8)
    ang = rng.uniform(0, 2 * np.pi)
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    lum += 30 * ((xx - w / 2) * np.cos(ang) + (yy - h / 2) * np.sin(ang)) / max(w, h)
    img = np.repeat(lum[:, :, None], 3, axis=2)
    for c in range(3):  # a gentle colour cast that wanders over the image
        img[:, :, c] += 10 * _smooth_noise(rng, w, h, 200)
    for _ in range(int(rng.integers(10, 20))):  # furniture: grey-ish boxes and discs
        grey = rng.uniform(40, 220)
        colour = tuple(float(grey + rng.uniform(-12, 12)) for _ in range(3))
        x0, y0 = int(rng.uniform(-0.1, 1.0) * w), int(rng.uniform(-0.1, 1.0) * h)
        sx, sy = int(rng.uniform(0.03, 0.3) * w), int(rng.uniform(0.03, 0.3) * h)
        if rng.uniform() < 0.6:
            cv2.rectangle(img, (x0, y0), (x0 + sx, y0 + sy), colour, -1)
        else:
            cv2.ellipse(img, (x0, y0), (sx // 2, sy // 2), float(rng.uniform(0, 180)), 0, 360, colour, -1)
    img = cv2.GaussianBlur(img, (3, 3), 0)
    for _ in range(distractors):  # similar-hue patches: what a colour tracker must not follow
        hue = (distractor_hue + int(rng.integers(-14, 15))) % 180
        hsv = np.uint8([[[hue, int(rng.integers(70, 230)), int(rng.integers(90, 240))]]])
        colour = tuple(float(c) for c in cv2.cvtColor(hsv, cv2.COLOR_HSV2BGR)[0, 0])
        centre = (int(rng.uniform(0.05, 0.95) * w), int(rng.uniform(0.05, 0.95) * h))
        axes = (int(rng.uniform(0.01, 0.05) * w), int(rng.uniform(0.01, 0.05) * w))
        cv2.ellipse(img, centre, axes, float(rng.uniform(0, 180)), 0, 360, colour, -1)
    return np.clip(img, 0, 255).astype(np.float32)


@dataclass
class _CameraCache:
    camera: Camera
    rays: np.ndarray  # H x W x 3 float32 unit directions, world frame
    centre: np.ndarray  # 3
    background: np.ndarray  # H x W x 3 float32: the static scene, occluders drawn in
    depth: np.ndarray  # H x W float32: distance along each ray to the static scene (inf: nothing)
    ids: np.ndarray  # H x W int16: what the static scene shows (see SceneRenderer.labels)
    tags: np.ndarray | None  # H x W uint8 material tags of a stage, else None
    focal: float
    background_sum: np.ndarray  # the background added once per sub-frame, as a frame's sub-frames are
    response: CameraResponse
    response_map: np.ndarray | None  # H x W x 3 per-pixel gains (white balance, vignetting), None when neutral


class SceneRenderer:
    """Renders frames of a scene in memory: ``render(i) -> (images, truth rows)``.

    Truth rows are (object_id, x, y, z, visible, clear) for every ball present
    that some camera sees or whose centre is in front of and inside every
    camera's image (hidden there, behind a prop); ``visible`` counts the
    cameras in which some of the ball is not hidden, ``clear`` those that show
    CLEAR_SHARE of its disc or more (a ball half out of an image shows half of
    it). Any frame can be rendered on its own and always comes out the same.
    """

    def __init__(self, spec: SceneSpec):
        self.spec = spec
        self.rig = spec.rig.build()
        rng = np.random.default_rng(spec.seed)
        light = np.asarray(spec.lighting.direction, float)
        self._light = (light / np.linalg.norm(light)).astype(np.float32)
        hue = int(cv2.cvtColor(spec.balls[0].bgr.astype(np.uint8)[None, None], cv2.COLOR_BGR2HSV)[0, 0, 0]) if spec.balls else 0
        w, h = spec.rig.width, spec.rig.height
        uu, vv = np.meshgrid(np.arange(w, dtype=float), np.arange(h, dtype=float))
        self._n_sub = max(1, int(spec.blur))
        self._cams = []
        for i, cam in enumerate(self.rig.cameras):
            response = spec.response(i)
            rays = pixel_rays(cam, uu, vv)  # undistorted, so lens distortion is exact
            tags = None
            if spec.stage is None:
                bg = make_background(rng, w, h, spec.distractors, hue)
                depth, ids = np.full((h, w), np.inf, np.float32), np.full((h, w), -1, np.int16)
            else:
                stage = render_stage(spec.stage, cam, spec.lighting, response.gamma)
                bg, depth, ids, tags = stage.colour, stage.depth, stage.ids, stage.tags
            cc = _CameraCache(cam, rays, cam.centre.astype(np.float32), bg, depth, ids, tags, float(cam.K[0, 0]), bg, response, None)
            for k, occ in enumerate(spec.occluders):  # static, so drawn once
                self._draw_box(cc, -2 - k, occ)
            for _ in range(self._n_sub - 1):
                cc.background_sum = cc.background_sum + bg
            if response.vignette > 0 or response.gains != (1.0, 1.0, 1.0):
                yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
                r2 = ((xx - (w - 1) / 2) ** 2 + (yy - (h - 1) / 2) ** 2) / ((w / 2) ** 2 + (h / 2) ** 2)
                cc.response_map = (1.0 - response.vignette * r2)[:, :, None] * np.asarray(response.gains, np.float32)
            self._cams.append(cc)
        # One bank of Gaussian noise; each frame reads it at seeded offsets (cheap, still Gaussian per pixel).
        self._noise = (rng.standard_normal(2 * w * h * 3, dtype=np.float32) * spec.noise) if spec.noise > 0 else None

    @property
    def n_frames(self) -> int:
        return self.spec.n_frames

    def time(self, frame: int) -> float:
        return frame / self.spec.fps

    def ball_positions(self, t: float) -> np.ndarray:
        """B x 3 ball centres at time t; NaN rows for balls not in the scene."""
        out = np.full((len(self.spec.balls), 3), np.nan)
        for k, b in enumerate(self.spec.balls):
            if b.appear <= t < b.disappear:
                out[k] = b.trajectory.positions(np.array([t]))[0]
        return out

    def stage_tags(self, camera: int) -> np.ndarray | None:
        """H x W material tags of the stage as camera ``camera`` sees it (shapes.TAG_*), or None without a stage."""
        return self._cams[camera].tags

    def pair(self, frame: int) -> FramePair:
        """Frame ``frame`` as a tracker takes it: every camera's image, all stamped with the frame's time."""
        images, _ = self.render(frame)
        return FramePair(frame, tuple(images), (self.time(frame),) * len(images))

    def render(self, frame: int) -> tuple[tuple[np.ndarray, ...], list[tuple[int, float, float, float, int]]]:
        spec = self.spec
        t = self.time(frame)
        rng = np.random.default_rng([spec.seed, frame])
        n_sub = self._n_sub
        offsets = ((np.arange(n_sub) + 0.5) / n_sub - 0.5) * spec.exposure / spec.fps if n_sub > 1 else np.zeros(1)
        # The recording starts at time 0: the first frame's exposure is its second half. Before 0 no ball is in the scene,
        # and those sub-frames drew every ball faded (a third transparent with the stress scenes' 3 sub-frames): a ball at
        # rest changed from the first frame to the next, and the background model saw it move (hue_wall tune seed 36).
        subs = [self._things(max(t + dt, 0.0)) for dt in offsets]
        images, visible = [], np.zeros(len(spec.balls), int)
        shown_px = []  # per camera, each ball's pixels in the middle sub-frame
        for cc in self._cams:
            acc = cc.background_sum.copy()
            boxes = [self._boxes(cc, things) for things in subs]
            crop = _union(boxes)
            if crop is not None:
                x0, y0, x1, y1 = crop
                part = None
                for k, (things, bx) in enumerate(zip(subs, boxes)):
                    img, ids = self._draw(cc, things, bx, crop)
                    part = img if part is None else part + img
                    if k == len(subs) // 2:
                        seen = np.bincount(ids[ids >= 0].ravel(), minlength=len(spec.balls))[: len(spec.balls)]
                        visible += seen > 0
                        shown_px.append(seen)
                acc[y0:y1, x0:x1] = part
            else:
                shown_px.append(np.zeros(len(spec.balls), int))
            response = cc.response
            gain = spec.lighting.brightness(t) * response.brightness(t)
            if response.gamma != 1.0:
                gain = max(gain, 0.0) ** (1.0 / response.gamma)
            if cc.response_map is not None:
                acc = cv2.multiply(acc, cc.response_map)
            # gain * mean of sub-frames + noise, saturated to uint8, in one OpenCV pass.
            if self._noise is not None:
                start = int(rng.integers(0, len(self._noise) - acc.size))
                noise = self._noise[start : start + acc.size].reshape(acc.shape)
                out = cv2.addWeighted(acc, gain / n_sub, noise, 1.0, 0.0, dtype=cv2.CV_8U)
            else:
                out = cv2.addWeighted(acc, gain / n_sub, acc, 0.0, 0.0, dtype=cv2.CV_8U)
            if response.greyscale:
                out = cv2.cvtColor(cv2.cvtColor(out, cv2.COLOR_BGR2GRAY), cv2.COLOR_GRAY2BGR)
            if spec.jpeg_quality > 0:
                ok, buf = cv2.imencode(".jpg", out, [cv2.IMWRITE_JPEG_QUALITY, int(spec.jpeg_quality)])
                out = cv2.imdecode(buf, cv2.IMREAD_COLOR)
            images.append(out)
        centres = self.ball_positions(t)
        clear = self._clear(centres, shown_px)
        truth = []
        # Every ball some camera sees (formats.md: a row per object visible), not only those whose centre is inside every
        # image: a fast ball flying in or out, tracked within 1-7 cm of its centre while that lay a few pixels out of one
        # image, was scored as a false positive (fast_ball tune seeds 0-79: 38 of 133). And every ball whose centre is
        # inside every image, hidden or not: a track coasting on a ball behind a prop is right. Where fewer than two
        # cameras show a quarter of it (``clear``), scoring leaves it optional.
        for k, c in enumerate(centres):
            if not np.isnan(c[0]) and (visible[k] > 0 or self._inside_every_image(c)):
                truth.append((k, float(c[0]), float(c[1]), float(c[2]), int(visible[k]), int(clear[k])))
        return tuple(images), truth

    def _inside_every_image(self, centre: np.ndarray) -> bool:
        """Is ``centre`` (3) in front of every camera and inside its image?"""
        for cam in self.rig.cameras:
            uv, front = cam.project(centre[None])
            if not (front[0] and 0 <= uv[0, 0] <= cam.width - 1 and 0 <= uv[0, 1] <= cam.height - 1):
                return False
        return True

    def _clear(self, centres: np.ndarray, shown_px: list[np.ndarray]) -> np.ndarray:
        """Per ball: how many cameras show CLEAR_SHARE or more of its disc (its pixels, ``shown_px`` per camera)."""
        shares = disc_shares(self.rig.cameras, centres, np.array([b.radius for b in self.spec.balls], float), shown_px)
        return (shares >= CLEAR_SHARE).sum(axis=0)

    def labels(self, frame: int) -> tuple[np.ndarray, ...]:
        """Per camera, H x W int16: what each pixel shows at the frame's time.

        k >= 0 is ball k, -1 the background (or a stage's walls), -2 - k
        occluder k, -1000 - k the stage's prop k, MOVER_IDS - j the j-th
        ellipsoid of the movers (hands, arms). Edge pixels count for a ball
        when it covers at least half of them. For measuring colour masks.
        """
        things = self._things(self.time(frame))
        out = []
        for cc in self._cams:
            ids = cc.ids.copy()
            boxes = self._boxes(cc, things)
            crop = _union([boxes])
            if crop is not None:
                x0, y0, x1, y1 = crop
                ids[y0:y1, x0:x1] = self._draw(cc, things, boxes, crop)[1]
            out.append(ids)
        return tuple(out)

    # ---- moving things at one instant: (id, object, centre, bounding radius)
    def _things(self, t: float) -> list[tuple]:
        out = []
        for k, (b, c) in enumerate(zip(self.spec.balls, self.ball_positions(t))):
            if not np.isnan(c[0]):
                out.append((k, b, c, float(b.radius)))
        shapes = [e for m in self.spec.movers for e in m.ellipsoids(t)]
        for j, e in enumerate(shapes):
            out.append((MOVER_IDS - j, e, np.asarray(e.centre, float), e.bound))
        return out

    def _boxes(self, cc: _CameraCache, things: list[tuple]) -> list[tuple[int, int, int, int] | None]:
        """Pixel bounding box of each thing: its bounding sphere's silhouette circle (the tangent cone), plus a margin."""
        if not things:
            return []
        h, w = cc.rays.shape[:2]
        c = np.array([th[2] for th in things], float)
        r = np.array([th[3] for th in things], float)
        oc = c - cc.centre
        dist = np.linalg.norm(oc, axis=1)
        inside = dist <= r * 1.01
        dist = np.where(inside, 2 * r, dist)
        axis = oc / dist[:, None]
        ref = np.where((np.abs(axis[:, 2]) < 0.9)[:, None], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0])
        a = np.cross(axis, ref)
        a /= np.linalg.norm(a, axis=1, keepdims=True)
        b = np.cross(axis, a)
        ang = np.linspace(0, 2 * np.pi, 24, endpoint=False)
        rim_r = 1.08 * r * np.sqrt(dist**2 - r**2) / dist
        rim = (cc.centre + axis * (dist - r * r / dist)[:, None])[:, None, :] + rim_r[:, None, None] * (
            np.cos(ang)[None, :, None] * a[:, None, :] + np.sin(ang)[None, :, None] * b[:, None, :]
        )
        uv, front = cc.camera.project(rim.reshape(-1, 3))
        uv, front = uv.reshape(len(c), 24, 2), front.reshape(len(c), 24)
        out = []
        for i in range(len(c)):
            if inside[i]:  # the camera is inside it: a ball is not drawn, anything else covers the image
                out.append(None if things[i][0] >= 0 else (0, 0, w, h))
                continue
            if not front[i].all():
                out.append(None)
                continue
            x0, y0 = np.floor(uv[i].min(axis=0)).astype(int) - 2
            x1, y1 = np.ceil(uv[i].max(axis=0)).astype(int) + 3
            x0, y0, x1, y1 = max(x0, 0), max(y0, 0), min(x1, w), min(y1, h)
            out.append(None if x0 >= x1 or y0 >= y1 else (int(x0), int(y0), int(x1), int(y1)))
        return out

    # ---- one camera, one instant: moving things z-buffered over the static scene, inside ``crop``
    def _draw(self, cc: _CameraCache, things: list[tuple], boxes: list, crop: tuple[int, int, int, int]) -> tuple[np.ndarray, np.ndarray]:
        x0, y0, x1, y1 = crop
        img = cc.background[y0:y1, x0:x1].copy()
        zbuf = cc.depth[y0:y1, x0:x1].copy()
        ids = cc.ids[y0:y1, x0:x1].copy()
        far_to_near = sorted(range(len(things)), key=lambda i: -float(np.linalg.norm(things[i][2] - cc.centre)))
        for i in far_to_near:  # so edges blend over what lies behind
            if boxes[i] is not None:
                self._draw_round(cc, img, zbuf, ids, crop, boxes[i], things[i])
        return img, ids

    def _draw_round(self, cc, img, zbuf, ids, crop, box, thing) -> None:
        """A ball or a mover's ellipsoid, with analytic anti-aliasing, into the crop's buffers."""
        k, obj, c, _ = thing
        x0, y0, x1, y1 = max(box[0], crop[0]), max(box[1], crop[1]), min(box[2], crop[2]), min(box[3], crop[3])
        if x0 >= x1 or y0 >= y1:
            return
        d = cc.rays[y0:y1, x0:x1]
        win = (slice(y0 - crop[1], y1 - crop[1]), slice(x0 - crop[0], x1 - crop[0]))
        lit = self.spec.lighting
        if k >= 0:  # a ball: a true sphere
            c = c.astype(np.float32)
            oc = c - cc.centre
            bproj = d @ oc  # distance along each ray to the closest approach
            miss2 = np.maximum(float(oc @ oc) - bproj * bproj, 0.0)  # squared ray-centre distance
            r = np.float32(obj.radius)
            miss = np.sqrt(miss2)
            # Pixel coverage from the ray's distance to the silhouette, in pixels.
            cover = np.clip(0.5 + (r - miss) * cc.focal / np.maximum(bproj, 1e-6), 0.0, 1.0)
            tz = bproj - np.sqrt(np.maximum(r * r - miss2, 0.0))
            mask = (cover > 0) & (bproj > 0) & (tz < zbuf[win])
            if not mask.any():
                return
            dm, tm, cm = d[mask], tz[mask], cover[mask][:, None]
            n = (cc.centre + tm[:, None] * dm - c) / r
            n /= np.linalg.norm(n, axis=1, keepdims=True)
            albedo, specular, shininess = obj.bgr, lit.specular, lit.shininess
        else:  # an ellipsoid: coverage from its normalised miss m (m = 1 on the silhouette), per pixel of image distance
            tz, m, normals = obj.intersect(cc.centre, d)
            gy, gx = np.gradient(m) if min(m.shape) > 1 else (np.ones_like(m), np.ones_like(m))
            cover = np.clip(0.5 + (1.0 - m) / np.maximum(np.hypot(gx, gy), 1e-6), 0.0, 1.0)
            mask = (cover > 0) & (tz > 0) & (tz < zbuf[win])
            if not mask.any():
                return
            dm, tm, cm, n = d[mask], tz[mask], cover[mask][:, None], normals[mask]
            mat = obj.material
            albedo, specular, shininess = np.asarray(mat.colour, np.float32), mat.specular, mat.shininess
        L = self._light
        lam = np.clip(n @ L, 0.0, None)
        half = L - dm
        half /= np.linalg.norm(half, axis=1, keepdims=True)
        highlight = np.clip(np.sum(n * half, axis=1), 0.0, None) ** shininess
        shade = lit.ambient + lit.diffuse * lam
        if cc.response.gamma != 1.0:
            shade = shade ** (1.0 / cc.response.gamma)
        colour = albedo * shade[:, None] + (255.0 * specular * highlight)[:, None]
        region = img[win]
        region[mask] = cm * colour + (1 - cm) * region[mask]
        solid = mask.copy()
        solid[mask] = cm[:, 0] >= 0.5
        zbuf[win][solid] = tz[solid]
        ids[win][solid] = k

    def _draw_box(self, cc: _CameraCache, k: int, occ: Occluder) -> None:
        """An occluder into the camera's static background, depth and ids."""
        img, zbuf, ids = cc.background, cc.depth, cc.ids
        lo = np.asarray(occ.centre, float) - np.asarray(occ.size, float) / 2
        hi = lo + np.asarray(occ.size, float)
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        uv, front = cc.camera.project(corners)
        h, w = cc.rays.shape[:2]
        if front.all():
            x0, y0 = np.maximum(np.floor(uv.min(axis=0)).astype(int) - 2, 0)
            x1, y1 = np.minimum(np.ceil(uv.max(axis=0)).astype(int) + 3, [w, h])
        else:
            x0, y0, x1, y1 = 0, 0, w, h
        if x0 >= x1 or y0 >= y1:
            return
        d = cc.rays[y0:y1, x0:x1]
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = 1.0 / d
            ta = (lo.astype(np.float32) - cc.centre) * inv
            tb = (hi.astype(np.float32) - cc.centre) * inv
        tmin, tmax = np.minimum(ta, tb), np.maximum(ta, tb)
        tmin = np.nan_to_num(tmin, nan=-np.inf)
        tmax = np.nan_to_num(tmax, nan=np.inf)
        t_near, face = tmin.max(axis=2), tmin.argmax(axis=2)
        t_far = tmax.min(axis=2)
        mask = (t_near <= t_far) & (t_near > 0) & (t_near < zbuf[y0:y1, x0:x1])
        if not mask.any():
            return
        normal_sign = -np.sign(d[mask][np.arange(mask.sum()), face[mask]])  # the face looks back at the camera
        normals = np.zeros((mask.sum(), 3), np.float32)
        normals[np.arange(mask.sum()), face[mask]] = normal_sign
        lit = self.spec.lighting
        shade = lit.ambient + lit.diffuse * np.clip(normals @ self._light, 0.0, None)
        if cc.response.gamma != 1.0:
            shade = shade ** (1.0 / cc.response.gamma)
        img[y0:y1, x0:x1][mask] = np.asarray(occ.colour, np.float32) * shade[:, None]
        zbuf[y0:y1, x0:x1][mask] = t_near[mask]
        ids[y0:y1, x0:x1][mask] = k


MOVER_IDS = -20000  # label of a mover's first ellipsoid (the j-th is MOVER_IDS - j)


def _union(boxes: list[list]) -> tuple[int, int, int, int] | None:
    """The part of the image that moving things touch during the exposure: the union of their boxes."""
    b = [x for bx in boxes for x in bx if x is not None]
    if not b:
        return None
    a = np.array(b)
    return int(a[:, 0].min()), int(a[:, 1].min()), int(a[:, 2].max()), int(a[:, 3].max())
