"""Ball trajectories for synthetic scenes: where each ball is at time t (world frame, z up).

Every trajectory maps an array of times (seconds) to T x 3 positions in
metres; NaN rows mean "not in the scene at that time". All are closed-form,
tabulated (motion capture) or integrated on a fixed grid from their start (a
flight with air drag), so any frame can be rendered on its own.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

G = 9.81  # m/s^2, along -z


@dataclass(frozen=True)
class Static:
    """A ball that does not move."""

    position: tuple[float, float, float]

    def positions(self, t: np.ndarray) -> np.ndarray:
        return np.broadcast_to(np.asarray(self.position, float), (len(t), 3)).copy()


@dataclass(frozen=True)
class Pendulum:
    """A ball on a string of ``length`` hanging from ``pivot``, swinging in a vertical plane.

    The swing plane holds the vertical and the horizontal direction at
    ``azimuth`` degrees from +x towards +y (0 = sideways across the image,
    90 = towards/away from the cameras). The period follows from the
    length: 2 pi sqrt(length / g).
    """

    pivot: tuple[float, float, float]
    length: float
    amplitude: float = 20.0  # degrees
    azimuth: float = 0.0  # degrees
    phase: float = 0.0  # degrees

    @property
    def period(self) -> float:
        return float(2 * np.pi * np.sqrt(self.length / G))

    def positions(self, t: np.ndarray) -> np.ndarray:
        t = np.asarray(t, float)
        theta = np.radians(self.amplitude) * np.cos(2 * np.pi * t / self.period + np.radians(self.phase))
        az = np.radians(self.azimuth)
        swing = np.array([np.cos(az), np.sin(az), 0.0])
        out = np.asarray(self.pivot, float) + self.length * (np.sin(theta)[:, None] * swing)
        out[:, 2] -= self.length * np.cos(theta)
        return out


@dataclass(frozen=True)
class Line:
    """Straight back and forth between ``start`` and ``end`` at constant speed (one way takes ``period`` / 2)."""

    start: tuple[float, float, float]
    end: tuple[float, float, float]
    period: float = 4.0  # seconds for there and back
    phase: float = 0.0  # fraction of the period already travelled at t = 0

    def positions(self, t: np.ndarray) -> np.ndarray:
        s = np.mod(np.asarray(t, float) / self.period + self.phase, 1.0)
        w = 1.0 - np.abs(2.0 * s - 1.0)  # 0 -> 1 -> 0 triangle wave
        a, b = np.asarray(self.start, float), np.asarray(self.end, float)
        return a + w[:, None] * (b - a)


@dataclass(frozen=True)
class Ballistic:
    """Repeated throws under gravity between two hands: ``start`` -> ``end`` -> ``start`` ...

    Each flight lasts ``flight`` seconds and lands at the height it left,
    so the apex is g flight^2 / 8 above the hands; ``dwell`` seconds in the
    hand (standing still) follow each catch.
    """

    start: tuple[float, float, float]
    end: tuple[float, float, float]
    flight: float = 0.8
    dwell: float = 0.2
    phase: float = 0.0  # seconds already elapsed at t = 0

    def positions(self, t: np.ndarray) -> np.ndarray:
        cycle = self.flight + self.dwell
        tt = np.asarray(t, float) + self.phase
        k = np.floor(tt / cycle).astype(int)
        tau = np.minimum(tt - k * cycle, self.flight)  # time in the air (held at the catch while dwelling)
        a, b = np.asarray(self.start, float), np.asarray(self.end, float)
        odd = (k % 2 == 1)[:, None]
        frm, to = np.where(odd, b, a), np.where(odd, a, b)
        s = (tau / self.flight)[:, None]
        out = frm + s * (to - frm)
        out[:, 2] += 0.5 * G * tau * (self.flight - tau)
        return out


@dataclass(frozen=True, eq=False)
class Samples:
    """A tabulated trajectory (e.g. motion capture): linear interpolation, NaN where unknown."""

    times: np.ndarray  # F seconds, increasing
    points: np.ndarray  # F x 3 metres, NaN = unknown
    loop: bool = False  # replay from the start after the last sample

    def positions(self, t: np.ndarray) -> np.ndarray:
        t = np.asarray(t, float)
        if self.loop:
            t = np.mod(t, self.times[-1])
        j = np.clip(np.searchsorted(self.times, t, side="right") - 1, 0, len(self.times) - 2)
        w = ((t - self.times[j]) / (self.times[j + 1] - self.times[j]))[:, None]
        a, b = self.points[j], self.points[j + 1]
        out = np.where(w < 1e-9, a, (1 - w) * a + w * b)
        out[(t < self.times[0]) | (t > self.times[-1])] = np.nan
        return out


AIR_DENSITY = 1.2  # kg/m^3


def drag_per_metre(radius: float, mass: float, drag_coefficient: float) -> float:
    """k (1/m) of a ball's quadratic air drag, its deceleration k |v| v: rho Cd (pi r^2) / 2m."""
    return AIR_DENSITY * drag_coefficient * np.pi * radius**2 / (2.0 * mass)


