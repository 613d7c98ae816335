"""Persistent identities: objects found each frame -> tracks with the same id over time.

Each track is a constant-velocity Kalman filter on (position, velocity), with gravity as a known acceleration when
the world's up axis is set and the ball flies freely (see ``in_free_flight``), and air drag on a fast ball
(``motion.fast_flight_model``). Every frame the tracks are predicted to the frame's time (dt from timestamps, not
frame counts), this frame's objects are assigned to them globally (Hungarian, ``scipy.optimize.linear_sum_assignment``)
inside a Mahalanobis gate, and the lifecycle moves on:

    tentative --(seen for confirm_time s, or 3 frames in a row at confirm_speed)--> confirmed <--> coasting --(unseen for delete_time s)--> deleted
    tentative --(unseen for tentative_time s)--> deleted

All limits are in seconds, so a run behaves the same at 15, 30 or 60 fps.
The frame a track is confirmed, its estimate carries its hits while tentative
(``TrackEstimate.before``): tracks.csv writes the ball from its first frame.
Once a frame is ``smooth_time`` old, each track gives its state there smoothed
with the frames since (``TrackEstimate.smoothed``, a Rauch-Tung-Striebel
smoother): tracks.csv writes that in place of the filter's.
With a rig, two places metres apart along a ray that are one ball in every
camera's image count as one ball (``sight.on_balls``): a track seen only off and
on that coasts where a hit track holds that ball is not reported, and an
object on a steadily seen track's ball starts no track of its own.
Objects of different targets never match each other; ids are positive
integers unique across targets within a run.

The motion noise is continuous white acceleration (spectral density
``accel_noise``): unlike a per-frame noise it integrates to the same
uncertainty over one second whatever the frame rate. A track unseen for a
while simply keeps growing its covariance by the motion model (we do not
"square the covariance when occluded": with variances below 1 m^2 that would
shrink it).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from functools import partial

import numpy as np
from scipy.optimize import linear_sum_assignment

from ..camera import Rig
from ..config import TrackSettings
from ..results import Object3D, TrackEstimate
from .flight import fit_parabola, in_free_flight
from .kernels import association_costs, kalman_correct, kalman_predict
from .motion import (
    FAST_FLIGHT,
    entering,
    fast_flight_model,
    flies_across,
    motion_model,
    moved_across_sight,
    robust_noise,
    within_max_speed,
)
from .sight import in_view, on_balls
from .smoothing import between_hits, hindsight_fills
from .start import EPS_TIME, INFEASIBLE, second_objects, start_moving
from .state import TrackState

FAST_CONFIRM_HITS = 3  # hits in a row that confirm a track moving at tracks.confirm_speed
# An object placed this sharply (one sigma, ball radii) is sharp: a first one at streaks (Object3D.swept) confirms its
# track, and one at rest may be a fast ball that stopped (``_caught``).
SWEPT_CONFIRM_RADII = 2.0
_FLIGHT_FIT_SIGMA = 0.02  # metres: objects vaguer than this per axis (depth-ambiguous: merged or hidden views) stay out of the flight fit
TRAVEL = 2.0  # a track is settled (its ball keeps its disc out of the background) once it has gone this many ball radii from where it was first shown ...
HAND_SPEED = 1.0  # m/s: how fast a caught ball may move with the hand that holds it (one sigma, per axis)
STOP_SPEED = 2.0  # m/s: a ball this fast at its latest hit may have stopped there (caught, at a wall): tried there too
# A ball caught at speed v may be thrown again as fast (a ballistic throw lands as fast as it left), a fast one may stop
# out of sight; its track's speed lags its ball's, so a new object up to this many times v dt away may be that ball.
LAUNCH_MARGIN = 1.5
# Seconds since its latest hit a lost track's ball is looked for at that pace: a launch or a stop blurs a frame or two
# away (motion_blur tune seed 19); lost longer, its reach holds other balls (fast_ball tune seed 6: one lost 0.6 s took
# a new ball 7 m off).
LAUNCH_TIME = 0.1
# A track seen fewer frames in a row than this before it was missed, coasting where a hit track's ball is in every view,
# is not reported: it was that ball's ghost along the rays (fast_ball tune seed 414: confirmed 1.4 m off along a streak's
# ray, it coasted beside the true track and was written for 9 frames). One seen steadily is a ball hidden behind
# another (hue_wall tune seed 135: two balls 0.2 m apart in depth).
SHADOW_RUN = FAST_CONFIRM_HITS
# A track seen this many frames in a row and missed this frame owns its ball's image: an unmatched object there in every
# view is that ball placed badly along the ray, and starts no track (fast_ball tune seed 456: a track seen once 11 frames
# before took such an object 0.45 m behind a sharp track, and then its ball; with 3, one confirmed on a wrong velocity
# held back its ball's new track for 5 frames, tune seed 419).
OWNER_RUN = 5
SETTLED_FRAMES = 8  # ... or been shown this many frames (a ghost under it is learnt by then: motion.ABSORB_FRAMES; 10 lost a pendulum at a turning point)

TENTATIVE, CONFIRMED, COASTING = "tentative", "confirmed", "coasting"


class TrackManager:
    """Keeps identities over time for every target's objects.

    >>> manager = TrackManager(config.tracks)
    >>> for frame in frames:
    ...     hints = manager.predicted(frame.time)       # where live tracks should be now
    ...     objects = ...                               # this frame's Object3Ds
    ...     tracks = manager.update(objects, frame.time)
    """

    def __init__(self, settings: TrackSettings | None = None, rig: Rig | None = None, radius: Mapping[str, float] | None = None):
        """``rig``: when given, a coasting track is reported only while its prediction is in every camera's view.
        ``radius``: each target's ball radius (metres), for ``TrackEstimate.settled``; without it a track settles by age only."""
        self.settings = settings or TrackSettings()
        self.rig = rig
        self._centres = None if rig is None else [cam.centre for cam in rig.cameras]
        self.radius = dict(radius or {})
        up = self.settings.up
        self.gravity = None if up is None else -self.settings.g * np.asarray(up, float) / np.linalg.norm(up)
        self._up = None if up is None else np.asarray(up, float) / np.linalg.norm(up)
        self._tracks: list[TrackState] = []
        self._next_id = 1
        self._time = self._before = None  # this update's time and the one before (None: none yet)
        self._models: dict[tuple[float, bool], tuple[np.ndarray, np.ndarray, np.ndarray]] = {}

    # ------------------------------------------------------------------ public

    def predicted(self, time: float) -> tuple[TrackEstimate, ...]:
        """Every live track predicted to ``time`` (seconds), without changing any state.

        Positions, velocities and position covariances come from the motion
        model alone (no measurement of this frame); ``state`` is the track's
        state after the previous update. Call it before ``update`` with the
        same time, e.g. to keep particles of one ball out of another ball.
        """
        states = [self._predict(tr, time)[:2] for tr in self._tracks]
        seen = in_view(self.rig, np.array([x[:3] for x, _ in states]).reshape(-1, 3))
        return tuple(self._estimate(tr, x, P, v, self._settled(tr, x[:3])) for tr, (x, P), v in zip(self._tracks, states, seen))

    def update(self, objects: Sequence[Object3D], time: float) -> tuple[TrackEstimate, ...]:
        """Take this frame's objects (seen at ``time`` seconds); return every live track after the update.

        Deleted tracks are gone from the result; ``state`` tells tentative,
        confirmed (seen this frame) and coasting (confirmed, unseen this frame).
        """
        s = self.settings
        self._before, self._time = self._time, time
        for tr in self._tracks:
            tr.x, tr.P, F = self._predict(tr, time)
            tr.link = (tr.x.copy(), tr.P.copy(), F)
            tr.time = time
            tr.streak = tr.streak if tr.hit else 0  # a frame missed ends the run of hits
            tr.hit = False
            tr.contested = tr.shadowed = False
            if tr.confirmed:  # the frames it was past tentative, counted as ``predicted`` showed them
                tr.settled = self._settled(tr, tr.x[:3])
                tr.first_shown = tr.x[:3].copy() if tr.first_shown is None else tr.first_shown
                tr.shown += 1
        self._forget_catches_of_seen_balls()
        by_target: dict[str, list[int]] = {}
        for i, obj in enumerate(objects):
            by_target.setdefault(obj.target, []).append(i)
        for target, idx in by_target.items():
            objs = [objects[i] for i in idx]
            z = np.array([o.position for o in objs], float).reshape(-1, 3)
            R = self._measurement_covs(objs)
            free = np.ones(len(objs), bool)
            # Confirmed (and coasting) tracks choose first, so a clutter track never steals a ball's object.
            for stage in (True, False):
                tracks = [t for t in self._tracks if t.target == target and t.confirmed == stage]
                cols = np.flatnonzero(free)
                if not tracks or not len(cols):
                    continue
                # An object may be a fast ball stopped where it was last seen only if it is at rest (not at streaks) and
                # placed to within a few ball radii (a far ball's depth is vaguer than its last frame's travel).
                still = self._sharp(target, R[cols]) & ~np.array([objs[j].swept for j in cols], bool)
                for ti, cj, caught in self._assign(tracks, z[cols], R[cols], time, still):
                    j = cols[cj]
                    if caught:
                        self._catch(tracks[ti], time)
                    self._correct(tracks[ti], z[j], R[j], objs[j], time)
                    free[j] = False
            # An unmatched object on the ball of a steady track missed this frame (OWNER_RUN) gives no young track its
            # second point and starts none: it is that ball, placed badly along the ray. A slow track may still be
            # restarted there (``_lost_ball``: it stopped or set off; motion_blur tune seed 7), a fast one not (fast_ball
            # tune seed 456: restarted 0.5 m off along the ray at 26 m/s, as if setting off from a noisy 51 m/s).
            owners = [t for t in self._tracks if t.target == target and t.confirmed and not t.hit and t.run >= OWNER_RUN]
            owned = np.zeros(len(objs), bool)
            owned[free] = self._on_balls(target, z[free], owners, time).any(axis=1)
            if s.max_speed > 0:
                self._two_point(target, z, R, objs, free, owned, time)
            # A missed track with an unmatched object of its colour nearby was lost by its motion model
            # (an abrupt catch): its prediction is not worth reporting.
            spare = z[free]
            for t in self._tracks:
                if t.target == target and not t.hit:
                    t.contested = bool(len(spare)) and np.min(np.linalg.norm(spare - t.x[:3], axis=1)) < 0.2
            # Unmatched objects start tentative tracks, unless they sit on a live track (one ball, two objects), are
            # a lost track's ball after a throw or a stop (``_lost_ball``), or are owned.
            live = np.array([t.x[:3] for t in self._tracks if t.target == target]).reshape(-1, 3)
            for j in np.flatnonzero(free):
                if len(live) and np.min(np.linalg.norm(live - z[j], axis=1)) < s.min_separation:
                    continue
                lost = self._lost_ball(target, z[j], R[j], time)
                if lost is not None and not (owned[j] and np.linalg.norm(lost[0].x[3:]) >= s.confirm_speed > 0):
                    self._restart(*lost, z[j], R[j], objs[j], time)
                elif owned[j]:
                    continue
                else:
                    self._tracks.append(self._new_track(target, z[j], R[j], objs[j], time, self._lost_near(target, z[j], time)))
                live = np.vstack([live, z[j]])
            self._shadowed(target, time)
        self._tracks = [t for t in self._tracks if not self._expired(t, time)]
        for t in self._tracks:
            # Where its ball was seen, not where the motion model carried it unseen: a still thing's track coasts on a
            # velocity its noisy depths gave it (fast_ball tune seed 47: a poster's patch 20 m away, seen one frame in
            # five, drifted so, and as a ball that moved was never judged scenery again).
            if t.confirmed and t.hit:
                t.travelled = t.travelled or self._travelled(t, t.x[:3])
        for t in self._tracks:
            if not t.confirmed and (t.hit or t.early):  # a frame missed between hits too, placed at confirmation (between_hits)
                t.early.append((time, t.x[:3].copy() if t.hit else None, t.P[:3, :3].copy(), t.n_particles))
        seen = in_view(self.rig, np.array([t.x[:3] for t in self._tracks]).reshape(-1, 3))
        smoothed = hindsight_fills([self._smoothed(t, time) for t in self._tracks], [t.target for t in self._tracks], self.radius)
        estimates = tuple(
            self._estimate(t, t.x, t.P, v, t.settled, self._entered(t) + between_hits(t.early) if t.confirmed else (), sm)
            for t, v, sm in zip(self._tracks, seen, smoothed)
        )
        for t in self._tracks:
            if t.confirmed and t.early:
                t.early = []  # given once, the frame it was confirmed
        return estimates

    def reset(self) -> None:
        """Forget every track (ids keep counting up: they stay unique within the run)."""
        self._tracks = []

    def __len__(self) -> int:
        return len(self._tracks)

    # ------------------------------------------------------------------ steps

    def _predict(self, tr: TrackState, time: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The track's state and covariance predicted to ``time``, and the transition F that took it there."""
        dt = max(0.0, time - tr.time)
        if dt == 0.0:
            return tr.x.copy(), tr.P.copy(), np.eye(6)
        if tr.prediction is not None and tr.prediction[:3] == (time, tr.time, tr.in_flight):
            return tr.prediction[3].copy(), tr.prediction[4].copy(), tr.prediction[5]
        if self._fast(tr):
            F, Q, b = fast_flight_model(dt, tr.x[3:], self.settings.fast_accel_noise, self.gravity, self.settings.drag)
        else:
            F, Q, b = self._motion_model(dt, tr.in_flight)
        x, P = kalman_predict(tr.x, tr.P, F, Q, b)
        tr.prediction = (time, tr.time, tr.in_flight, x, P, F)
        return x.copy(), P.copy(), F

    def _fast(self, tr: TrackState) -> bool:
        """Thrown (motion.FAST_FLIGHT): it flies under gravity and drag, and its objects are weighed robustly."""
        return self.gravity is not None and tr.confirmed and np.linalg.norm(tr.x[3:]) >= FAST_FLIGHT

    def _motion_model(self, dt: float, in_flight: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``motion_model`` for this manager, remembered per (dt, in flight): every track of a frame shares dt."""
        key = (dt, in_flight)
        if key not in self._models:
            self._models = self._models if len(self._models) <= 16 else {}
            self._models[key] = motion_model(dt, self.settings.accel_noise, self.gravity if in_flight else None)
        return self._models[key]

    def _measurement_covs(self, objs: Sequence[Object3D]) -> np.ndarray:
        """Per object (M x 3 x 3): the measurement noise plus the object's own covariance (symmetrised;
        a missing or non-finite one counts zero)."""
        zero = np.zeros((3, 3))
        covs = np.array([zero if o.covariance is None or np.shape(o.covariance) != (3, 3) else o.covariance for o in objs], float).reshape(
            -1, 3, 3
        )
        covs[~np.isfinite(covs).all(axis=(1, 2))] = zero
        R = np.eye(3) * self.settings.measurement_sigma**2 + 0.5 * (covs + covs.transpose(0, 2, 1))
        if self.settings.measurement_sigma <= 0:  # zero noise everywhere: keep the filter invertible
            R[np.linalg.det(R) <= 0] += np.eye(3) * 1e-8
        return R

    def _assign(
        self, tracks: list[TrackState], z: np.ndarray, R: np.ndarray, time: float, still: np.ndarray
    ) -> list[tuple[int, int, bool]]:
        """Gated global assignment: (track index, object index, caught) with squared Mahalanobis distance <= gate.
        A flying ball missed since its latest hit may have been caught: it is then near where it was last seen, not
        down its parabola. Each such track is also tried there (``_caught``); ``caught`` says that hypothesis won."""
        pos = np.array([t.x[:3] for t in tracks])  # T x 3
        Pp = np.array([t.P[:3, :3] for t in tracks])  # T x 3 x 3
        z, R = np.ascontiguousarray(z, dtype=float), np.ascontiguousarray(R, dtype=float)
        # Negative log-likelihood: among gated pairs, a sharp track beats a vague (long-coasting) one.
        d2, cost = association_costs(pos, Pp, z, R)
        gated = (d2 <= self.settings.gate) & self._within_max_speed(tracks, z, R, d2)
        caught = np.zeros(d2.shape, bool)
        held = [(i, self._caught(t, time)) for i, t in enumerate(tracks)]
        held = [(i, h) for i, h in held if h is not None]
        if held:
            rows = np.array([i for i, _ in held])
            d2h, costh = association_costs(np.array([h[0] for _, h in held]), np.array([h[1] for _, h in held]), z, R)
            # A flying ball missed since its latest hit: the likelier place wins. A fast ball not in flight is tried where it
            # was only for objects its prediction does not gate (an abrupt stop), not where it is merely nearer, and only
            # for ``still`` objects.
            flying = np.array([tracks[i].in_flight for i in rows])[:, None]
            better = (d2h <= self.settings.gate) & (~gated[rows] | (flying & (costh < cost[rows]))) & (flying | still[None, :])
            cost[rows] = np.where(better, costh, cost[rows])
            gated[rows] |= better
            caught[rows] = better
        rows, cols = linear_sum_assignment(np.where(gated, cost, INFEASIBLE))
        return [(int(r), int(c), bool(caught[r, c])) for r, c in zip(rows, cols) if gated[r, c]]

    def _within_max_speed(self, tracks: list[TrackState], z: np.ndarray, R: np.ndarray, d2: np.ndarray) -> np.ndarray:
        """``motion.within_max_speed`` per track and object (T x M); a track seen once has no velocity to correct yet
        (``start.start_moving`` caps its start)."""
        ok = np.ones(d2.shape, bool)
        rows = [i for i, t in enumerate(tracks) if t.hits >= 2]
        if self.settings.max_speed > 0 and rows and len(z):
            x, P = np.array([tracks[i].x for i in rows]), np.array([tracks[i].P for i in rows])
            fast = np.array([self._fast(tracks[i]) for i in rows])
            ok[rows] = within_max_speed(x, P, fast, z, R, d2[rows], self.settings.max_speed)
        return ok

    def _caught(self, tr: TrackState, time: float) -> tuple[np.ndarray, np.ndarray] | None:
        """Where a ball would be had it stopped at its latest hit (a hand caught it, a wall stopped it): (position,
        covariance) around that hit, growing as a hand may carry it (HAND_SPEED). Asked of a flying ball missed since
        then, and of a fast ball not in flight (STOP_SPEED) the frame after; None otherwise."""
        # streak: 0 once a frame was missed (``update``). A flying ball seen last frame is where its parabola says; one
        # stopped where it was last seen (a fast ball not in flight) shows there the very next frame.
        if tr.caught_at is None or (tr.in_flight and tr.streak > 0) or (not tr.in_flight and tr.streak == 0):
            return None
        dt = time - tr.last_hit
        position, P = tr.caught_at
        return position, P + np.eye(3) * (HAND_SPEED * dt) ** 2

    def _forget_catches_of_seen_balls(self) -> None:
        """A lost track whose catch point is within a ball's width of where a track of its colour was seen last frame
        was that ball seen twice (a duplicate track), not a ball caught out of sight: it keeps no catch hypothesis."""
        seen = [t for t in self._tracks if t.streak > 0 and t.seen_at is not None]
        for tr in self._tracks:
            if tr.caught_at is None or tr.streak > 0:
                continue
            near = max(self.settings.min_separation, 2.0 * self.radius.get(tr.target, 0.0))
            if any(t.target == tr.target and np.linalg.norm(t.seen_at - tr.caught_at[0]) < near for t in seen):
                tr.caught_at = None

    def _catch(self, tr: TrackState, time: float) -> None:
        """The ball was caught at its latest hit: it stops flying and starts again from there, at rest in a hand."""
        position, P = self._caught(tr, time)
        tr.arrival = max(float(np.linalg.norm(tr.x[3:])), tr.top_speed)  # the filter's speed lags a fast ball's
        tr.top_speed = 0.0
        tr.x = np.r_[position, 0.0, 0.0, 0.0]
        tr.P = np.zeros((6, 6))
        tr.P[:3, :3] = P
        tr.P[3:, 3:] = np.eye(3) * HAND_SPEED**2
        tr.in_flight = False
        tr.parabola = None
        tr.history = []
        tr.caught_at = None
        tr.link = None  # set anew: the smoother starts over here

    def _pace(self, tr: TrackState, sharp: bool) -> float | None:
        """How fast the ball of a confirmed track not in flight may have gone since its latest hit where its motion model
        does not follow it, to be this object (``sharp``: ``_sharp``): one at rest since a catch or a stop, or slower
        than it came, may have been thrown again as fast as it came (its ``arrival``; a launch blurs: any object); a
        fast one (STOP_SPEED) missed since the frame before may have stopped out of sight (a ball at rest is sharp; one
        seen then is tried where it was, ``_caught``). None for any other."""
        if not tr.confirmed or tr.in_flight:
            return None
        speed = float(np.linalg.norm(tr.x[3:]))
        # At rest, or setting off again: the filter lags the launch (motion_blur tune seed 22: 3.6 m/s after the first
        # frame of a launch to 7.4, 0.3 m from where it was seen; 0.256 -> 0.911).
        if speed < max(STOP_SPEED, tr.arrival or 0.0):
            return tr.arrival
        return speed if tr.streak == 0 and sharp else None

    def _lost_ball(self, target: str, z: np.ndarray, R: np.ndarray, time: float) -> tuple[TrackState, float] | None:
        """The track, missed this frame, whose ball this unmatched object may be, and its pace: the nearest within
        LAUNCH_MARGIN times its ``_pace`` since its latest hit of where it was then, lost for LAUNCH_TIME at most; None if
        none. A launch from rest (or a stop the frame after a miss) leaves the prediction behind: without this each throw
        started a new track, and the one left at rest took the ball on its next pass (motion_blur tune seed 19: 38 id
        switches)."""
        sharp = bool(self._sharp(target, R))
        lost = [t for t in self._tracks if t.target == target and not t.hit and time - t.last_hit <= LAUNCH_TIME + EPS_TIME]
        lost = [(t, self._pace(t, sharp)) for t in lost if t.seen_at is not None]
        lost = [(t, p) for t, p in lost if p is not None]
        if not lost:
            return None
        dist = np.array([np.linalg.norm(z - t.seen_at) for t, _ in lost])
        reach = np.array([LAUNCH_MARGIN * p * max(time - t.last_hit, EPS_TIME) for t, p in lost])
        k = int(np.argmin(np.where(dist <= reach, dist, np.inf)))
        return lost[k] if dist[k] <= reach[k] else None

    def _restart(self, tr: TrackState, pace: float, z: np.ndarray, R: np.ndarray, obj: Object3D, time: float) -> None:
        """Its ball found again (``_lost_ball``): the track starts over at ``z`` as a new one would (seen once, velocity
        unknown: ``_two_point`` gives it one next frame), keeping its id, its confirmation and its pace."""
        tr.arrival = pace
        tr.x, tr.P = self._first_state(z, R)
        tr.last_hit, tr.streak, tr.run, tr.hits, tr.hit, tr.n_particles = time, 1, 1, 1, True, int(obj.n_particles)
        tr.history, tr.parabola, tr.prediction, tr.caught_at, tr.top_speed = [], None, None, None, 0.0
        tr.seen_at = z.copy()
        tr.link = None

    def _correct(self, tr: TrackState, z: np.ndarray, R: np.ndarray, obj: Object3D, time: float) -> None:
        z, dt = np.ascontiguousarray(z, dtype=float), time - tr.last_hit
        # Its second object in its gate, gone across the view as only a flying ball goes: it starts at the two objects'
        # velocity (``_start_moving``), not from rest held back by init_speed_sigma (motion.flies_across).
        if tr.hits == 1 and self._centres and flies_across(tr.x[:3], z, dt, self._centres):
            self._start_moving(tr, tr.x[:3].copy(), z, R, dt)
        else:
            tr.x, tr.P = kalman_correct(tr.x, tr.P, z, robust_noise(tr.x[:3], tr.P[:3, :3], z, R) if self._fast(tr) else R)
        self._hit(tr, z, R, obj, time)

    def _two_point(
        self, target: str, z: np.ndarray, R: np.ndarray, objs: Sequence[Object3D], free: np.ndarray, owned: np.ndarray, time: float
    ) -> None:
        """Two-point start of fast balls (``start.second_objects``): a track seen once whose second object fell outside its
        gate takes the nearest free object within ``max_speed`` of it (not one ``owned`` by a steady track's ball)."""
        young = [t for t in self._tracks if t.target == target and not t.hit and t.hits == 1]
        for tr, j, first, dt in second_objects(young, z, np.flatnonzero(free & ~owned), time, self.settings.max_speed):
            self._start_moving(tr, first, z[j], R[j], dt)
            self._hit(tr, z[j], R[j], objs[j], time)
            free[j] = False

    def _start_moving(self, tr: TrackState, first: np.ndarray, z: np.ndarray, R: np.ndarray, dt: float) -> None:
        """``start.start_moving`` with this manager's motion model over ``dt``."""
        start_moving(tr, first, z, R, dt, self._motion_model(dt, False), self.settings.max_speed)

    def _hit(self, tr: TrackState, z: np.ndarray, R: np.ndarray, obj: Object3D, time: float) -> None:
        """A track met an object: its lifecycle moves on."""
        tr.hits += 1
        tr.streak += 1
        tr.run = tr.streak
        tr.hit = True
        tr.last_hit = time
        self._follow_flight(tr, z, R, time)
        tr.n_particles = int(obj.n_particles)
        tr.seen_at = tr.x[:3].copy()
        speed = float(np.linalg.norm(tr.x[3:]))
        fast = speed >= STOP_SPEED
        # A ball stopped dead (a swing's or a slide's end) seen vaguely is no catch: the filter slows down over a few hits,
        # and the speed it may be launched at again is the top speed it came at, not the last (motion_blur tune seed 7:
        # 0.800 -> 0.963, each launch had started a new track).
        if not fast and tr.top_speed > 0.0:
            tr.arrival = tr.top_speed
        tr.top_speed = max(tr.top_speed, speed) if fast else 0.0
        tr.caught_at = (tr.seen_at, tr.P[:3, :3].copy()) if tr.in_flight or fast else None
        if not tr.confirmed and time - tr.born >= self.settings.confirm_time - EPS_TIME:
            tr.confirmed = True
        # Three hits in a row that a fast constant-velocity motion explains: the second gave the velocity, the third
        # fell in a gate a few centimetres wide around where it predicted. Clutter does not fly; a thrown ball crosses
        # the view in a few frames, too few to wait confirm_time for.
        fast = self.settings.confirm_speed > 0 and np.linalg.norm(tr.x[3:]) >= self.settings.confirm_speed
        if not tr.confirmed and tr.streak >= FAST_CONFIRM_HITS and fast:
            tr.confirmed = True

    def _follow_flight(self, tr: TrackState, z: np.ndarray, R: np.ndarray, time: float) -> None:
        """Gravity only for a ball in free flight: a pendulum, a held or a rolling ball is not falling."""
        if self.gravity is None:
            return
        if np.trace(R) < 3 * _FLIGHT_FIT_SIGMA**2:
            tr.history.append((time, np.array(z, float)))
        tr.history = [(t, p) for t, p in tr.history if time - t <= self.settings.flight_window + EPS_TIME]
        times = np.array([t for t, _ in tr.history])
        positions = np.array([p for _, p in tr.history]).reshape(-1, 3)
        if len(times) >= 5 and times[-1] - times[0] >= 0.4 * self.settings.flight_window:
            flying = in_free_flight(times, positions, self.gravity)
            if flying and not tr.in_flight:
                tr.launch = float(np.min(positions @ self._up))
            tr.in_flight = flying
        enough = len(times) >= 3 and times[-1] - times[0] > EPS_TIME
        tr.parabola = fit_parabola(times, positions, self.gravity) if tr.in_flight and enough else None

    def _lost_near(self, target: str, z: np.ndarray, time: float) -> bool:
        """Is a confirmed track of this target, missed this frame and predicted in view, within ``max_speed`` of ``z``
        since its latest hit? Then a new object there may be its ball again (a juggled ball lost at a catch)."""
        lost = [t for t in self._tracks if t.target == target and t.confirmed and not t.hit]
        if not lost:
            return False
        pos = np.array([t.x[:3] for t in lost])
        reach = np.array([self.settings.max_speed * max(time - t.last_hit, EPS_TIME) for t in lost])
        return bool((in_view(self.rig, pos) & (np.linalg.norm(pos - z, axis=1) <= reach)).any())

    def _first_state(self, z: np.ndarray, R: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(x, P) of a ball seen once, at ``z`` with noise ``R``: at rest, give or take init_speed_sigma."""
        P = np.zeros((6, 6))
        P[:3, :3] = R
        P[3:, 3:] = np.eye(3) * self.settings.init_speed_sigma**2
        return np.r_[z, 0.0, 0.0, 0.0], P

    def _new_track(self, target: str, z: np.ndarray, R: np.ndarray, obj: Object3D, time: float, rival: bool = False) -> TrackState:
        x, P = self._first_state(z, R)
        tr = TrackState(self._next_id, target, x, P, time, time, time, n_particles=int(obj.n_particles))
        # A fast ball's streaks in two cameras that triangulate where its particles are, to within two ball radii:
        # clutter leaves no streaks, and a thrown ball is seen for a few frames only (waiting for three hits lost the
        # first two of every throw). A far one's depth is vaguer: reported there, it would be a miss and a false track.
        # A ``rival`` (``_lost_near``) may be the same ball: its track gets the hits to win it back first.
        fast = self.settings.confirm_speed > 0 and obj.swept and bool(self._sharp(target, R)) and not rival
        tr.confirmed = self.settings.confirm_time <= EPS_TIME or fast
        tr.entry = None if self._before is None or self.rig is None else (self._before, (time, z.copy(), R.copy(), tr.n_particles))
        self._next_id += 1
        return tr

    def _entered(self, tr: TrackState) -> list:
        """``motion.entering``, once a confirmed track has FAST_CONFIRM_HITS hits (a velocity to go back by)."""
        if tr.entry is None or not tr.confirmed or tr.hits < FAST_CONFIRM_HITS:
            return []
        entry, tr.entry = tr.entry, None
        return entering(entry, tr.x, tr.P, self.settings.confirm_speed, partial(in_view, self.rig))

    def _sharp(self, target: str, R: np.ndarray) -> np.ndarray:
        """Per measurement covariance (... x 3 x 3): placed to within SWEPT_CONFIRM_RADII ball radii (one sigma, its
        vaguest axis). Never without the target's radius."""
        sigma = np.sqrt(np.maximum(np.linalg.eigvalsh(R)[..., -1], 0.0))
        return sigma <= SWEPT_CONFIRM_RADII * self.radius.get(target, 0.0)

    def _settled(self, tr: TrackState, position: np.ndarray) -> bool:
        """Has this track, at ``position`` this frame, gone TRAVEL ball radii from where it was first past tentative,
        or been past tentative SETTLED_FRAMES frames (this one included)? Then its ball may keep the background from
        learning its disc (evidence/motion.py). A new track that has not moved may sit on a ghost (a ball that was
        there when the background started, then left): kept out of the update, the ghost would last for ever."""
        if tr.settled:
            return True
        if not tr.confirmed:
            return False
        start = position if tr.first_shown is None else tr.first_shown
        radius = self.radius.get(tr.target, np.inf)
        return tr.shown + 1 >= SETTLED_FRAMES or bool(np.linalg.norm(position - start) > TRAVEL * radius)

    def _travelled(self, tr: TrackState, position: np.ndarray) -> bool:
        """Has this track, at ``position``, gone TRAVEL ball radii from where it was first past tentative, across some
        camera's line of sight (with a rig; else in any direction)? Scenery does not move: its ball is a thing that moves
        (``TrackEstimate.travelled``). Across the line of sight, as a camera sees it move: a far still thing's depth is
        vague along its rays and strays farther than that (hue_wall tune seed 18: a book's end 2.8 m off every ball).
        Never without the target's radius."""
        start = position if tr.first_shown is None else tr.first_shown
        return moved_across_sight(start, position, TRAVEL * self.radius.get(tr.target, np.inf), self._centres)

    def _smoothed(self, tr: TrackState, time: float) -> tuple:
        """Keep this frame's state; give each frame smooth_time old by now smoothed with the later ones (FilterHistory.
        revise_until); none with smooth_time 0. A filter's estimate at a frame knows only the frames before it: a far
        ball's depth, a pixel of disparity off in one frame, pulls the track off for several. The smoother's knows the frames
        after too (fast_ball tune seeds 0-59, smoothed over 0.15 s: median MOTA 0.862 -> 0.926, mean 0.708 -> 0.789). A
        tentative track's miss is no estimate to revise (between_hits places it)."""
        window = self.settings.smooth_time
        if window <= 0:
            return ()
        tr.past.append(time, tr.x, tr.P, tr.link, (tr.confirmed or tr.hit) and not self._caught_below_launch(tr, tr.x), tr.hit)
        return tr.past.revise_until(time - window + EPS_TIME, tr.confirmed)

    def _caught_below_launch(self, tr: TrackState, x: np.ndarray) -> bool:
        """Is this track, missed at state ``x``, a flying ball lost on its way down past the height it was thrown from?
        Then it was most likely caught there, and is reported where it was last seen (``_estimate``)."""
        return bool(not tr.hit and tr.in_flight and tr.caught_at is not None and tr.launch is not None and x[:3] @ self._up < tr.launch)

    def _expired(self, tr: TrackState, time: float) -> bool:
        return time - tr.last_hit > (self.settings.delete_time if tr.confirmed else self.settings.tentative_time) + EPS_TIME

    def _shadowed(self, target: str, time: float) -> None:
        """Mark each of ``target``'s confirmed tracks missed this frame, seen fewer than SHADOW_RUN frames in a row
        before, whose prediction lies on a hit track's ball in every view (``sight.on_balls``): the hit track has that ball."""
        missed = [t for t in self._tracks if t.target == target and t.confirmed and not t.hit and t.run < SHADOW_RUN]
        hit = [t for t in self._tracks if t.target == target and t.hit]
        on = self._on_balls(target, np.array([t.x[:3] for t in missed]).reshape(-1, 3), hit, time)
        for t, shadowed in zip(missed, on.any(axis=1)):
            t.shadowed = bool(shadowed)

    def _on_balls(self, target: str, points: np.ndarray, tracks: list[TrackState], time: float) -> np.ndarray:
        """``sight.on_balls`` for ``target``'s ``tracks`` at this update's ``time``."""
        dt = 0.0 if self._before is None else time - self._before
        motion = np.array([t.x for t in tracks]).reshape(-1, 6)
        return on_balls(self.rig, self.radius.get(target, 0.0), points, motion[:, :3], motion[:, 3:], dt)

    def _estimate(
        self, tr: TrackState, x: np.ndarray, P: np.ndarray, in_view: bool, settled: bool, before: list = (), smoothed: tuple = ()
    ) -> TrackEstimate:
        state = TENTATIVE if not tr.confirmed else (CONFIRMED if tr.hit else COASTING)
        # A confirmed ball missed for a frame or two (merged with another, a blink of occlusion) is
        # still reported, at its predicted position, for at most report_coasting seconds.
        # A track seen once has no velocity to coast by (one confirmed by its first streak, ``_new_track``).
        recent = tr.time - tr.last_hit <= self.settings.report_coasting + EPS_TIME
        coasting_ok = recent and in_view and tr.hits > 1 and not (tr.contested or tr.shadowed)
        reported = tr.confirmed and (tr.hit or coasting_ok)
        if self._caught_below_launch(tr, x):
            x = np.r_[tr.caught_at[0], 0.0, 0.0, 0.0]
        return TrackEstimate(
            track_id=tr.track_id,
            target=tr.target,
            position=x[:3].copy(),
            velocity=x[3:].copy(),
            covariance=P[:3, :3].copy(),
            state=state,
            n_particles=tr.n_particles,
            reported=bool(reported),
            flight=tr.parabola,
            settled=settled,
            travelled=tr.travelled,
            before=tuple(before),
            smoothed=smoothed,
        )
