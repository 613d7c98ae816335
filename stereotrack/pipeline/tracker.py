"""Wires the stages: frame pair -> evidence -> particles -> objects -> tracks, with per-stage timings.

``Tracker.step`` turns one FramePair into one FrameResult (``run.py`` feeds
a source through it into sinks). The tracker never knows where frames came
from, and sinks never reach back into it.
"""

from __future__ import annotations

import os
import time
from collections.abc import Iterable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field, replace

import cv2
import numpy as np

from ..camera import Camera, Rig, intrinsics_from_fov, look_at
from ..config import Config, Target
from ..errors import StereotrackError
from ..evidence.colour import CameraMasks, camera_masks, motion_range, range_bounds, streak_range
from ..evidence.colour_model import ColourModel, load_colour_model
from ..evidence.gather import CameraEvidence, Faint, every_nth, every_nth_and_halved, on_grid
from ..evidence.motion import SCALE, BackgroundModel, shading, still_only
from ..evidence.outlines import OutlineFinder, marked
from ..evidence.stereo_patches import paired
from ..frames import FramePair
from ..kernels import KERNELS
from ..objects.clustering import ClusterSettings, cluster_particles
from ..objects.explain import ExplainSettings, explain
from ..objects.surface import SurfacePatches, flat
from ..particles.population import Population
from ..results import FrameResult, Object3D, ParticleSet, Rays, TrackedBalls
from ..tracks.manager import TrackManager


