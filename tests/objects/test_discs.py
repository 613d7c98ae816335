import numpy as np
from scene_helpers import RADIUS, default_rig, disc_masks

from stereotrack.evidence.blobs import find_blobs
from stereotrack.objects.discs import depth_on_ray, union_mismatch


def scene(lateral: float):
    """Ball A 1 m ahead; ball B 1.5 m along cam1's ray through A, ``lateral`` metres above it: one blob in
    cam1 (B partly or wholly behind A), two blobs in cam0."""
    rig = default_rig()
    c1 = rig.cameras[1]
    a = np.array([0.0, 1.0, 0.0])
    ray = (a - c1.centre) / np.linalg.norm(a - c1.centre)
    b = c1.centre + 1.5 * ray + np.array([0.0, 0.0, lateral])
    masks, _ = disc_masks(rig, np.array([a, b]))
    blobs = [find_blobs(m) for m in masks]
    assert [len(x) for x in blobs] == [2, 1]
    return rig, blobs, a, b


def cam0_ray(rig, blobs, point):
    """cam0's ray through the blob that ``point`` projects into, and the point's true depth along it."""
    c0 = rig.cameras[0]
    uv, _ = c0.project(point[None])
    k = int(np.argmin(np.linalg.norm(blobs[0].centres - uv, axis=1)))
    o, d = c0.rays(blobs[0].centres[k][None])
    return o[0], d[0], float((point - o[0]) @ d[0])


def mismatch_along_cam0_ray(lateral: float, below: float, above: float, n: int):
    """Ball B placed at depths along cam0's ray through it, against A's disc in cam1's shared blob:
    (depths, mismatch, B's true depth, B's disc area in cam1)."""
    rig, blobs, a, b = scene(lateral)
    o, d, true_depth = cam0_ray(rig, blobs, b)
    depths = np.linspace(true_depth - below, true_depth + above, n)
    mismatch = union_mismatch(rig.cameras[1], blobs[1], 0, o + depths[:, None] * d, a[None], RADIUS)
    area = np.pi * (rig.cameras[1].K[0, 0] * RADIUS / 1.5) ** 2
    return depths, mismatch, true_depth, area


def test_the_shared_blob_is_best_made_up_at_the_true_depth():
    depths, mismatch, true_depth, _ = mismatch_along_cam0_ray(0.03, 0.3, 0.3, 61)
    assert abs(depths[np.argmin(mismatch)] - true_depth) <= 0.015  # the label grid is 2 px: 1.4 cm at 1.5 m
    # 20 cm off the true depth the union leaves much of the blob unexplained or spills over it.
    far = np.abs(depths - true_depth) > 0.2
    assert mismatch[far].min() > mismatch.min() + 100


def test_a_partly_hidden_ball_is_placed_by_its_visible_part_whatever_the_prior():
    depths, mismatch, true_depth, area = mismatch_along_cam0_ray(0.03, 0.35, 0.25, 41)
    for prior in (true_depth - 0.1, true_depth + 0.1):  # the particles' mean, pulled towards A or away
        fit = depth_on_ray(mismatch, depths, prior, 0.12, 0.05 * area)
        assert abs(fit.depth - true_depth) < 0.025  # a quarter of the prior's error, or less
        assert fit.sigma < 0.04  # the particles alone: 0.12


def test_a_wholly_hidden_ball_keeps_the_prior_and_says_the_blob_knew_little():
    depths, mismatch, true_depth, area = mismatch_along_cam0_ray(0.0, 0.3, 0.3, 41)
    prior = true_depth + 0.04
    fit = depth_on_ray(mismatch, depths, prior, 0.12, 0.05 * area)
    assert abs(fit.depth - prior) < 0.03  # anywhere behind A fits: the prior decides
    assert fit.sigma > 0.05


def test_candidates_behind_the_camera_cannot_fit():
    rig, blobs, a, b = scene(lateral=0.03)
    c1 = rig.cameras[1]
    behind = c1.centre - 0.5 * (a - c1.centre)
    mismatch = union_mismatch(c1, blobs[1], 0, np.array([behind, b]), a[None], RADIUS)
    assert np.isinf(mismatch[0]) and np.isfinite(mismatch[1])
    assert depth_on_ray(np.array([np.inf, np.inf]), np.array([1.0, 2.0]), 1.5, 0.1, 10.0) is None