@dataclass(frozen=True)
class Flight:
    """A ball in free flight: at ``start`` with ``velocity`` (m/s) at time ``t0``, then gravity (a throw, a pitch) and,
    with ``drag`` (k, 1/m: ``drag_per_metre``), air drag: a pitched baseball at 30 m/s slows by about 6 m/s^2, a
    tennis ball by 18. Before ``t0`` it flies on backwards without drag."""

    start: tuple[float, float, float]
    velocity: tuple[float, float, float]
    t0: float = 0.0
    drag: float = 0.0

    STEP = 1e-3  # seconds: the grid a flight with drag is integrated on (fourth-order Runge-Kutta), from t0 ...
    CHUNK = 0.5  # ... this many seconds at a time, as far as a time asked needs

    def __post_init__(self):
        if not (np.isfinite(self.drag) and 0.0 <= self.drag <= 10.0):
            raise ValueError(f"drag must be 0-10 per metre (a tennis ball's is 0.02), got {self.drag}")

    def positions(self, t: np.ndarray) -> np.ndarray:
        tau = np.asarray(t, float) - self.t0
        out = np.asarray(self.start, float) + tau[:, None] * np.asarray(self.velocity, float)
        out[:, 2] -= 0.5 * G * tau**2
        after = tau > 0
        if self.drag > 0 and after.any():
            out[after] = self._dragged(tau[after])
        return out

    def _dragged(self, tau: np.ndarray) -> np.ndarray:
        """Positions at ``tau`` >= 0 seconds after t0, by cubic Hermite interpolation of the integrated grid."""
        p, v = self._grid(float(tau.max()))
        i = np.minimum((tau / self.STEP).astype(int), len(p) - 2)
        s = (tau / self.STEP - i)[:, None]
        h00, h10, h01, h11 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s, -2 * s**3 + 3 * s**2, s**3 - s**2
        return h00 * p[i] + h10 * self.STEP * v[i] + h01 * p[i + 1] + h11 * self.STEP * v[i + 1]

    def _grid(self, until: float) -> tuple[np.ndarray, np.ndarray]:
        """Positions and velocities every STEP from t0 to ``until`` seconds after it or further, integrated once and
        extended when a later time is asked: each step follows from the one before, so a time's position is the same
        whatever was asked before it."""
        p, v = self.__dict__.get("_integrated", (np.empty((0, 3)), np.empty((0, 3))))
        if len(p) < 2 or (len(p) - 2) * self.STEP < until:
            n = int(np.ceil(until / self.CHUNK) * round(self.CHUNK / self.STEP)) + 2
            p, v = self._integrate(n, p, v)
            self.__dict__["_integrated"] = (p, v)  # a cache, not a field: the frozen flight is unchanged
        return p, v

    def _integrate(self, n: int, p: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The first ``n`` steps, continuing the ``p``, ``v`` already integrated (none: from the start)."""
        g = np.array([0.0, 0.0, -G])

        def accel(u: np.ndarray) -> np.ndarray:
            return g - self.drag * np.linalg.norm(u) * u

        done = max(len(p), 1)
        p, v = np.vstack([p, np.empty((n - len(p), 3))]), np.vstack([v, np.empty((n - len(v), 3))])
        if done == 1:
            p[0], v[0] = self.start, self.velocity
        h = self.STEP
        for k in range(done - 1, n - 1):
            x, u = p[k], v[k]
            a1 = accel(u)
            a2 = accel(u + 0.5 * h * a1)
            a3 = accel(u + 0.5 * h * a2)
            a4 = accel(u + h * a3)
            p[k + 1] = x + h * u + h * h / 6.0 * (a1 + a2 + a3)
            v[k + 1] = u + h / 6.0 * (a1 + 2 * a2 + 2 * a3 + a4)
        return p, v


TRAJECTORIES = {"static": Static, "pendulum": Pendulum, "line": Line, "ballistic": Ballistic, "flight": Flight}
