"""The mixed particle population (paper Table I): CONDENSATION + abductive importance sampling.

Each frame, for one target colour:
1. sequential part, (1 - alpha) N particles: systematic resampling from last
   frame's combined weighted set, then the motion model (drift by the
   particle's velocity, if its ball has one, plus an isotropic Gaussian
   random walk), weighted by eq. 14 and normalised to sum to 1 - alpha;
2. abductive part, alpha N particles: placed uniformly along the viewing
   rays of this frame's colour blobs (depth range narrowed by the ball's
   apparent size), and a share (``crossing_share``) around the points where
   rays of two cameras cross, weighted by eq. 14 and normalised to sum to
   alpha. Along a ray, a ball that just appeared gets a few particles per
   ball-length of ray; at a crossing it gets them all, and is found a frame
   or two sooner (a juggled ball coming out of the hand).
Good abductive particles survive into the next sequential part; bad ones die.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..camera import Camera
from ..config import TrackerSettings
from ..evidence.blobs import Blobs
from .kernels import intruders
from .likelihood import likelihood
from .proposal import depth_range_from_size, particles_on_rays, ray_crossings
from .resampling import systematic_indices


@dataclass(frozen=True, eq=False)
class TrackedBalls:
    """The balls the tracks predict for this frame (all targets): for exclusion and occlusion."""

    centres: np.ndarray  # B x 3
    radii: np.ndarray  # B
    track_ids: np.ndarray  # B
    other_colour: np.ndarray  # B bool: the ball is of another target than this population's


@dataclass(frozen=True, eq=False)
class PopulationState:
    """One target's particles after a step."""

    positions: np.ndarray  # N x 3
    velocities: np.ndarray  # N x 3, metres per second (zero unless a track lends one)
    weights: np.ndarray  # N, summing to 1
    likelihoods: np.ndarray  # N, eq. 14 values (1 = full windows in every camera)
    abductive: np.ndarray  # N bool
    owners: np.ndarray | None = None  # N track id a particle follows (-1: none), set after tracking


def split_counts(n: int, alpha: float) -> tuple[int, int]:
    """(sequential, abductive) particle counts for N and alpha."""
    n_abd = int(round(alpha * n))
    return n - n_abd, n_abd


def frustum_particles(camera: Camera, n: int, d_min: float, d_max: float, rng: np.random.Generator) -> np.ndarray:
    """Particles spread over the camera's field of view between d_min and d_max (no information)."""
    uv = rng.random((n, 2)) * np.array([camera.width, camera.height])
    o, d = camera.rays(uv)
    dist = d_min + rng.random(n) * (d_max - d_min)
    return o + dist[:, None] * d


