import dataclasses

import numpy as np
import pytest
from scene_helpers import RADIUS, TARGET, balls_at, default_rig, disc_masks, evidence

from stereotrack.config import Target, TrackerSettings
from stereotrack.particles.motion import STOPPED_EVERY, RandomWalk
from stereotrack.particles.population import Population, split_counts
from stereotrack.results import TrackEstimate

BALLS = np.array([[-0.2, 1.3, 0.0], [0.25, 1.9, 0.1]])


def share_near(state, ball, radius=2 * RADIUS):
    near = np.linalg.norm(state.positions - ball, axis=1) < radius
    return float(state.weights[near].sum()), float(near.mean())


def run_population(alpha, frames=40, seed=0, particles=1000):
    rig = default_rig()
    masks, integrals = disc_masks(rig, BALLS)
    views = evidence(rig, masks)
    pop = Population(rig.cameras, TrackerSettings(particles=particles, alpha=alpha), TARGET, np.random.default_rng(seed))
    for _ in range(frames):
        state = pop.step(views, dt=1 / 30)
    return state


def test_split_counts():
    assert split_counts(1000, 0.2) == (800, 200)
    assert split_counts(1000, 0.0) == (1000, 0)
    assert split_counts(1000, 1.0) == (0, 1000)


def test_weights_split_alpha_between_parts():
    state = run_population(0.3, frames=5)
    assert state.weights.sum() == pytest.approx(1.0)
    assert state.weights[state.abductive].sum() == pytest.approx(0.3)
    assert state.abductive.sum() == 300


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_alpha_zero_collapses_onto_one_mode(seed):
    """Paper Table II: pure CONDENSATION abandons all but one ball (or a stereo ghost of both)."""
    state = run_population(0.0, frames=200, seed=seed)
    shares = sorted(share_near(state, b)[1] for b in BALLS)
    assert shares[0] < 0.03
    centre = np.median(state.positions, axis=0)
    assert (np.linalg.norm(state.positions - centre, axis=1) < 0.15).mean() > 0.6  # one compact mode


@pytest.mark.parametrize("alpha", [0.1, 0.2, 0.5])
def test_alpha_positive_keeps_particles_on_both_balls(alpha):
    state = run_population(alpha, frames=40)
    for b in BALLS:
        assert share_near(state, b)[1] >= 0.05


def test_alpha_one_puts_every_particle_on_a_blob_ray():
    rig = default_rig()
    masks, integrals = disc_masks(rig, BALLS)
    views = evidence(rig, masks)
    for share in (0.0, 0.25):  # the paper's proposal (rays only), then ours (a share at ray crossings)
        pop = Population(rig.cameras, TrackerSettings(particles=500, alpha=1.0, crossing_share=share), TARGET, np.random.default_rng(0))
        state = pop.step(views, dt=1 / 30)
        assert state.abductive.all() and state.weights.sum() == pytest.approx(1.0)
        # Every particle projects onto a ball's disc in the camera whose ray placed it, or sits
        # around a crossing of two rays (here: a ball).
        on_disc = np.zeros(len(state.positions), bool)
        for cam, m in zip(rig.cameras, masks):
            uv, ok = cam.project(state.positions)
            u = np.clip(np.rint(uv[:, 0]).astype(int), 0, cam.width - 1)
            v = np.clip(np.rint(uv[:, 1]).astype(int), 0, cam.height - 1)
            on_disc |= ok & (m[v, u] == 1)
        near_ball = (np.linalg.norm(state.positions[:, None] - BALLS[None], axis=2) < 3 * RADIUS).any(axis=1)
        assert on_disc.all() if share == 0 else (on_disc | near_ball).all()
        assert (~on_disc).sum() <= share * 500 * 0.5


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_first_frame_places_every_particle_from_the_evidence(seed):
    """The first frame has no past to propagate, so every particle is abductive: each ball seen then gets a sixth of
    them within two radii (the frustum's blind guesses beside the abductive share left it under 4 %, and its cluster
    a frame or two late). The paper's pure CONDENSATION (alpha 0) still starts from the frustum."""
    rig = default_rig()
    masks, _ = disc_masks(rig, BALLS)
    views = evidence(rig, masks)
    state = Population(rig.cameras, TrackerSettings(particles=1000, alpha=0.2), TARGET, np.random.default_rng(seed)).step(views, 1 / 30)
    assert state.abductive.all() and state.weights.sum() == pytest.approx(1.0)
    for b in BALLS:
        assert share_near(state, b)[1] > 0.1
    state = Population(rig.cameras, TrackerSettings(particles=1000, alpha=0.0), TARGET, np.random.default_rng(seed)).step(views, 1 / 30)
    assert not state.abductive.any()


@pytest.mark.parametrize("likelihood, gain", [("colour_window", 3.0), ("ball_shape", 1.3)])
def test_crossing_particles_find_a_new_ball_in_its_first_frame(likelihood, gain):
    """Along the rays a ball that just appeared gets a few particles per ball-length; at the crossing of
    its two rays it gets a share of them all (a juggled ball coming out of the hand). The ball-shape
    model already weighs the right depth along a ray (by the disc's size), so crossings add less."""
    rig = default_rig()
    masks, integrals = disc_masks(rig, BALLS)
    views = evidence(rig, masks)
    weight = {}
    for share in (0.0, 0.25):
        settings = TrackerSettings(alpha=0.2, crossing_share=share, likelihood=likelihood)
        pop = Population(rig.cameras, settings, TARGET, np.random.default_rng(0))
        state = pop.step(views, dt=1 / 30)
        weight[share] = min(share_near(state, b, RADIUS)[0] for b in BALLS)
    assert weight[0.25] > gain * weight[0.0]
    assert weight[0.25] > 0.02  # above the clusters' minimum mass (0.01): an object this very frame


