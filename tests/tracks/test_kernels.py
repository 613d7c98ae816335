"""The track stage's compiled kernels against the textbook formulas."""

import numpy as np

from stereotrack.tracks import kernels as track_kernels
from stereotrack.tracks.manager import motion_model
from stereotrack.tracks.smoothing import FILL_APART, FILL_RADII, FilterHistory, hindsight_fills


def test_kalman_steps_match_the_textbook_formulas():
    rng = np.random.default_rng(2)
    F, Q, b = motion_model(1 / 30, 30.0, np.array([0.0, 0.0, -9.81]))
    H = np.hstack([np.eye(3), np.zeros((3, 3))])
    for _ in range(20):
        A, B = rng.normal(size=(6, 6)), rng.normal(size=(3, 3))
        P, R = A @ A.T + 0.1 * np.eye(6), B @ B.T + 0.01 * np.eye(3)
        x, z = rng.normal(size=6), rng.normal(size=3)
        xp, Pp = track_kernels.kalman_predict(x, P, F, Q, b)
        assert np.allclose(xp, F @ x + b) and np.allclose(Pp, F @ P @ F.T + Q)
        K = P @ H.T @ np.linalg.inv(H @ P @ H.T + R)
        IKH = np.eye(6) - K @ H
        xc, Pc = track_kernels.kalman_correct(x, P, z, R)
        assert np.allclose(xc, x + K @ (z - H @ x)) and np.allclose(Pc, IKH @ P @ IKH.T + K @ R @ K.T)


def test_association_costs_match_numpy():
    rng = np.random.default_rng(6)
    pos, z = rng.normal(size=(4, 3)), rng.normal(size=(5, 3))
    A, B = rng.normal(size=(4, 3, 3)), rng.normal(size=(5, 3, 3))
    P, R = A @ A.transpose(0, 2, 1) + 0.1 * np.eye(3), B @ B.transpose(0, 2, 1) + 0.01 * np.eye(3)
    d2, cost = track_kernels.association_costs(pos, P, z, R)
    S = P[:, None] + R[None]
    y = z[None] - pos[:, None]
    want = np.einsum("tmi,tmi->tm", y, np.linalg.solve(S, y[..., None])[..., 0])
    assert np.allclose(d2, want) and np.allclose(cost, want + np.linalg.slogdet(S)[1])


def _rts_reference(xf, Pf, xp, Pp, F):
    """The Rauch-Tung-Striebel recursion as textbooks write it, every state smoothed, oldest first."""
    xs, Ps = [xf[-1]], [Pf[-1]]
    for k in range(len(xf) - 2, -1, -1):
        C = Pf[k] @ F[k + 1].T @ np.linalg.inv(Pp[k + 1])
        xs.insert(0, xf[k] + C @ (xs[0] - xp[k + 1]))
        Ps.insert(0, Pf[k] + C @ (Ps[0] - Pp[k + 1]) @ C.T)
    return xs, Ps


def _filtered(rng, n, dt=1 / 30):
    """A Kalman filter's states, and its predictions into each, along a noisy constant-velocity path."""
    F, Q, b = motion_model(dt, 30.0, None)
    R = np.eye(3) * 0.01**2
    x, P = np.zeros(6), np.eye(6)
    xf, Pf, xp, Pp = [], [], [], []
    for k in range(n):
        x, P = track_kernels.kalman_predict(x, P, F, Q, b)
        xp.append(x)
        Pp.append(P)
        x, P = track_kernels.kalman_correct(x, P, np.array([k * dt, 0.0, 2.0]) + rng.normal(0, 0.01, 3), R)
        xf.append(x)
        Pf.append(P)
    return np.array(xf), np.array(Pf), np.array(xp), np.array(Pp), np.repeat(F[None], n, axis=0)


def test_the_smoother_matches_the_textbook_recursion_and_starts_over_past_a_break():
    rng = np.random.default_rng(11)
    xf, Pf, xp, Pp, F = _filtered(rng, 8)
    xs, Ps = track_kernels.rts_oldest(xf, Pf, xp, Pp, F, np.ones(8, bool))
    ref_x, ref_P = _rts_reference(xf, Pf, xp, Pp, F)
    assert np.allclose(xs, ref_x[0]) and np.allclose(Ps, ref_P[0])
    assert not np.allclose(xs, xf[0]), "the later states moved it"
    linked = np.ones(8, bool)
    linked[4] = False  # the state was set anew at the fifth: the first four are smoothed among themselves
    xs, Ps = track_kernels.rts_oldest(xf, Pf, xp, Pp, F, linked)
    ref_x, ref_P = _rts_reference(xf[:4], Pf[:4], xp[:4], Pp[:4], F[:4])
    assert np.allclose(xs, ref_x[0]) and np.allclose(Ps, ref_P[0])