class Population:
    """The particle population of one target, stepped frame by frame."""

    def __init__(self, cameras: Sequence[Camera], settings: TrackerSettings, radius: float, rng: np.random.Generator):
        self.cameras = tuple(cameras)
        self.settings = settings
        self.radius = radius
        self.rng = rng
        self.state: PopulationState | None = None

    def _abductive(self, blobs: Sequence[Blobs], rays, n: int, balls: TrackedBalls | None = None) -> np.ndarray:
        s = self.settings
        origins, dirs, near, far = [], [], [], []
        for cam, b, (o, d) in zip(self.cameras, blobs, rays):
            if len(b) == 0:
                continue
            if s.depth_from_size:
                lo, hi = depth_range_from_size(cam, b.radii, self.radius, s.d_min, s.d_max)
            else:
                lo, hi = np.full(len(b), s.d_min), np.full(len(b), s.d_max)
            origins.append(o)
            dirs.append(d)
            near.append(lo)
            far.append(hi)
        if not origins:  # nothing of this colour in any image: search blindly
            return frustum_particles(self.cameras[0], n, s.d_min, s.d_max, self.rng)
        crossings = np.zeros((0, 3))
        if s.crossing_share > 0:
            # Crossings are for balls no track holds yet: blobs a tracked ball of this colour projects
            # into are left out (their ball has its particles; a partly hidden one's shifted centroid
            # would cross at the wrong depth).
            held = None
            if balls is not None and (~balls.other_colour).any():
                mine = balls.centres[~balls.other_colour]
                held = []
                for cam, b in zip(self.cameras, blobs):
                    uv, ok = cam.project(mine)
                    d = np.linalg.norm(uv[:, None] - b.centres[None], axis=2)
                    held.append((ok[:, None] & (d < np.maximum(b.radii[None], 3.0))).any(axis=0))
            crossings = ray_crossings(self.cameras, blobs, self.radius, s.d_min, s.d_max, held, rays=rays)
        n_cross = int(round(s.crossing_share * n)) if len(crossings) else 0
        pts, _ = particles_on_rays(np.vstack(origins), np.vstack(dirs), np.concatenate(near), np.concatenate(far), n - n_cross, self.rng)
        if n_cross:
            at = np.repeat(np.arange(len(crossings)), n_cross // len(crossings))
            at = np.r_[at, self.rng.permutation(len(crossings))[: n_cross - len(at)]]
            pts = np.vstack([pts, crossings[at] + self.rng.normal(0.0, 0.5 * self.radius, (n_cross, 3))])
        return pts

    def step(
        self,
        integrals: Sequence[np.ndarray],
        blobs: Sequence[Blobs],
        dt: float,
        balls: TrackedBalls | None = None,
        rays: Sequence[tuple[np.ndarray, np.ndarray]] | None = None,
    ) -> PopulationState:
        """Advance one frame. ``balls``: tracked balls for exclusion and occlusion (seed 000's blocking);
        ``rays``: the blobs' viewing rays per camera (origins, directions), computed here if not given."""
        s = self.settings
        if rays is None:
            rays = [cam.rays(b.centres) for cam, b in zip(self.cameras, blobs)]
        n_seq, n_abd = split_counts(s.particles, s.alpha)
        rng = self.rng
        if n_seq:
            if self.state is None:
                seq = frustum_particles(self.cameras[0], n_seq, s.d_min, s.d_max, rng)
                seq_vel = np.zeros_like(seq)
            else:
                idx = systematic_indices(self.state.weights, n_seq, rng)
                seq_vel = self.state.velocities[idx]
                seq = self.state.positions[idx] + seq_vel * dt + rng.normal(0.0, s.motion_sigma, (n_seq, 3))
                if self.state.owners is not None:
                    seq_owner = self.state.owners[idx]
        else:
            seq, seq_vel = np.zeros((0, 3)), np.zeros((0, 3))
        abd = self._abductive(blobs, rays, n_abd, balls) if n_abd else np.zeros((0, 3))
        positions = np.vstack([seq, abd])
        # Only a ball of another colour can hide a particle unfairly: one of the same colour fills
        # the window anyway, and eq. 14 already scores that view as a match.
        occluders = None
        if balls is not None and s.occlusion and balls.other_colour.any():
            occluders = (balls.centres[balls.other_colour], balls.radii[balls.other_colour])
        lik = likelihood(self.cameras, integrals, positions, s.window, occluders)
        if balls is not None and s.exclusion and len(balls.centres) and n_seq and self.state is not None and self.state.owners is not None:
            # Two balls cannot share space: a particle following one track dies inside another's ball.
            lik[:n_seq] = np.where(intruders(seq, seq_owner, balls.centres, balls.radii.astype(float), balls.track_ids), 0.0, lik[:n_seq])
        weights = np.empty(len(positions))
        alpha_eff = 0.0 if n_seq == 0 else s.alpha
        parts = [(slice(0, n_seq), 1.0 - alpha_eff if n_abd else 1.0), (slice(n_seq, None), alpha_eff if n_seq else 1.0)]
        for part, share in parts:
            total = lik[part].sum()
            if lik[part].size:
                weights[part] = share * lik[part] / total if total > 0 else share / lik[part].size
        weights /= weights.sum()
        velocities_out = np.zeros((len(positions), 3))
        velocities_out[:n_seq] = seq_vel
        abductive = np.zeros(len(positions), bool)
        abductive[n_seq:] = True
        self.state = PopulationState(positions, velocities_out, weights, lik, abductive)
        return self.state

    def follow_tracks(self, velocities: np.ndarray, owners: np.ndarray) -> None:
        """Give the current particles the velocity (m/s) and id of the track each follows, for the next step."""
        if self.state is not None:
            st = self.state
            self.state = PopulationState(st.positions, velocities, st.weights, st.likelihoods, st.abductive, owners)
