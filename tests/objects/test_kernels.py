"""The object stage's compiled kernels against plain numpy versions of the same arithmetic."""

import numpy as np
import pytest
from scene_helpers import RADIUS, default_rig

from stereotrack.camera import stacked_kernel_arrays
from stereotrack.objects import kernels as object_kernels


def test_weighted_em_counts_a_weight_as_repeated_points():
    rng = np.random.default_rng(0)
    X = np.vstack([rng.normal([0, 1.5, 0], 0.02, (40, 3)), rng.normal([0.1, 1.6, 0], 0.02, (40, 3))])
    reps = rng.integers(1, 4, len(X))
    means0 = np.array([[0.01, 1.5, 0.0], [0.09, 1.6, 0.0]])
    covs0 = np.repeat(np.eye(3)[None] * 1e-3, 2, axis=0)
    a = object_kernels.weighted_em(X, reps.astype(float), means0, covs0, 3, 1e-6)
    b = object_kernels.weighted_em(np.repeat(X, reps, axis=0), np.ones(reps.sum()), means0, covs0, 3, 1e-6)
    for x, y in zip(a[:3], b[:3]):
        assert np.allclose(x, y, rtol=1e-9, atol=1e-12)


def test_weighted_moments_and_hard_labels_match_numpy():
    rng = np.random.default_rng(1)
    X = rng.normal(0, 1, (200, 3))
    rw = rng.random((200, 3))
    mass, means, covs = object_kernels.weighted_moments(X, rw)
    for k in range(3):
        assert mass[k] == pytest.approx(rw[:, k].sum())
        assert np.allclose(means[k], np.average(X, axis=0, weights=rw[:, k]))
        assert np.allclose(covs[k], np.cov(X.T, aweights=rw[:, k], bias=True))
    pis = np.array([0.2, 0.3, 0.5])
    assert np.array_equal(object_kernels.hard_labels(X, means, covs, pis), object_kernels.log_gauss(X, means, covs, pis).argmax(axis=1))


def test_blob_at_takes_the_label_else_the_nearest_blob_within_reach():
    labels = np.zeros((10, 10), np.int32)
    labels[2:4, 2:4] = 1
    label_blob = np.array([-1, 0])
    centres = np.array([[5.0, 5.0], [15.0, 15.0]])  # pixels; labels are at scale 2
    radii = np.array([2.0, 2.0])
    uv = np.array([[5.0, 5.0], [12.0, 12.0], [40.0, 40.0], [5.0, 5.0]])
    ok = np.array([True, True, True, False])
    got = object_kernels.blob_at(uv, ok, np.full(4, 3.0), 20, 20, labels, label_blob, 2, True, centres, radii)
    assert list(got) == [0, 1, -1, -1]  # on blob 0's label; 4.2 px from blob 1 (within 3 + 2); far; behind the camera


def test_disc_union_mismatch_counts_cells_like_a_drawn_picture():
    """Against the definition: cells where (candidate disc | other discs) differs from the blob."""
    rng = np.random.default_rng(4)
    labels = np.zeros((40, 50), np.int32)
    yy, xx = np.mgrid[0:40, 0:50]
    labels[(xx - 20) ** 2 + (yy - 18) ** 2 <= 36] = 1
    labels[(xx - 27) ** 2 + (yy - 20) ** 2 <= 25] = 1
    label_blob = np.array([-1, 0])
    box = np.array([14, 12, 33, 26])
    scale, off = 2, 0.5
    gx, gy = xx * scale + off, yy * scale + off
    others_uv, others_r = np.array([[54.5, 40.5]]), np.array([10.0])
    cand_uv = rng.uniform(20, 80, (15, 2))
    cand_r = rng.uniform(5, 15, 15)
    got = object_kernels.disc_union_mismatch(labels, label_blob, 0, box, scale, cand_uv, cand_r, others_uv, others_r)
    covered = (gx - others_uv[0, 0]) ** 2 + (gy - others_uv[0, 1]) ** 2 <= others_r[0] ** 2
    for (u, v), r, g in zip(cand_uv, cand_r, got):
        balls = covered | ((gx - u) ** 2 + (gy - v) ** 2 <= r * r)
        assert g == np.count_nonzero(balls != (labels == 1)) * scale * scale


def test_merge_one_ball_clusters_merges_a_depth_elongated_ball_and_keeps_touching_balls():
    rig = default_rig()
    c0 = rig.cameras[0]
    ball = np.array([0.0, 1.5, 0.0])
    ray = (ball - c0.centre) / np.linalg.norm(ball - c0.centre)
    # Two pieces of one ball's cloud 1.5 R apart along cam0's ray (cam1 sees them a little apart), and a
    # second ball touching the first from the side (2R apart: two balls).
    means = np.array([ball - 0.75 * RADIUS * ray, ball + 0.75 * RADIUS * ray, ball + np.array([2.05 * RADIUS, 0, 0])])
    mass = np.array([0.2, 0.3, 0.5])
    labels = np.array([0, 1, 2, -1, 1])
    kept, out_means, out_mass, out_labels = object_kernels.merge_one_ball_clusters(
        means, mass, labels, RADIUS, *stacked_kernel_arrays(rig.cameras)
    )
    assert list(kept) == [True, False, True]
    assert np.allclose(out_means[0], (0.2 * means[0] + 0.3 * means[1]) / 0.5) and np.allclose(out_mass, [0.5, 0.5])
    assert list(out_labels) == [0, 0, 1, -1, 0]


def test_greedy_seeds_keep_last_frames_objects_and_claim_new_balls():
    rig = default_rig()
    rng = np.random.default_rng(5)
    a, b = np.array([0.0, 1.5, 0.0]), np.array([0.3, 1.2, 0.1])
    X = np.vstack([a + rng.normal(0, 0.01, (60, 3)), b + rng.normal(0, 0.01, (40, 3))])
    w = np.full(100, 0.01)
    views = [c.view(X) for c in rig.cameras]
    uv, ok, z = (np.stack(v) for v in zip(*views))
    f_over_z = np.stack([0.5 * (c.K[0, 0] + c.K[1, 1]) / zc for c, zc in zip(rig.cameras, z)])
    seeds = object_kernels.greedy_seeds(X, w, a[None] + 0.02, RADIUS, 0.05, 12, uv, ok, f_over_z)
    assert len(seeds) == 2  # a (from last frame's object) and b (new), nothing else weighs 0.05
    assert np.linalg.norm(seeds[0] - a) < 0.01 and np.linalg.norm(seeds[1] - b) < 0.01