class Tracker:
    """The particle tracker of the paper plus persistent identities.

    One particle population per target colour; one TrackManager for all.
    """

    def __init__(self, rig: Rig, config: Config, keep_rays: bool = False):
        if not config.targets:
            raise StereotrackError("no targets to track: the config has an empty 'targets' list (see 'stereotrack colour learn')")
        self.rig = rig
        self.config = config
        self.keep_rays = keep_rays
        s = config.tracker
        # the user's files first: a damaged colour model is refused before the (slow) kernel warm-up
        self.colour_models = (
            {
                t.name: [ColourModel.for_target(t, load_colour_model(t.colour_model) if t.colour_model else None) for _ in rig.cameras]
                for t in config.targets
            }
            if s.colour_model
            else None
        )
        warm_up()  # compile (first run on a machine) or load the kernels now, not in the first frame
        root = np.random.default_rng(s.seed)
        self.populations = {t.name: Population(rig.cameras, s, t, np.random.default_rng(root.integers(2**63))) for t in config.targets}
        self.cluster_settings = {t.name: ClusterSettings.of(s, t.radius) for t in config.targets}
        self.explain_settings = {
            t.name: ExplainSettings.of(s, t.radius, short_streaks=not t.any_hue, partial_views=not t.any_hue) for t in config.targets
        }
        self.cluster_rng = np.random.default_rng(root.integers(2**63))
        self.prev_means: dict[str, np.ndarray] = {t.name: np.zeros((0, 3)) for t in config.targets}
        self.radius = {t.name: t.radius for t in config.targets}
        self.identities = TrackManager(config.tracks, rig, self.radius)
        # The surface test judges still objects, and without motion (no backgrounds) nothing is still: no test then. A
        # white or grey ball's blob at rest is its shading's patch (motion.shading), not its outline: no shape test for it
        self.surfaces = (
            {t.name: SurfacePatches(t.radius, rig.cameras, shapes=not t.any_hue, colour=t) for t in config.targets}
            if s.surfaces and s.motion
            else {}
        )
        # Evidence on a coarser grid where balls span many pixels (config: evidence_scale); the background model
        # reads that grid's image too (and keeps half its size, motion.py).
        smallest = min(t.radius for t in config.targets)
        self.scales = [evidence_scale(s, cam, smallest) for cam in rig.cameras]
        self.evidence_cameras = [on_grid(cam, k) for cam, k in zip(rig.cameras, self.scales)]
        white = {t.name: t for t in config.targets if t.any_hue}  # their kept-out discs are checked for ghosts
        self._held_early = tuple(white) if s.motion else ()  # their tentative tracks keep their discs out of the backgrounds
        self.backgrounds = (
            [
                BackgroundModel(cam, s.background_rate, s.foreground_threshold, white, faint=len(white) < len(config.targets))
                for cam in self.evidence_cameras
            ]
            if s.motion
            else None
        )
        # Where each target's moving map may take pixels out of its range: a white ball's shaded side, a fast ball's streak
        self.moving_ranges = {t.name: (motion_range(t), None) if t.any_hue else (None, streak_range(t)) for t in config.targets}
        self.bounds = {t.name: range_bounds(t) for t in config.targets}
        coloured = [t for t in config.targets if not t.any_hue]
        self.other_bounds = {  # per target, the other coloured targets' ranges: their balls' edges are no faint streak
            t.name: np.array([self.bounds[o.name] for o in coloured if o.name != t.name], np.int64).reshape(-1, 7) for t in config.targets
        }
        self.last_time: float | None = None
        # A white or grey target's shading is compared between cameras (stereo_patches.py) before its evidence is made,
        # where the surface test can tell a pair that is a patch of what it is seen on
        self._pairs_shading = bool(self.surfaces) and s.shading and len(rig.cameras) > 1 and any(t.any_hue for t in config.targets)
        # A white or grey target's still patch is looked for in the other views by its outline (evidence/outlines.py; with
        # motion only: a patch is still where nothing moves). Not a coloured target's: a ball of its colour larger than it
        # (static_props seeds 3003 and 3016, never tuned on: big balls on stands) showed round outlines of its size in
        # both views at one depth, its highlight's or its limb's, and held false tracks for 49-77 frames.
        outlined = [t for t in config.targets if t.any_hue] if s.outlines and s.motion and len(rig.cameras) > 1 else []
        self._outline_finders = {t.name: OutlineFinder(rig.cameras, self.scales, t, s) for t in outlined}
        workers = min(len(rig.cameras), s.threads or os.cpu_count() or 1)
        self._pool = ThreadPoolExecutor(workers, thread_name_prefix="evidence") if workers > 1 else _InThisThread()

    def colours(self, images) -> list:
        """Per camera: the image on its evidence grid, that image's HSV and range masks, and (with motion) the image on
        the background's grid (motion.halved). The step's first part,
        and nothing the tracks hold changes it: a caller with the next pair at hand may make it ahead, in another
        thread (pipeline/run.py), and give it to ``step``."""
        return [self._colours(j, image) for j, image in enumerate(images)]

    @property
    def background_start(self) -> int:
        """How many frames spread over a recording its backgrounds would start from (``start_backgrounds``; 0: from its
        first frame). Only with a white or grey target: its colour is the room's, so motion finds it, and the first
        frame's balls left ghosts and hid moving balls (white_ball tune seeds 0-19: median 0.863 -> 0.974). A coloured
        ball's colour finds it from the first frame, and in such a background a hand that moves a little is moving
        whole from the first frame, before any track has taught the colour model the ball's colours (hands tune
        seeds 12 and 17: 0.522 -> 0.033, 0.872 -> 0.256)."""
        if not self.backgrounds or not any(t.any_hue for t in self.config.targets):
            return 0
        return self.config.tracker.background_start

    def start_backgrounds(self, pairs: Iterable[FramePair]) -> None:
        """Start each camera's background from these pairs (spread over a recording) instead of the first frame
        tracked (motion.BackgroundModel.start). Each pair is kept on the background's grid only, as it comes (15 pairs
        of three 1280x720 frames would hold 125 MB). Nothing to do without motion, or without pairs."""
        if not self.backgrounds:
            return
        grids = [[every_nth_and_halved(image, k)[1] for image, k in zip(pair.images, self.scales)] for pair in pairs]
        if grids:
            for j, bg in enumerate(self.backgrounds):
                bg.start([cameras[j] for cameras in grids])

    def _colours(self, j: int, image: np.ndarray):
        # The frame on the background's grid is made here too (no track is needed for it: made ahead with the rest),
        # in the same pass as the evidence grid's when that is coarser than the frame.
        if self.backgrounds:
            small, small_halved = every_nth_and_halved(image, self.scales[j])
        else:
            small, small_halved = every_nth(image, self.scales[j]), None
        # The ranges' integral images are made with the other maps (evidence/gather.py), if at all
        masks = camera_masks(self.evidence_cameras[j].name, small, self.config.targets, integrals=False)
        return small, masks, small_halved

    def step(self, pair: FramePair, colours: list | None = None) -> FrameResult:
        """Track one pair; ``colours``: the pair's ``colours(pair.images)``, when it was made ahead."""
        self.rig.check_images(pair.images)
        s = self.config.tracker
        now = pair.time
        dt = (now - self.last_time) if self.last_time is not None else 0.0
        if not np.isfinite(dt) or dt < 0:
            dt = 0.0
        self.last_time = now
        timings: dict[str, float] = {"masks": 0.0, "blobs": 0.0}
        t0 = time.perf_counter()
        cams = self.rig.cameras
        predicted = self.identities.predicted(now)
        balls = TrackedBalls.from_tracks(predicted, self.radius)  # confirmed and coasting
        confirmed = balls.confirmed_only()
        # The backgrounds keep a white or grey ball out from its first hit: a ball at rest is learnt into the room in the
        # frames its track is tentative, and leaves a ghost when it rolls on (motion.BackgroundModel._moved)
        held = TrackedBalls.from_tracks(predicted, self.radius, self._held_early) if self._held_early else balls
        # Each camera's evidence, once: its masks, then each target's blobs and their viewing rays, read by
        # every later stage. Cameras are independent, so they run side by side (the compiled and OpenCV
        # parts release the GIL).
        n = len(cams)
        if self._pairs_shading:  # two passes: a white ball's crowded patches are kept where another camera shows them too
            motion = list(self._pool.map(self._camera_motion, range(n), pair.images, [held] * n, colours or [None] * n))
            self._pair_crowded(motion, pair.images, now)
            per_camera = list(self._pool.map(self._camera_views, range(n), motion, [confirmed] * n))
        else:
            per_camera = list(
                self._pool.map(self._camera_evidence, range(n), pair.images, [held] * n, [confirmed] * n, colours or [None] * n)
            )
        if self._outline_finders:  # a ball at rest that one view buries in its colour, found by its outline in another
            self._find_buried(per_camera, pair.images, confirmed, now)
        cmasks = [cm for cm, _, _, _ in per_camera]
        views = {t.name: tuple(v[t.name] for _, v, _, _ in per_camera) for t in self.config.targets}
        for _, _, (masks_ms, blobs_ms), _ in per_camera:  # work done, summed over cameras
            timings["masks"] += masks_ms
            timings["blobs"] += blobs_ms
        t2 = time.perf_counter()
        timings["evidence"] = 1e3 * (t2 - t0)  # the stage's own time, cameras side by side
        states = {t.name: self.populations[t.name].step(views[t.name], dt, confirmed) for t in self.config.targets}
        t3 = time.perf_counter()
        timings["particles"] = 1e3 * (t3 - t2)
        objects: list[Object3D] = []
        particle_sets = []
        for t in self.config.targets:
            st = states[t.name]
            cl = cluster_particles(
                st.positions, st.weights, st.likelihoods, cams, self.cluster_settings[t.name], self.prev_means[t.name], self.cluster_rng
            )
            self.prev_means[t.name] = cl.means
            candidates = [
                Object3D(t.name, cl.means[k], cl.covariances[k], float(cl.masses[k]), int(cl.counts[k])) for k in range(len(cl.means))
            ]
            occluders = balls.occluding(t.name) if s.occlusion else None
            kept_objects, into = explain(candidates, views[t.name], self.explain_settings[t.name], balls.of(t.name), occluders)
            # Nothing is still in a background's first frame (it is the background): nothing is judged there
            if t.name in self.surfaces and all(bg.compared for bg in self.backgrounds):
                foregrounds = [m.foreground for _, _, _, m in per_camera] if t.any_hue else None
                kept_objects, into = self._off_surfaces(kept_objects, into, views[t.name], pair.images, balls.of(t.name), now, foregrounds)
            remap = np.append(np.where(into >= 0, into + len(objects), -1), -1)  # the last entry maps label -1
            objects.extend(kept_objects)
            particle_sets.append(ParticleSet(t.name, st.positions, st.weights, st.abductive, remap[cl.labels]))
        t4 = time.perf_counter()
        timings["clusters"] = 1e3 * (t4 - t3)
        tracks = self.identities.update(objects, now)
        for population in self.populations.values():
            population.follow(tracks)
        t5 = time.perf_counter()
        timings["tracks"] = 1e3 * (t5 - t4)
        timings["step"] = 1e3 * (t5 - t0)
        shown_rays = (
            tuple(
                Rays(name, v.camera.name, v.origins, v.directions, v.blobs.centres * k)  # full-size pixels
                for name, vs in views.items()
                for v, k in zip(vs, self.scales)
            )
            if self.keep_rays
            else ()
        )
        masks = {(t.name, cm.camera): cm.masks[t.name] for cm in cmasks for t in self.config.targets}
        evidence = {(name, v.camera.name): _kept(v) for name, vs in views.items() for v in vs}
        return FrameResult(
            frame=pair,
            particles=tuple(particle_sets),
            objects=tuple(objects),
            tracks=tracks,
            rays=shown_rays,
            masks=masks,
            evidence=evidence,
            timings_ms=timings,
        )

    def _camera_evidence(self, j: int, image: np.ndarray, held: TrackedBalls, confirmed: TrackedBalls, colours=None):
        """Camera j's masks (``colours``: made ahead), and every target's evidence in it; with the ms each half took.
        ``held``: the balls whose discs the background may keep from learning (confirmed and coasting; a white target's
        tentative ones too)."""
        return self._camera_views(j, self._camera_motion(j, image, held, colours), confirmed)

    def _camera_motion(self, j: int, image: np.ndarray, held: TrackedBalls, colours=None) -> _CameraMotion:
        """Camera j's masks, its foreground and each white or grey target's shading in it (``_camera_evidence``'s
        first half)."""
        t0 = time.perf_counter()
        small, cm, small_halved = colours if colours is not None else self._colours(j, image)
        foreground = self.backgrounds[j].update(small, held, small_halved) if self.backgrounds else None
        t1 = time.perf_counter()
        shaded, crowded = self._shaded(j, small_halved, foreground)
        return _CameraMotion(cm, small_halved, foreground, shaded, crowded, 1e3 * (t1 - t0), 1e3 * (time.perf_counter() - t1))

    def _pair_crowded(self, motion: list[_CameraMotion], images, now: float) -> None:
        """Each white or grey target's crowded patches that another camera shows as the same ball (evidence/
        stereo_patches.py), and that are no patch of the surface they are seen on (objects/surface.py, as still
        objects are judged), join its shaded map, in every camera."""
        s = self.config.tracker
        for t in self.config.targets:
            if t.name not in motion[0].crowded:
                continue
            alone = [m.shaded[t.name] & ~m.foreground for m in motion]  # (crowded only with a foreground: _shaded)
            crowded = [m.crowded[t.name] for m in motion]

            def scenery(point, judge=self.surfaces[t.name]):
                return judge.on_surface(point, images, now)

            for m, found in zip(motion, paired(crowded, alone, self.evidence_cameras, t.radius, s.d_min, s.d_max, SCALE, scenery)):
                m.shaded[t.name] |= found

    def _camera_views(self, j: int, motion: _CameraMotion, confirmed: TrackedBalls):
        """Every target's evidence in camera j, from its masks and motion (``_camera_evidence``'s second half); with the
        ms each half took and ``motion`` (holding the colour tables used, for ``_find_buried``)."""
        cm, t1 = motion.masks, time.perf_counter()
        motion.colour = {t.name: self._colour_table(t, j, cm, confirmed, motion.foreground) for t in self.config.targets}
        views = {t.name: self._target_view(j, t, motion) for t in self.config.targets}
        return cm, views, (motion.masks_ms, motion.shading_ms + 1e3 * (time.perf_counter() - t1)), motion

    def _target_view(self, j: int, t: Target, motion: _CameraMotion, foreground=None, in_range=None) -> CameraEvidence:
        """Target ``t``'s evidence in camera j, from its masks, motion and colour table; ``foreground``: what moves for it
        (default: the camera's foreground, or a white or grey target's shaded map); ``in_range``: its range mask (default:
        the camera's)."""
        s, cm, k = self.config.tracker, motion.masks, self.scales[j]
        if foreground is None:
            foreground = motion.shaded[t.name] if t.name in motion.shaded else motion.foreground
        table, things = motion.colour[t.name]
        return CameraEvidence.from_mask(
            self.evidence_cameras[j],
            cm.masks[t.name] if in_range is None else in_range,
            None,
            s.blob_method,
            max(1, round(s.min_blob_area / (k * k))),  # the setting counts full-size pixels
            foreground,
            (t.radius, s.d_min, s.d_max) if s.ball_blobs_only else None,
            table,
            cm.hsv,
            # read with a colour table only; not for a white or grey ball, whose colour is the room's: what a pixel
            # replaced is as likely the ball's, and a ball at rest (its shading) is in the background
            self.backgrounds[j].behind if self.backgrounds and self.colour_models and not t.any_hue else None,
            *self.moving_ranges[t.name],
            self._faint(t, j, motion.small_halved),
            things,
        )

    def _find_buried(self, per_camera: list, images, confirmed: TrackedBalls, now: float) -> None:
        """Per target, the balls that one view buries in their colour, found by their outlines (evidence/outlines.py), count
        as moving in the views that show them, with the ring round them out of the range where it is of their colour:
        those views' evidence is made again with them (``per_camera``'s views, in place)."""
        for t in (t for t in self.config.targets if t.name in self._outline_finders):
            views = [v[t.name] for _, v, _, _ in per_camera]
            in_range = [cm.masks[t.name] for cm, _, _, _ in per_camera]
            foregrounds = [motion.foreground for _, _, _, motion in per_camera]
            judge = self._thing_judge(t, images, now)
            found = self._outline_finders[t.name](views, in_range, foregrounds, images, confirmed.of(t.name).centres, judge)
            for j, ((_, views, _, motion), discs) in enumerate(zip(per_camera, found)):
                if len(discs):
                    moving = motion.shaded[t.name] if t.name in motion.shaded else motion.foreground
                    views[t.name] = self._target_view(j, t, motion, *marked(moving, in_range[j], discs, self.scales[j]))

    def _thing_judge(self, t: Target, images, now: float):
        """Is a ball of ``t`` found by its outline at a point a thing? One flat colour in every view (a knob, a sticker:
        surface.flat) or a patch of the surface it is seen on (surface.SurfacePatches.on_surface, when still objects are
        judged), as a still object would be judged; its disc moves once found, and a moving object is not."""
        judge = self.surfaces.get(t.name)
        colour = None if t.any_hue else t

        def thing(point: np.ndarray) -> bool:
            if flat(point, t.radius, self.rig.cameras, images, colour):
                return True
            return judge is not None and judge.on_surface(point, images, now)

        return thing

    def _off_surfaces(
        self, objects: list[Object3D], into: np.ndarray, views, images, balls: TrackedBalls, now: float, foregrounds=None
    ) -> tuple:
        """The objects less those that are patches of the surface they are seen on (objects/surface.py: a still object
        away from every ball that has travelled, whose surround matches between views at its own depth: a book's end, a
        poster's corner of the ball's colour); with ``into`` renumbered. With each camera's ``foregrounds`` (a white or
        grey target's), a calm object must show a round outline too (SurfacePatches.drop)."""
        if not objects:
            return objects, into
        calm = self._calm(objects, foregrounds) if foregrounds is not None else None
        drop = self.surfaces[objects[0].target].drop(objects, views, images, balls.where(balls.travelled).centres, now, calm)
        if not drop.any():
            return objects, into
        new = np.cumsum(~drop) - 1
        gone = drop[np.maximum(into, 0)]
        into = np.where((into >= 0) & ~gone, new[np.maximum(into, 0)], -1)
        return [o for o, d in zip(objects, drop) if not d], into

    def _calm(self, objects: list[Object3D], foregrounds: list[np.ndarray]) -> np.ndarray:
        """Per object, whether no camera's foreground changed lately in the box of its ball's disc (motion.BackgroundModel.
        changed): what holds it in the moving map is shading or a still difference from the background."""
        positions = np.array([o.position for o in objects])
        radius = self.radius[objects[0].target]
        out = np.ones(len(objects), bool)
        for bg, foreground in zip(self.backgrounds, foregrounds):
            uv, front, depth = bg.camera.view(positions)
            r = bg.camera.apparent_radius(radius, depth) + 1.0  # a pixel more: the disc's blurred edge
            for k in np.flatnonzero(front & np.isfinite(uv).all(axis=1)):
                out[k] &= not bg.changed(foreground, uv[k, 0], uv[k, 1], r[k])
        return out

    def _faint(self, target, j: int, small_halved: np.ndarray | None) -> Faint | None:
        """Where camera j's faint changes may hold a streak of ``target`` (a coloured one: motion.py's FAINT_SHARE)."""
        bg = self.backgrounds[j] if self.backgrounds else None
        if bg is None or bg.faint is None or target.any_hue or bg.behind is None or small_halved is None:
            return None
        return Faint(bg.faint, small_halved, bg.behind, self.bounds[target.name], self.other_bounds[target.name])

    def _shaded(self, j: int, small_halved: np.ndarray | None, foreground: np.ndarray | None) -> tuple[dict, dict]:
        """Per target of every hue (a white or grey ball), camera j's foreground with the pixels that show a ball by their
        shading added (motion.shading): a white ball at rest in a white room moves no more than the wall and has its
        colour, and counts as moving where its shading shows. And per such target, when the cameras' shading is paired,
        the still patches that would show a ball but for what is around them (kept where another camera shows them
        too: ``_pair_crowded``). Empty without motion or such a target."""
        if foreground is None or small_halved is None or not self.config.tracker.shading:
            return {}, {}
        out, crowded = {}, {}
        cam = self.evidence_cameras[j]
        for t in self.config.targets:
            if t.any_hue:
                seen = cam.apparent_radius(t.radius, 1.0) / SCALE  # the ball's apparent radius on the background's grid at 1 m
                near, far = seen / max(self.config.tracker.d_min, SHADING_NEAR), seen / self.config.tracker.d_max
                if self._pairs_shading:  # its crowded patches are compared between cameras (_pair_crowded)
                    alone, busy = shading(small_halved, t, near, far, crowded=True)
                    crowded[t.name] = still_only(busy, foreground)
                else:
                    alone = shading(small_halved, t, near, far)
                out[t.name] = cv2.bitwise_or(foreground, still_only(alone, foreground))
        return out, crowded

    def _colour_table(self, target, j: int, cm, confirmed: TrackedBalls, foreground: np.ndarray | None = None) -> tuple:
        """(p(ball | colour) per colour bin, the colours of moving things) for ``target`` in camera j, both as learnt
        before this frame (None, None without colour models); then the model learns this frame, the ball's colours
        under the confirmed tracks of the target."""
        if self.colour_models is None:
            return None, None
        model = self.colour_models[target.name][j]
        table, things = model.table_and_things(cm.hsv)
        cam = self.evidence_cameras[j]
        mine = confirmed.of(target.name)
        uv, front, depth = cam.view(mine.centres)
        model.learn(cm.hsv, cm.masks[target.name], uv[front], cam.apparent_radius(mine.radii[front], depth[front]), foreground, things)
        return table, things


