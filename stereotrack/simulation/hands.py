"""A juggler's hands: a throw-and-catch pattern, the balls' paths in it, and hands and arms that carry them.

``JugglePattern`` is the timing of a two-handed pattern (throws alternate
hands every ``beat`` seconds; a ball thrown at throw k is thrown again at
throw k + balls, so odd ball counts cross between hands (cascade) and even
ones stay on their side (fountain)). A ball flies on an exact ballistic arc
from a hand's throw point to a catch point, then is carried in the hand on
a smooth curve to the next throw point. ``Juggled`` is one ball's
trajectory in the pattern; ``Hand`` is a mover: at any time, the
ellipsoids of a hand gripping (or about to grip) the ball from below, with
fingers curled round its lower front, and the forearm and upper arm up to
the shoulder.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .shapes import Ellipsoid, Material, frame_from_axis
from .trajectories import G


def _hermite(p0, m0, p1, m1, s):
    s = s[:, None]
    h00 = 2 * s**3 - 3 * s**2 + 1
    h10 = s**3 - 2 * s**2 + s
    h01 = -2 * s**3 + 3 * s**2
    h11 = s**3 - s**2
    return h00 * p0 + h10 * m0 + h01 * p1 + h11 * m1


@dataclass(frozen=True)
class JugglePattern:
    catch: tuple[tuple[float, float, float], tuple[float, float, float]]  # where the left and right hands catch
    throw: tuple[tuple[float, float, float], tuple[float, float, float]]  # where they throw from
    balls: int = 3
    beat: float = 0.28  # seconds between throws (alternating hands)
    dwell: float = 0.3  # seconds a ball spends in a hand; < 2 beats
    phase: float = 0.0  # seconds of the pattern already played at t = 0
    carry: float = 0.35  # share of the ball's velocity kept through a catch or a throw (shapes the scoop)

    @property
    def flight(self) -> float:
        return self.balls * self.beat - self.dwell

    def _pts(self, which, hands):
        return np.asarray(which, float)[np.asarray(hands) % 2]

    def _velocity(self, k):
        """Launch and landing velocity of throw k (arrays over k)."""
        a = self._pts(self.throw, k)
        b = self._pts(self.catch, k + self.balls)
        f = self.flight
        v = (b - a) / f
        up = np.array([0.0, 0.0, 0.5 * G * f])
        return v + up, v - up

    def ball(self, index: int, t: np.ndarray) -> np.ndarray:
        """T x 3 positions of ball ``index`` (0 .. balls - 1)."""
        b, beat, f = self.balls, self.beat, self.flight
        s = np.asarray(t, float) + self.phase - index * beat
        n = np.floor(s / (b * beat))
        tau = s - n * b * beat
        k = (index + n * b).astype(int)
        out = np.empty((len(s), 3))
        fly = tau < f
        if fly.any():
            a = self._pts(self.throw, k[fly])
            c = self._pts(self.catch, k[fly] + b)
            tt = tau[fly][:, None]
            out[fly] = a + (c - a) * tt / f
            out[fly, 2] += 0.5 * G * tau[fly] * (f - tau[fly])
        hold = ~fly
        if hold.any():
            kk = k[hold]
            _, v_in = self._velocity(kk)
            v_out, _ = self._velocity(kk + b)
            c = self._pts(self.catch, kk + b)
            a = self._pts(self.throw, kk + b)
            d = self.dwell
            out[hold] = _hermite(c, self.carry * d * v_in, a, self.carry * d * v_out, (tau[hold] - f) / d)
        return out

    def hand(self, side: int, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Where hand ``side`` (0 left, 1 right) holds its ball-sized grip (T x 3), and whether it holds one (T)."""
        beat, d = self.beat, self.dwell
        s = np.asarray(t, float) + self.phase - side * beat  # hand ``side`` throws at s = 0, 2 beat, 4 beat, ...
        n = np.floor(s / (2 * beat))
        tau = s - n * 2 * beat  # 0 = a throw; the next catch is at 2 beat - dwell
        k = (side + 2 * n).astype(int)  # this hand's last throw
        empty_time = 2 * beat - d
        holding = tau >= empty_time
        out = np.empty((len(s), 3))
        if (~holding).any():
            kk = k[~holding]
            v_out, _ = self._velocity(kk)
            _, v_in = self._velocity(kk + 2 - self.balls)  # the ball this hand catches next was thrown at throw k + 2 - balls
            a = self._pts(self.throw, kk)
            c = self._pts(self.catch, kk)
            out[~holding] = _hermite(a, self.carry * empty_time * v_out, c, self.carry * empty_time * v_in, tau[~holding] / empty_time)
        if holding.any():
            kk = k[holding] + 2  # the next throw, of the ball in the hand
            v_out, _ = self._velocity(kk)
            _, v_in = self._velocity(kk - self.balls)
            c = self._pts(self.catch, kk)
            a = self._pts(self.throw, kk)
            out[holding] = _hermite(c, self.carry * d * v_in, a, self.carry * d * v_out, (tau[holding] - empty_time) / d)
        return out, holding