def test_the_filter_history_grows_and_drops_its_oldest_keeping_order():
    history = FilterHistory(capacity=2)
    rng = np.random.default_rng(3)
    states = [
        (
            k / 30,
            rng.normal(size=6),
            np.eye(6) * (k + 1),
            None if k == 2 else (rng.normal(size=6), np.eye(6), np.eye(6)),
            k != 3,
            k % 2 == 0,
        )
        for k in range(7)
    ]
    for state in states:
        history.append(*state)
    history.drop_oldest()
    assert len(history) == 6 and history.oldest() == (1 / 30, True)
    assert np.array_equal(history.x[:6], [s[1] for s in states[1:]])
    assert list(history.linked[:6]) == [True, False, True, True, True, True]
    assert list(history.kept[:6]) == [True, True, False, True, True, True]
    assert list(history.hit[:6]) == [False, True, False, True, False, True]


def test_restating_the_newest_state_keeps_its_position_and_opens_its_velocity():
    """A two-point start learns the velocity only at its second hit: the first frame's state keeps where it was seen,
    as uncertain as the start says, and its velocity is open up to the top speed (no sharper than it was known)."""
    history = FilterHistory(capacity=2)
    rng = np.random.default_rng(5)
    older, newest = rng.normal(size=6), rng.normal(size=6)
    history.append(0.0, older, np.eye(6), None, True, True)
    history.append(1 / 30, newest, np.eye(6) * 2, None, True, True)
    cov = np.diag([0.01, 0.04, 0.02])
    x, P = history.restate_newest(cov, 12.0)
    assert np.array_equal(x[:3], newest[:3]) and not x[3:].any()
    assert np.array_equal(P[:3, :3], cov) and np.array_equal(P[3:, 3:], np.eye(3) * 144.0) and not P[:3, 3:].any()
    assert np.array_equal(history.x[1], x) and np.array_equal(history.P[1], P) and np.array_equal(history.x[0], older)
    x[0] = 99.0  # a copy: the caller's prediction does not write into the history
    assert history.x[1, 0] != 99.0


def test_a_gap_is_filled_only_where_sharp_and_apart_from_another_tracks_ball():
    """hindsight_fills: a frame a track missed, its ball met since, is filled where its smoothed state is within
    FILL_RADII ball radii (one sigma) and no other track of its colour held a ball within FILL_APART radii then; a frame
    that is no gap is not filled, and without the target's radius nothing is filled."""
    r, here = 0.03, np.array([0.0, 0.0, 2.0])
    sharp, vague = np.eye(3) * (0.9 * FILL_RADII * r) ** 2, np.diag([1e-6, 1e-6, (1.1 * FILL_RADII * r) ** 2])
    beside = here + [1.1 * FILL_APART * r, 0.0, 0.0]
    near = here + [0.9 * FILL_APART * r, 0.0, 0.0]

    def fills(revisions, targets=("red", "red"), radius=None):
        return [[f for *_, f in track] for track in hindsight_fills(revisions, list(targets), {"red": r} if radius is None else radius)]

    assert fills([[(0.1, here, sharp, True), (0.2, here, vague, True), (0.3, here, sharp, False)], []]) == [[True, False, False], []]
    assert fills([[(0.1, here, sharp, True)], [(0.1, beside, sharp, False)]]) == [[True], [False]]
    assert fills([[(0.1, here, sharp, True)], [(0.1, near, sharp, False)]]) == [[False], [False]]
    assert fills([[(0.1, here, sharp, True)], [(0.1, near, sharp, False)]], targets=("red", "blue")) == [[True], [False]]
    assert fills([[(0.1, here, sharp, True)], [(0.2, near, sharp, False)]]) == [[True], [False]], "another frame's ball"
    assert fills([[(0.1, here, sharp, True)], []], radius={}) == [[False], []]


def test_a_revision_is_a_gap_where_the_track_missed_and_has_met_its_ball_since():
    """FilterHistory.revise_until marks a frame a gap when the track met no object there and has met one at a later
    frame still in the history: not a frame it was seen in, nor a miss with no hit after it (a ball gone)."""
    history = FilterHistory()
    F = np.eye(6)
    hits = [True, False, False, True, False, False]
    for k, hit in enumerate(hits):
        history.append(k / 30, np.full(6, float(k)), np.eye(6), (np.full(6, float(k)), np.eye(6) * 2, F) if k else None, True, hit)
    early = history.revise_until(2.5 / 30, True)  # frames 0, 1, 2: frame 3 met the ball since
    assert [gap for *_, gap in early] == [False, True, True]
    late = history.revise_until(4.5 / 30, True)  # frames 3 and 4: 4 missed, and nothing met since
    assert [gap for *_, gap in late] == [False, False]