@dataclass
class _CameraMotion:
    """A camera's first half of its evidence (Tracker._camera_motion), before the cameras' shading is compared."""

    masks: CameraMasks  # its HSV and range masks
    small_halved: np.ndarray | None  # the frame on the background's grid
    foreground: np.ndarray | None  # what moves there (uint8 0/1); None without motion
    shaded: dict  # per white or grey target, the foreground with its shading's patches (uint8 0/1)
    crowded: dict  # ... and the patches that are not alone (Tracker._shaded)
    masks_ms: float  # the masks and the foreground took
    shading_ms: float  # the shading took
    colour: dict = field(default_factory=dict)  # per target, its colour table and moving things as _colour_table gave them


SHADING_NEAR = 0.5  # metres: the nearest a white ball's shading map expects it (its holes are filled up to its lit centre there)
HALF_GRID_MIN_WIDTH = 1280  # automatic evidence_scale: images this wide or wider ...
HALF_GRID_MIN_RADIUS_PX = 5.0  # ... where the smallest ball at d_max spans at least this radius (full-size pixels)


def evidence_scale(s, camera: Camera, radius: float) -> int:
    """How many image pixels a side of one evidence cell spans in this camera (TrackerSettings.evidence_scale);
    ``radius``: the smallest target's, metres. Automatic: every other pixel where even that ball at the farthest
    depth looks large (a small or far ball, a few pixels wide, keeps every pixel)."""
    if s.evidence_scale:
        return s.evidence_scale
    large = camera.focal_px * radius / s.d_max >= HALF_GRID_MIN_RADIUS_PX
    return 2 if camera.width >= HALF_GRID_MIN_WIDTH and large and s.likelihood == "ball_shape" else 1


