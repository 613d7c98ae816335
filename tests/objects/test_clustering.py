import numpy as np
from scene_helpers import RADIUS, default_rig

from stereotrack.objects.clustering import ClusterSettings, cluster_particles
from stereotrack.particles.resampling import systematic_indices


def ball_cloud(rng, centre, n, rig):
    """Particles the way a ball's likelihood plateau spreads them: tight across, longer along the viewing direction."""
    view = centre / np.linalg.norm(centre)
    pts = rng.normal(0, RADIUS / 3, (n, 3)) + np.outer(rng.normal(0, RADIUS, n), view)
    return centre + pts


def test_two_balls_ten_cm_apart_are_split():
    rng = np.random.default_rng(0)
    rig = default_rig()
    a, b = np.array([0.0, 1.5, 0.0]), np.array([0.1, 1.5, 0.0])
    X = np.vstack([ball_cloud(rng, a, 400, rig), ball_cloud(rng, b, 400, rig)])
    w = np.full(len(X), 1 / len(X))
    cl = cluster_particles(X, w, np.ones(len(X)), rig.cameras, ClusterSettings(radius=RADIUS))
    assert len(cl.means) == 2
    got = cl.means[np.argsort(cl.means[:, 0])]
    assert np.abs(got - np.array([a, b])).max() < 0.01
    assert np.allclose(cl.masses.sum(), 1.0) and (cl.labels >= 0).all()


def test_one_ball_is_one_cluster_even_from_three_seeds():
    rng = np.random.default_rng(1)
    rig = default_rig()
    c = np.array([0.2, 1.2, 0.1])
    X = ball_cloud(rng, c, 800, rig)
    w = rng.random(len(X))
    w /= w.sum()
    prev = c + np.array([[0.02, 0, 0], [-0.02, 0.01, 0], [0, 0, 0.02]])
    cl = cluster_particles(X, w, np.ones(len(X)), rig.cameras, ClusterSettings(radius=RADIUS), prev_means=prev)
    assert len(cl.means) == 1
    assert np.linalg.norm(cl.means[0] - c) < 0.01


def test_low_likelihood_and_light_clusters_are_discarded():
    rng = np.random.default_rng(2)
    rig = default_rig()
    X = np.vstack([ball_cloud(rng, np.array([0.0, 1.5, 0.0]), 500, rig), rng.uniform(-1, 1, (500, 3)) + [0, 2, 0]])
    lik = np.r_[np.ones(500), np.full(500, 0.001)]  # the uniform junk has floor likelihood
    w = lik / lik.sum()
    cl = cluster_particles(X, w, lik, rig.cameras, ClusterSettings(radius=RADIUS))
    assert len(cl.means) == 1 and (cl.labels[500:] == -1).all()


def test_systematic_resampling_is_proportional():
    rng = np.random.default_rng(3)
    w = np.array([0.5, 0.25, 0.125, 0.125])
    idx = systematic_indices(w, 800, rng)
    assert list(np.bincount(idx, minlength=4)) == [400, 200, 100, 100]


def test_compiled_log_gauss_matches_the_textbook_formula():
    from stereotrack.objects.kernels import log_gauss

    rng = np.random.default_rng(3)
    X = rng.normal([0.1, 1.5, -0.2], 0.2, (300, 3))
    means = rng.normal([0.1, 1.5, -0.2], 0.1, (5, 3))
    A = rng.normal(0, 0.03, (5, 3, 3))
    covs = A @ A.transpose(0, 2, 1) + np.eye(3) * 1e-4  # ball-sized, some long and thin
    pis = np.array([0.1, 0.2, 0.3, 0.25, 0.15])
    got = log_gauss(X, means, covs, pis)
    for k in range(5):
        d = X - means[k]
        maha = np.einsum("ni,ij,nj->n", d, np.linalg.inv(covs[k]), d)
        want = np.log(pis[k]) - 0.5 * (maha + np.log(np.linalg.det(covs[k])) + 3 * np.log(2 * np.pi))
        assert np.allclose(got[:, k], want, rtol=1e-9, atol=1e-6)


def test_the_settings_table_says_the_mass_floor_of_em_s_subsample():
    """cluster_min_particles' line names the subsample's size and the mass floor it sets (a user lowering
    cluster_min_mass under it sees no change): kept true when EM_POINTS or the default changes."""
    from dataclasses import fields

    from stereotrack.config import TrackerSettings
    from stereotrack.objects.clustering import EM_POINTS

    (field,) = [f for f in fields(TrackerSettings) if f.name == "cluster_min_particles"]
    assert f"{EM_POINTS}-particle subsample" in field.metadata["doc"]
    assert f"under {field.default / EM_POINTS:.3f} of the weight at {field.default}" in field.metadata["doc"]