def test_exclusion_kills_particles_of_one_track_inside_another_ball():
    rig = default_rig()
    masks, integrals = disc_masks(rig, BALLS)
    views = evidence(rig, masks)
    pop = Population(rig.cameras, TrackerSettings(particles=1000, alpha=0.0, motion_sigma=0.0), TARGET, np.random.default_rng(0))
    pop.step(views, dt=1 / 30)
    # Pretend every particle follows track 1 while track 2's ball sits on ball 0.
    pop.state = dataclasses.replace(pop.state, owners=np.full(1000, 1))
    pop.state = type(pop.state)(
        np.repeat(BALLS[:1], 1000, axis=0),
        pop.state.velocities,
        np.full(1000, 1e-3),
        pop.state.likelihoods,
        pop.state.abductive,
        pop.state.owners,
    )
    balls = balls_at(BALLS[:1], first_id=2)
    state = pop.step(views, dt=1 / 30, balls=balls)
    assert state.weights.sum() == pytest.approx(1.0)
    assert np.allclose(state.weights, 1e-3)  # every particle was an intruder: all zero, renormalised to uniform
    # With the ball being their own track, nothing happens to them.
    pop.state = dataclasses.replace(pop.state, owners=np.full(1000, 2))
    state = pop.step(views, dt=1 / 30, balls=balls)
    assert state.likelihoods.min() > 0.5


def _followed(pop, views, start: np.ndarray, tracks, frames: int):
    """``pop`` after one step on ``views``, its particles then set at ``start`` weighted by their likelihood, and
    ``frames`` more steps each following ``tracks``: the last state."""
    pop.step(views, dt=1 / 30)
    lik = pop.likelihood(start, views, None)
    pop.state = dataclasses.replace(pop.state, positions=start, weights=lik / lik.sum(), likelihoods=lik)
    for _ in range(frames):
        pop.follow(tracks)
        state = pop.step(views, dt=1 / 30)
    return state


def _weak_ball_share(track_floor: float, frames: int = 20) -> float:
    """Ball 0 drawn whole, ball 1 with every third row left out (a ball partly hidden in a hand: its likelihood a fifth of
    ball 0's), each followed by a confirmed track; the particles start half on each. No abductive particles: what
    stays on ball 1 is what resampling keeps. The share of particles on ball 1 after ``frames`` steps."""
    rig = default_rig()
    whole, _ = disc_masks(rig, BALLS[:1])
    faint, _ = disc_masks(rig, BALLS[1:])
    for f in faint:
        f[::3] = 0
    masks = [w | f for w, f in zip(whole, faint)]
    views = evidence(rig, masks)
    settings = TrackerSettings(particles=1000, alpha=0.0, track_floor=track_floor)
    pop = Population(rig.cameras, settings, TARGET, np.random.default_rng(0))
    rng = np.random.default_rng(1)
    start = np.repeat(BALLS, 500, axis=0) + rng.normal(0.0, 0.005, (1000, 3))
    lik = pop.likelihood(start, views, None)
    assert lik[500:].mean() < 0.3 * lik[:500].mean()  # the drawn ball 1 is the weak one
    tracks = [TrackEstimate(k + 1, TARGET.name, b, np.zeros(3), 1e-4 * np.eye(3), "confirmed") for k, b in enumerate(BALLS)]
    return share_near(_followed(pop, views, start, tracks, frames), BALLS[1])[1]


def test_a_tracked_ball_whose_likelihood_falls_keeps_its_share_of_particles():
    """The track floor (mixture particle filter): without it, resampling by weight drains the weak ball in a few frames."""
    assert _weak_ball_share(0.0) < 0.02
    assert _weak_ball_share(0.5) > 0.1  # of 0.25 kept for it (0.5 over two tracks), some walked out of its disc
    # Not for a white ball: along its ray a white wall scores as well as the ball (population.py)
    white = Target("white", (0, 0, 180), (179, 40, 255), RADIUS)
    assert white.any_hue
    assert Population(default_rig().cameras, TrackerSettings(), white, np.random.default_rng(0)).track_floor == 0.0


def _caught_ball_share(stopped_every: int, frames: int = 5) -> float:
    """A ball at rest (just caught) whose confirmed track still has the velocity it was thrown with (2 m/s sideways:
    a track's velocity lags a catch by a few frames); no abductive particles, so what stays on the ball is what the
    sequential part keeps. The share of particles on the ball after ``frames`` steps."""
    rig = default_rig()
    masks, _ = disc_masks(rig, BALLS[:1])
    views = evidence(rig, masks)
    settings = TrackerSettings(particles=1000, alpha=0.0)
    pop = Population(rig.cameras, settings, TARGET, np.random.default_rng(0), motion=RandomWalk(settings.motion_sigma, stopped_every))
    start = BALLS[0] + np.random.default_rng(1).normal(0.0, 0.005, (1000, 3))
    thrown = [TrackEstimate(1, TARGET.name, BALLS[0], np.array([2.0, 0.0, 0.0]), 1e-4 * np.eye(3), "confirmed")]
    return share_near(_followed(pop, views, start, thrown, frames), BALLS[0])[1]


def test_a_caught_balls_particles_stay_on_it_while_its_tracks_velocity_still_says_it_flies():
    """Every fourth particle keeps still (motion.STOPPED_EVERY): with all of them drifting on the track's stale
    velocity the cloud overshoots the stopped ball by two radii a frame and leaves it."""
    assert _caught_ball_share(0) < 0.05
    assert _caught_ball_share(STOPPED_EVERY) > 0.3