class _InThisThread:
    """``map`` without threads (a one-core machine, or one camera)."""

    def map(self, fn, *iterables):
        return map(fn, *iterables)


def _kept(view: CameraEvidence) -> np.ndarray:
    """The pixels the observation model counts: the colour it kept, and the moving part of the range."""
    if view.counted is not None:
        return view.counted
    return view.mask if view.moving is None else cv2.bitwise_or(view.mask, view.moving)


# --------------------------------------------------------------------------- warm-up

_WARM = False


def warm_up() -> None:
    """Compile (first run on a machine) or load every kernel now, not in the first frame.

    Derived from the tracker itself rather than kept as a list of calls: a
    tracker follows a tiny drawn scene made to visit every stage's branches
    (two colours; a pink ball partly behind an orange one in one view; two
    pink balls sharing a blob in one view and apart in the other, so the disc
    fit runs; a pink ball cut by a grey bar in one view, so the partial-view
    fit runs; tracks confirmed, so exclusion and the Kalman steps run). Every
    kernel is then compiled with the argument types a real run passes;
    tests/test_kernels.py checks that each one was, and that a real run
    compiles nothing more.
    """
    global _WARM
    if _WARM:
        return
    _WARM = True
    w, h, radius = 320, 240, 0.035
    cams = []
    for i, x in enumerate((-0.15, 0.15)):
        R, t = look_at((x, 0.0, 0.0), (0.0, 1.5, 0.0), up=(0.0, 0.0, 1.0))
        cams.append(Camera(f"cam{i}", (w, h), intrinsics_from_fov(w, h, 60.0), np.zeros(5), R, t))
    rig = Rig(tuple(cams))
    pink, orange = Target("pink", (150, 80, 80), (170, 255, 255), radius), Target("orange", (5, 80, 80), (20, 255, 255), radius)
    tracker = Tracker(rig, Config(targets=(pink, orange)))
    colours = {
        "pink": cv2.cvtColor(np.uint8([[[160, 200, 230]]]), cv2.COLOR_HSV2BGR)[0, 0],
        "orange": cv2.cvtColor(np.uint8([[[12, 200, 230]]]), cv2.COLOR_HSV2BGR)[0, 0],
    }
    near = np.array([0.0, 1.2, 0.0])
    behind = cams[0].centre + 1.6 * (near - cams[0].centre) + np.array([0.0, 0.0, 0.6 * radius])  # shares near's blob in cam0 only
    for frame in range(8):
        drift = np.array([0.01 * frame, 0.0, 0.0])
        balls = [
            ("pink", near + drift),
            ("pink", behind + drift),
            ("pink", np.array([0.3, 1.8, 0.1]) - drift),
            ("orange", np.array([0.27, 1.6, 0.1]) - drift),
            ("pink", cut := np.array([-0.35, 1.4, -0.15]) + drift),
        ]
        images = []
        for cam in cams:
            img = np.full((h, w, 3), 90, np.uint8)
            for name, centre in sorted(balls, key=lambda b: -cam.depth(b[1][None])[0]):  # far to near
                uv, _, z = cam.view(centre[None])
                r = cam.apparent_radius(radius, z[0])
                cv2.circle(img, (int(round(uv[0, 0])), int(round(uv[0, 1]))), max(1, int(round(r))), colours[name].tolist(), -1)
            if cam is cams[1]:  # a grey bar hides the left half of one ball in this view only
                uv, _, z = cam.view(cut[None])
                r = cam.apparent_radius(radius, z[0])
                cv2.rectangle(img, (int(uv[0, 0] - r - 2), int(uv[0, 1] - r - 2)), (int(uv[0, 0]), int(uv[0, 1] + r + 2)), (60, 60, 60), -1)
            images.append(img)
        tracker.step(FramePair(frame, tuple(images), (frame / 30.0,) * 2))
        if frame == 0:  # a camera's evidence on a coarser grid than its frames (a wide frame's): picked and halved at once
            coarse = Tracker(rig, Config(targets=(pink, orange), tracker=replace(tracker.config.tracker, evidence_scale=2)))
            coarse.step(FramePair(frame, tuple(images), (frame / 30.0,) * 2))
    # a white or grey target's shading map (its straight edges' kernel): the scene's balls are coloured
    shading(np.full((h // 2, w // 2, 3), 200, np.uint8), Target("white", (0, 0, 170), (179, 50, 255), radius), 10.0, 1.0)


def compiled_kernels() -> dict[str, int]:
    """How many signatures each kernel has compiled so far (name -> count)."""
    return {f"{k.py_func.__module__}.{k.py_func.__name__}": len(k.signatures) for k in KERNELS}
