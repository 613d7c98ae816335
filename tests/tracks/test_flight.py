"""A ball in free flight: the parabola under known gravity, its landing point, and the track manager exposing it."""

import numpy as np
import pytest

from stereotrack.config import TrackSettings
from stereotrack.results import Object3D, Parabola
from stereotrack.tracks import TrackManager
from stereotrack.tracks.flight import fit_parabola, landing

GRAVITY = np.array([0.0, 0.0, -9.81])


def throw(t, p0=(0.1, 1.5, -0.3), v0=(0.6, -0.2, 3.5)):
    t = np.asarray(t, float)[:, None]
    return np.asarray(p0) + np.asarray(v0) * t + 0.5 * GRAVITY * t * t


def test_fit_recovers_the_position_and_velocity_at_the_latest_time():
    t = np.arange(8) / 30.0
    flight = fit_parabola(t, throw(t), GRAVITY)
    assert flight.time == pytest.approx(t[-1])
    np.testing.assert_allclose(flight.position, throw([t[-1]])[0], atol=1e-12)
    np.testing.assert_allclose(flight.velocity, np.array([0.6, -0.2, 3.5]) + GRAVITY * t[-1], atol=1e-10)


def test_noise_averages_out_in_the_fit():
    rng = np.random.default_rng(4)
    t = np.arange(8) / 30.0
    flight = fit_parabola(t, throw(t) + rng.normal(0, 0.002, (8, 3)), GRAVITY)
    assert np.linalg.norm(flight.velocity - (np.array([0.6, -0.2, 3.5]) + GRAVITY * t[-1])) < 0.1


def test_landing_is_where_the_parabola_comes_down_through_the_height():
    flight = Parabola(2.0, np.array([0.1, 1.5, -0.3]), np.array([0.6, -0.2, 3.5]), GRAVITY)
    point, when = landing(flight, -0.3)
    airtime = 2 * 3.5 / 9.81  # back to the throw height
    assert when == pytest.approx(2.0 + airtime)
    np.testing.assert_allclose(point, [0.1 + 0.6 * airtime, 1.5 - 0.2 * airtime, -0.3], atol=1e-9)
    # lower down: later, further along
    low, when_low = landing(flight, -1.0)
    assert when_low > when and low[2] == pytest.approx(-1.0) and low[0] > point[0]


def test_no_landing_above_the_apex_or_once_the_ball_is_below_the_height():
    up = Parabola(0.0, np.zeros(3), np.array([0.0, 0.0, 2.0]), GRAVITY)
    assert landing(up, 0.5) is None  # the apex is 2^2 / (2 g) = 0.20 m
    assert landing(up, 0.2) is not None
    falling = Parabola(0.0, np.zeros(3), np.array([0.0, 0.0, -1.0]), GRAVITY)
    assert landing(falling, 0.1) is None  # came down through it before
    assert landing(Parabola(0.0, np.zeros(3), np.array([0.0, 0.0, 3.0]), GRAVITY), 0.0, after=1.0) is None  # landed at 0.61 s


def test_landing_follows_any_up_axis():
    g = np.array([0.0, 9.81, 0.0])  # up is -y (a camera-like world)
    flight = Parabola(0.0, np.array([0.0, -1.0, 2.0]), np.array([0.5, -3.0, 0.0]), g)
    point, when = landing(flight, 1.0)  # height 1 along -y, i.e. y = -1
    assert point[1] == pytest.approx(-1.0) and when == pytest.approx(6.0 / 9.81)


def run_manager(positions, times, up=(0.0, 0.0, 1.0)):
    manager = TrackManager(TrackSettings(up=up))
    out = []
    for t, p in zip(times, positions):
        out.append(manager.update([Object3D("pink", p, np.eye(3) * 1e-6, 1.0, 100)], float(t)))
    return out


def test_the_manager_gives_a_thrown_ball_its_parabola_and_a_pendulum_none():
    rng = np.random.default_rng(7)
    times = np.arange(20) / 30.0
    thrown = run_manager(throw(times) + rng.normal(0, 0.002, (20, 3)), times)
    flights = [est[0].flight for est in thrown]
    assert flights[0] is None  # too few positions to tell
    assert all(f is not None for f in flights[8:])
    point, when = landing(flights[-1], -0.3)
    airtime = 2 * 3.5 / 9.81
    assert abs(when - airtime) < 0.01
    assert np.linalg.norm(point - throw([airtime])[0]) < 0.02
    swing = 0.3 * np.sin(2 * np.pi * times / 1.5)
    pendulum = np.stack([swing, np.full(20, 1.5), -0.2 * np.cos(2 * np.pi * times / 1.5)], axis=1)
    assert all(est[0].flight is None for est in run_manager(pendulum, times))
    assert all(est[0].flight is None for est in run_manager(throw(times), times, up=None))  # no gravity known
