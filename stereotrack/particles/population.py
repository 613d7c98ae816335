"""The mixed particle population (paper Table I): CONDENSATION + abductive importance sampling.

Each frame, for one target colour:
1. sequential part, (1 - alpha) N particles: systematic resampling from last
   frame's combined weighted set, then the motion model (drift by the
   particle's velocity, if its ball has one, for three particles in four,
   plus an isotropic Gaussian random walk), weighted by the likelihood and
   normalised to sum to 1 - alpha;
2. abductive part, alpha N particles: placed uniformly along the viewing
   rays of this frame's colour blobs (depth range narrowed by the ball's
   apparent size), and a share (``crossing_share``) around the points where
   rays of two cameras cross, weighted by the likelihood and normalised to sum to
   alpha. Along a ray, a ball that just appeared gets a few particles per
   ball-length of ray; at a crossing it gets them all, and is found a frame
   or two sooner (a juggled ball coming out of the hand).
Good abductive particles survive into the next sequential part; bad ones die.

The population composes one component per role, each replaceable: the
resampler (``resampling.systematic_indices``), the motion model
(``motion.RandomWalk``), the abductive proposal (``proposal.RayProposal``)
and the likelihood (``likelihoods/``, eq. 14 by default).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..camera import Camera
from ..config import Target, TrackerSettings
from ..evidence.gather import CameraEvidence
from ..results import TrackedBalls, TrackEstimate
from .kernels import intruders, lifted_weights, nearest_within
from .likelihoods import Likelihood, make_likelihood
from .motion import RandomWalk
from .proposal import RayProposal, frustum_particles
from .resampling import systematic_indices


@dataclass(frozen=True, eq=False)
class PopulationState:
    """One target's particles after a step."""

    positions: np.ndarray  # N x 3
    velocities: np.ndarray  # N x 3, metres per second (zero unless a track lends one)
    weights: np.ndarray  # N, summing to 1
    likelihoods: np.ndarray  # N, eq. 14 values (1 = full windows in every camera)
    abductive: np.ndarray  # N bool
    owners: np.ndarray | None = None  # N track id a particle follows (-1: none), set after tracking
    anchors: np.ndarray | None = None  # sorted ids of the confirmed (or coasting) tracks among them, set with ``owners``


def split_counts(n: int, alpha: float) -> tuple[int, int]:
    """(sequential, abductive) particle counts for N and alpha."""
    n_abd = int(round(alpha * n))
    return n - n_abd, n_abd


FOLLOW_MARGIN_SQ = 0.0025  # (5 cm)^2 added to (3 ball radii)^2: how far from a track a particle still follows it


