"""A track's recent Kalman filter states, kept for smoothing them in hindsight (tracks.smooth_time).

The tracks.csv sink holds each frame's rows a moment before it writes them
(sinks/tracks_csv.py); meanwhile the frames after it are tracked, and a
Rauch-Tung-Striebel smoother (kernels.rts_oldest) can use them to revise the
state at that frame. This is the history it reads: per frame, the filtered
state, the prediction into it from the frame before, whether the track
reported it and whether it met an object. Arrays that grow as needed and
shift by one as the oldest leaves, so the smoother reads them as they are,
once per track and frame.
"""

from __future__ import annotations

import numpy as np

from .kernels import rts_oldest


def between_hits(frames: list) -> list:
    """A tentative track's frames, each (time, position, 3 x 3 covariance, n_particles), with those it was missed in
    (position None) placed on the line between the hits around them, as vague as the vaguer hit. Its filter state
    there is no estimate: the velocity of a track seen once is its prior's (zero), and a ball then stayed where it was
    first seen for the frames to its second hit (fast_ball tune seed 24: three rows 0.4-0.8 m behind the ball).
    Misses after its last hit are left out."""
    hits = [f for f in frames if f[1] is not None]
    times = np.array([f[0] for f in hits])
    out = []
    for time, position, covariance, n in frames:
        k = int(np.searchsorted(times, time))
        if position is None and 0 < k < len(hits):
            (ta, a, ca, _), (tb, b, cb, _) = hits[k - 1], hits[k]
            w = (time - ta) / (tb - ta)
            position, covariance = (1.0 - w) * a + w * b, (ca if np.trace(ca) > np.trace(cb) else cb).copy()
        if position is not None:
            out.append((time, position, covariance, n))
    return out


# A frame a confirmed track coasted through unreported (contested, out of view, or past report_coasting) and whose ball
# it met again since is written in hindsight at its smoothed state, where that is sharp: its vaguest axis within
# FILL_RADII ball radii (one sigma). A longer or more abrupt gap (a catch, a ball lost behind a hand) leaves it vaguer,
# and a false track's (an empty hand, a patch of a poster) more so. Nor where another track of its colour held a ball
# within FILL_APART radii at that frame: one ball, two tracks (hands tune seeds 0-159: such rows 187 on a ball alone,
# 45 within 0.1-0.3 m of one, 37 on none, 58 on a ball another track held; sharp and apart: 104, 17, 8 and 5).
FILL_RADII = 2.0
FILL_APART = 3.0


def hindsight_fills(revised: list[tuple], targets: list[str], radius: dict[str, float]) -> list[tuple]:
    """Per track (``targets``: its target's name), its revisions (FilterHistory.revise_until: each (time, position,
    covariance, gap)), the last field now whether the frame is to be written where the track reported nothing
    (TrackEstimate.smoothed). Never without the target's ball radius."""
    if not any(gap for revisions in revised for *_, gap in revisions):  # most frames: nothing to fill
        return revised
    held: dict[tuple[str, float], list[tuple[int, np.ndarray]]] = {}  # (target, time) -> (track, position) of each revision
    for i, (revisions, target) in enumerate(zip(revised, targets)):
        for time, position, *_ in revisions:
            held.setdefault((target, time), []).append((i, position))
    out = []
    for i, (revisions, target) in enumerate(zip(revised, targets)):
        r = radius.get(target, 0.0)
        mine = []
        for time, position, covariance, gap in revisions:
            sharp = gap and np.sqrt(max(np.linalg.eigvalsh(covariance)[-1], 0.0)) <= FILL_RADII * r
            alone = sharp and all(j == i or np.linalg.norm(p - position) >= FILL_APART * r for j, p in held[(target, time)])
            mine.append((time, position, covariance, bool(alone)))
        out.append(tuple(mine))
    return out


