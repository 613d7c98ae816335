"""Wires the stages: frame pair -> masks -> particles -> objects -> tracks, with per-stage timings.

``Tracker.step`` turns one FramePair into one FrameResult (``run.py`` feeds
a source through it into sinks). The tracker never knows where frames came
from, and sinks never reach back into it.
"""

from __future__ import annotations

import time

import cv2
import numpy as np

from ..camera import Camera, Rig, intrinsics_from_fov, look_at
from ..config import Config, Target
from ..errors import StereotrackError
from ..evidence.blobs import Blobs, find_blobs
from ..evidence.colour import camera_masks
from ..frames import FramePair
from ..kernels import KERNELS
from ..objects.clustering import ClusterSettings, cluster_particles
from ..objects.explain import ExplainSettings, explain
from ..particles.kernels import nearest_within
from ..particles.population import Population, TrackedBalls
from ..results import FrameResult, Object3D, ParticleSet, Rays
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
        warm_up()  # compile (first run on a machine) or load the kernels now, not in the first frame
        s = config.tracker
        root = np.random.default_rng(s.seed)
        self.populations = {
            t.name: Population(rig.cameras, s, t.radius, np.random.default_rng(root.integers(2**63))) for t in config.targets
        }
        self.cluster_settings = {t.name: ClusterSettings.of(s, t.radius) for t in config.targets}
        self.explain_settings = {t.name: ExplainSettings.of(s, t.radius) for t in config.targets}
        self.cluster_rng = np.random.default_rng(root.integers(2**63))
        self.prev_means: dict[str, np.ndarray] = {t.name: np.zeros((0, 3)) for t in config.targets}
        self.identities = TrackManager(config.tracks, rig)
        self.last_time: float | None = None

    def step(self, pair: FramePair) -> FrameResult:
        self.rig.check_images(pair.images)
        s = self.config.tracker
        now = pair.time
        dt = (now - self.last_time) if self.last_time is not None else 0.0
        if not np.isfinite(dt) or dt < 0:
            dt = 0.0
        self.last_time = now
        timings: dict[str, float] = {}
        t0 = time.perf_counter()
        cams = self.rig.cameras
        cmasks = [camera_masks(cam.name, img, self.config.targets) for cam, img in zip(cams, pair.images)]
        t1 = time.perf_counter()
        timings["masks"] = 1e3 * (t1 - t0)
        blobs: dict[str, list[Blobs]] = {
            t.name: [find_blobs(cm.masks[t.name], s.blob_method, s.min_blob_area) for cm in cmasks] for t in self.config.targets
        }
        # Every blob's viewing ray, once: abduction places particles on them, explain-away fixes
        # one-view balls on them, the viewer draws them.
        rays = {name: [cam.rays(b.centres) for cam, b in zip(cams, per_cam)] for name, per_cam in blobs.items()}
        t2 = time.perf_counter()
        timings["blobs"] = 1e3 * (t2 - t1)
        live = [tr for tr in self.identities.predicted(now) if tr.state != "tentative"]
        predicted = [tr for tr in live if tr.state == "confirmed"]
        radius = {t.name: t.radius for t in self.config.targets}
        centres = np.array([tr.position for tr in predicted]).reshape(-1, 3)
        radii = np.array([radius[tr.target] for tr in predicted])
        ids = np.array([tr.track_id for tr in predicted], dtype=int)
        states = {}
        for t in self.config.targets:
            balls = TrackedBalls(centres, radii, ids, np.array([tr.target != t.name for tr in predicted], dtype=bool))
            states[t.name] = self.populations[t.name].step([cm.integrals[t.name] for cm in cmasks], blobs[t.name], dt, balls, rays[t.name])
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
            pred = np.array([tr.position for tr in live if tr.target == t.name]).reshape(-1, 3)
            others = [tr for tr in live if tr.target != t.name] if s.occlusion else []
            occluders = (np.array([tr.position for tr in others]).reshape(-1, 3), np.array([radius[tr.target] for tr in others]))
            kept_objects, into = explain(candidates, cams, blobs[t.name], self.explain_settings[t.name], pred, rays[t.name], occluders)
            remap = np.r_[np.where(into >= 0, into + len(objects), -1), -1]  # the last entry maps label -1
            objects.extend(kept_objects)
            particle_sets.append(ParticleSet(t.name, st.positions, st.weights, st.abductive, remap[cl.labels]))
        t4 = time.perf_counter()
        timings["clusters"] = 1e3 * (t4 - t3)
        tracks = self.identities.update(objects, now)
        self._follow_tracks(tracks)
        t5 = time.perf_counter()
        timings["tracks"] = 1e3 * (t5 - t4)
        timings["step"] = 1e3 * (t5 - t0)
        shown_rays = self._rays(blobs, rays) if self.keep_rays else ()
        masks = {(t.name, cm.camera): cm.masks[t.name] for cm in cmasks for t in self.config.targets}
        return FrameResult(
            frame=pair,
            particles=tuple(particle_sets),
            objects=tuple(objects),
            tracks=tracks,
            rays=shown_rays,
            masks=masks,
            timings_ms=timings,
        )

    def _follow_tracks(self, tracks) -> None:
        """Particles near a live track follow it: its velocity drifts them in the next step (beyond the
        random walk) and its id marks whose ball they are (for exclusion)."""
        for t in self.config.targets:
            pop = self.populations[t.name]
            if pop.state is None:
                continue
            mine = [tr for tr in tracks if tr.target == t.name]
            centres = np.array([tr.position for tr in mine]).reshape(-1, 3)
            nearest = nearest_within(pop.state.positions, centres, np.sqrt((3 * t.radius) ** 2 + 0.0025))
            # Looked up with a last row for "no track" (nearest = -1): one gather per array.
            owners = np.array([tr.track_id for tr in mine] + [-1])[nearest]
            speeds = [tr.velocity for tr in mine] if self.config.tracker.particle_velocity else [np.zeros(3)] * len(mine)
            vel = np.array(speeds + [np.zeros(3)]).reshape(-1, 3)[nearest]
            pop.follow_tracks(vel, owners)

    def _rays(self, blobs: dict[str, list[Blobs]], rays) -> tuple[Rays, ...]:
        out = []
        for name, per_cam in blobs.items():
            for cam, b, (o, d) in zip(self.rig.cameras, per_cam, rays[name]):
                out.append(Rays(name, cam.name, o, d, b.centres))
        return tuple(out)


# --------------------------------------------------------------------------- warm-up

_WARM = False


def warm_up() -> None:
    """Compile (first run on a machine) or load every kernel now, not in the first frame.

    Derived from the tracker itself rather than kept as a list of calls: a
    tracker follows a tiny drawn scene made to visit every stage's branches
    (two colours; a pink ball partly behind an orange one in one view; two
    pink balls sharing a blob in one view and apart in the other, so the disc
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
        ]
        images = []
        for cam in cams:
            img = np.full((h, w, 3), 90, np.uint8)
            for name, centre in sorted(balls, key=lambda b: -cam.depth(b[1][None])[0]):  # far to near
                uv, _, z = cam.view(centre[None])
                r = cam.focal_px * radius / z[0]
                cv2.circle(img, (int(round(uv[0, 0])), int(round(uv[0, 1]))), max(1, int(round(r))), colours[name].tolist(), -1)
            images.append(img)
        tracker.step(FramePair(frame, tuple(images), (frame / 30.0,) * 2))


def compiled_kernels() -> dict[str, int]:
    """How many signatures each kernel has compiled so far (name -> count)."""
    return {f"{k.py_func.__module__}.{k.py_func.__name__}": len(k.signatures) for k in KERNELS}