@dataclass(frozen=True)
class Juggled:
    """Trajectory of one ball of a ``JugglePattern``."""

    pattern: JugglePattern
    index: int

    def positions(self, t: np.ndarray) -> np.ndarray:
        return self.pattern.ball(self.index, np.asarray(t, float))


@dataclass(frozen=True)
class Hand:
    """A hand (and arm) of a juggler, following ``pattern``'s hand ``side``; palm up, fingers towards the cameras (-y)."""

    pattern: JugglePattern
    side: int  # 0 left (smaller x), 1 right
    ball_radius: float
    shoulder: tuple[float, float, float]
    skin: Material
    sleeve: Material | None = None  # long sleeves: the upper arm and the back half of the forearm
    size: float = 1.0  # hand scale (1 = an adult's, palm 8.5 cm wide)

    def ellipsoids(self, t: float) -> list[Ellipsoid]:
        grip, _ = self.pattern.hand(self.side, np.array([t]))
        c = grip[0]
        r = self.ball_radius
        k = self.size
        skin = self.skin
        inward = 1.0 if self.side == 0 else -1.0  # towards the body's midline
        out: list[Ellipsoid] = []
        # Palm under the ball, reaching back towards the wrist.
        palm = c + np.array([0.0, 0.03 * k, -(r + 0.013 * k)])
        out.append(Ellipsoid(tuple(palm), (0.043 * k, 0.052 * k, 0.015 * k), skin))
        # Fingers and thumb as chains of segments on a shell just outside the ball, from below it to around its equator.
        shell = r + 0.011 * k

        def on_shell(theta, phi):
            th, ph = np.radians(theta), np.radians(phi)
            return c + shell * np.array([np.sin(th) * np.sin(ph), -np.sin(th) * np.cos(ph), -np.cos(th)])

        digits = [(phi, (28, 62, 92, 112), 0.0085) for phi in (-38, -13, 12, 37)]
        digits.append((inward * 80, (40, 75, 100), 0.0105))  # the thumb, on the inner side
        for phi, thetas, thick in digits:
            pts = [on_shell(th, phi) for th in thetas]
            for p, q in zip(pts[:-1], pts[1:]):
                length = float(np.linalg.norm(q - p))
                out.append(
                    Ellipsoid(tuple((p + q) / 2), (thick * k, thick * k, 0.5 * length + 0.5 * thick * k), skin, frame_from_axis(q - p))
                )
        # Arm: wrist -> elbow -> shoulder, the elbow where a two-bone arm puts it (down, back and out).
        wrist = palm + np.array([0.0, 0.055 * k, -0.004])
        shoulder = np.asarray(self.shoulder, float)
        upper, fore = 0.29 * k, 0.26 * k
        span = shoulder - wrist
        dist = float(np.clip(np.linalg.norm(span), 0.05, 0.99 * (upper + fore)))
        axis = span / np.linalg.norm(span)
        along = (fore**2 - upper**2 + dist**2) / (2 * dist)
        height = np.sqrt(max(fore**2 - along**2, 0.0))
        hint = np.array([-inward * 0.5, 0.3, -1.0])
        perp = hint - (hint @ axis) * axis
        perp /= np.linalg.norm(perp)
        elbow = wrist + along * axis + height * perp
        fore_mat = skin
        sleeve = self.sleeve or skin
        mid = wrist + 0.55 * (elbow - wrist)
        for a, b, rad, mat in ((wrist, mid, 0.027 * k, fore_mat), (mid, elbow, 0.034 * k, sleeve), (elbow, shoulder, 0.042 * k, sleeve)):
            length = float(np.linalg.norm(b - a))
            out.append(Ellipsoid(tuple((a + b) / 2), (rad, rad * 0.9, 0.5 * length + 0.6 * rad), mat, frame_from_axis(b - a)))
        return out