class Population:
    """The particle population of one target, stepped frame by frame."""

    def __init__(
        self,
        cameras: Sequence[Camera],
        settings: TrackerSettings,
        target: Target,
        rng: np.random.Generator,
        likelihood: Likelihood | None = None,
        motion=None,
        proposal=None,
    ):
        self.cameras = tuple(cameras)
        self.settings = settings
        self.target = target
        self.rng = rng
        self.likelihood = likelihood or make_likelihood(settings, target)
        self.motion = motion or RandomWalk(settings.motion_sigma)
        self.proposal = proposal or RayProposal(settings, target.radius, target.any_hue)
        self.state: PopulationState | None = None
        # Not for a white or grey ball: along its ray a white wall scores as well as the ball, and a kept share kept
        # wrong-depth modes too (white_ball tune seeds 0-39: MOTA summed -0.03 and -0.32 over tracker seeds 0 and 1)
        self.track_floor = 0.0 if target.any_hue else settings.track_floor

    def step(self, views: Sequence[CameraEvidence], dt: float, balls: TrackedBalls | None = None) -> PopulationState:
        """Advance one frame on this target's evidence in every camera. ``balls``: the confirmed tracked balls of
        every target, for exclusion (seed 000's blocking), occlusion by other colours, and the crossings they hold."""
        s = self.settings
        n_seq, n_abd = split_counts(s.particles, s.alpha)
        if self.state is None and n_abd:
            # The first frame has no past to propagate: every particle is born from the evidence (a frustum's worth of
            # blind guesses left a ball a few abductive particles and its cluster a frame or two late).
            n_seq, n_abd = 0, s.particles
        rng = self.rng
        if n_seq:
            if self.state is None:
                seq = frustum_particles(self.cameras[0], n_seq, s.d_min, s.d_max, rng)
                seq_vel = np.zeros_like(seq)
            else:
                idx = systematic_indices(self._floored_weights(), n_seq, rng)
                seq_vel = self.state.velocities[idx]
                seq = self.motion(self.state.positions[idx], seq_vel, dt, rng)
                if self.state.owners is not None:
                    seq_owner = self.state.owners[idx]
        else:
            seq, seq_vel = np.zeros((0, 3)), np.zeros((0, 3))
        mine = balls.of(self.target.name) if balls is not None else None
        abd = self.proposal(views, n_abd, mine, rng) if n_abd else np.zeros((0, 3))
        positions = np.vstack([seq, abd])
        # Only a ball of another colour can hide a particle unfairly: one of the same colour fills
        # the window anyway, and the likelihood already scores that view as a match (and one overlapping
        # a ball of this colour is that ball seen by another target: TrackedBalls.occluding).
        lik = self.likelihood(positions, views, balls.occluding(self.target.name) if balls is not None else None)
        if balls is not None and s.exclusion and len(balls) and n_seq and self.state is not None and self.state.owners is not None:
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

    def _floored_weights(self) -> np.ndarray:
        """Last step's weights to resample from, with each confirmed track's particles lifted to ``track_floor / K`` of
        the whole at least (K tracks). One population serves every ball of a colour, and resampling by weight alone
        starves a ball whose likelihood falls (held in a hand, half hidden: 0.18 where a ball in flight reads 0.9):
        its particles halve every frame, its cluster falls under ``cluster_min_mass`` and the ball is lost while in
        plain view (hands tune seed 36, frames 72-76). Kept a share, as each component of a mixture particle filter
        keeps its own (Vermaak et al. 2003), its cluster stays. Only a track with a cluster's worth of particles in
        likelihood is lifted: a ball that has gone leaves nothing to keep."""
        st, s = self.state, self.settings
        if not self.track_floor or st.anchors is None or not len(st.anchors):
            return st.weights
        # The particles following a confirmed track, which track, its mass and whether it is alive; then the lift
        # (kernels.lifted_weights: one pass where numpy took a dozen calls)
        weights = lifted_weights(
            st.weights, st.likelihoods, st.owners, st.anchors, s.cluster_min_likelihood, s.cluster_min_particles, self.track_floor
        )
        return weights / weights.sum()

    def follow(self, tracks: Sequence[TrackEstimate]) -> None:
        """Particles near a track of this target follow it: its velocity drifts them in the next step (beyond the
        random walk, with ``particle_velocity``) and its id marks whose ball they are (for exclusion)."""
        if self.state is None:
            return
        mine = [tr for tr in tracks if tr.target == self.target.name]
        centres = np.array([tr.position for tr in mine]).reshape(-1, 3)
        nearest = nearest_within(self.state.positions, centres, np.sqrt((3 * self.target.radius) ** 2 + FOLLOW_MARGIN_SQ))
        # Looked up with a last row for "no track" (nearest = -1): one gather per array.
        owners = np.array([tr.track_id for tr in mine] + [-1])[nearest]
        speeds = [tr.velocity for tr in mine] if self.settings.particle_velocity else [np.zeros(3)] * len(mine)
        velocities = np.array(speeds + [np.zeros(3)]).reshape(-1, 3)[nearest]
        anchors = np.unique(np.array([tr.track_id for tr in mine if tr.state != "tentative"], np.int64))
        st = self.state
        self.state = PopulationState(st.positions, velocities, st.weights, st.likelihoods, st.abductive, owners, anchors)