class FilterHistory:
    """One track's filter states over its last frames, oldest first."""

    FIELDS = ("times", "x", "P", "xp", "Pp", "F", "linked", "kept", "hit")  # its arrays, one row per frame

    def __init__(self, capacity: int = 16):
        self.n = 0
        self.times = np.empty(capacity)
        self.x = np.empty((capacity, 6))  # the filtered states ...
        self.P = np.empty((capacity, 6, 6))
        self.xp = np.empty((capacity, 6))  # ... the predictions into them from the frame before ...
        self.Pp = np.empty((capacity, 6, 6))
        self.F = np.empty((capacity, 6, 6))  # ... with the transition that made them
        self.linked = np.zeros(capacity, bool)  # False where the state was set anew (a catch, a restart): no prediction
        self.kept = np.zeros(capacity, bool)  # its state that frame is what the track reported (not where a hand caught it)
        self.hit = np.zeros(capacity, bool)  # it met an object that frame

    def __len__(self) -> int:
        return self.n

    def append(self, time: float, x: np.ndarray, P: np.ndarray, link: tuple | None, kept: bool, hit: bool) -> None:
        """A frame's state (``link``: the prediction into it, (x, P, F), or None where it was set anew; ``kept``: the
        track reported it; ``hit``: it met an object)."""
        if self.n == len(self.times):
            self._grow()
        k = self.n
        self.times[k], self.x[k], self.P[k], self.kept[k], self.hit[k] = time, x, P, kept, hit
        self.linked[k] = link is not None
        if link is not None:
            self.xp[k], self.Pp[k], self.F[k] = link
        self.n += 1

    def restate_newest(self, position_cov: np.ndarray, speed: float) -> tuple[np.ndarray, np.ndarray]:
        """The newest frame's state set anew (a start learning its velocity only now): its position kept, as uncertain
        as ``position_cov`` (3 x 3), its velocity unknown up to ``speed`` (m/s) per axis. Returns copies of (x, P)."""
        k = self.n - 1
        self.x[k, 3:] = 0.0
        self.P[k] = 0.0
        self.P[k, :3, :3], self.P[k, 3:, 3:] = position_cov, np.eye(3) * speed**2
        return self.x[k].copy(), self.P[k].copy()

    def oldest(self) -> tuple[float, bool]:
        """The oldest frame's time, and whether the track reported its state then."""
        return float(self.times[0]), bool(self.kept[0])

    def smoothed_oldest(self) -> tuple[np.ndarray, np.ndarray]:
        """The oldest frame's state (6) and covariance (6 x 6) smoothed with every later one (kernels.rts_oldest)."""
        n = self.n
        return rts_oldest(self.x[:n], self.P[:n], self.xp[:n], self.Pp[:n], self.F[:n], self.linked[:n])

    def revise_until(self, cutoff: float, confirmed: bool) -> tuple:
        """Every frame at or before ``cutoff`` (seconds), oldest first, dropped from the history, and of those the
        track reported (``kept``) smoothed with every later frame, as (time, position, 3 x 3 covariance, gap: the
        track met no object there but has since); none while the track is not ``confirmed`` (its tentative frames are
        smoothed the same once it is, while that recent)."""
        revised = []
        # Every frame that old now, not one a frame: after a slower frame (a live frame skipped, a gap) several are, and
        # one a frame would leave the rest ever later, past the tracks.csv hold.
        while self.n and self.times[0] <= cutoff:
            # A frame it was missed and reported where a hand caught it keeps that (hands tune seed 6: smoothed on down
            # the parabola, 0.17 m off); one it coasted through on its path is smoothed between the frames it was seen in
            # (fast_ball tune seeds 0-59: median 0.919 without, 0.936 with).
            if confirmed and self.n >= 2 and self.kept[0]:
                xs, Ps = self.smoothed_oldest()
                gap = not self.hit[0] and self.hit[1 : self.n].any()  # missed there, its ball met since
                revised.append((float(self.times[0]), xs[:3].copy(), Ps[:3, :3].copy(), bool(gap)))
            self.drop_oldest()
        return tuple(revised)

    def drop_oldest(self) -> None:
        n = self.n
        for name in self.FIELDS:
            a = getattr(self, name)
            a[: n - 1] = a[1:n]
        self.n -= 1

    def _grow(self) -> None:
        for name in self.FIELDS:
            a = getattr(self, name)
            bigger = np.zeros((2 * len(a), *a.shape[1:]), a.dtype)
            bigger[: len(a)] = a
            setattr(self, name, bigger)
