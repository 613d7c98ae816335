import cv2
import numpy as np
import pytest
from scene_helpers import RADIUS, default_rig, disc_masks, evidence

from stereotrack.camera import Camera, intrinsics_from_fov, look_at
from stereotrack.evidence.blobs import find_blobs
from stereotrack.particles.proposal import depth_range_from_size, particles_on_rays, ray_crossings


def disc_mask(centres, radius, shape=(480, 640)):
    m = np.zeros(shape, np.uint8)
    for c in centres:
        cv2.circle(m, (int(round(c[0])), int(round(c[1]))), radius, 1, -1)
    return m


def test_components_find_each_disc():
    centres = [(100, 100), (300, 100), (100, 300)]  # share a row and a column
    blobs = find_blobs(disc_mask(centres, 10), "components", 6)
    assert len(blobs) == 3
    got = sorted(map(tuple, np.round(blobs.centres).astype(int)))
    assert got == sorted(centres)
    assert np.allclose(blobs.radii, 10.5, atol=1)


def test_histogram_maxima_find_discs_and_drop_empty_ghosts():
    centres = [(100, 100), (300, 100), (100, 300)]
    blobs = find_blobs(disc_mask(centres, 10), "histogram", 6)
    got = {tuple(c) for c in np.round(blobs.centres).astype(int)}
    for c in centres:
        assert any(abs(g[0] - c[0]) <= 1 and abs(g[1] - c[1]) <= 1 for g in got)
    assert len(blobs) == 3  # the (300, 300) ghost has no colour and is dropped


def test_rays_from_blobs_pass_through_the_ball():
    K = intrinsics_from_fov(640, 480, 60)
    R, t = look_at((-0.15, 0, 0), (0, 0, 1.5))
    cam = Camera("cam0", (640, 480), K, np.zeros(5), R, t)
    balls = np.array([[0.1, 0.05, 1.2], [-0.3, -0.1, 2.0]])
    radius = 0.035
    uv, _ = cam.project(balls)
    r_px = [int(round(K[0, 0] * radius / cam.depth(balls)[i])) for i in range(2)]
    mask = disc_mask(uv[:1], r_px[0]) | disc_mask(uv[1:], r_px[1])
    blobs = find_blobs(mask, "components", 6)
    o, d = cam.rays(blobs.centres)
    near, far = depth_range_from_size(cam, blobs.radii, radius, 0.2, 5.0)
    for ball in balls:
        v = ball - o
        dist = np.linalg.norm(v - (v * d).sum(1, keepdims=True) * d, axis=1)
        i = int(np.argmin(dist))
        assert dist[i] < 0.005  # the ray passes within 5 mm of the ball centre
        along = float(v[i] @ d[i])
        assert near[i] < along < far[i]  # the size-based range keeps the true distance
    rng = np.random.default_rng(0)
    pts, ray = particles_on_rays(o, d, near, far, 1001, rng)
    assert len(pts) == 1001 and abs(np.bincount(ray)[0] - np.bincount(ray)[1]) <= 1


def test_ray_crossings_find_each_ball_and_skip_blobs_of_the_wrong_size():
    rig = default_rig()
    balls = np.array([[-0.2, 1.2, 0.1], [0.1, 1.6, -0.1], [0.3, 2.2, 0.1]])  # apart in both views
    masks, _ = disc_masks(rig, balls)
    crossings = ray_crossings(evidence(rig, masks), RADIUS, 0.2, 5.0)
    for ball in balls:
        assert np.linalg.norm(crossings - ball, axis=1).min() < 0.01
    assert len(crossings) < 9  # fewer than every pair: ghosts off the epipolar lines or of the wrong size are gone
    # The same three balls drawn five times too large (a poster, not a ball at that depth): no crossing.
    posters, _ = disc_masks(rig, balls, radius=5 * RADIUS)
    assert len(ray_crossings(evidence(rig, posters), RADIUS, 0.2, 5.0)) == 0


def test_crossings_skip_the_blob_a_tracked_ball_holds_when_seeds_are_fewer_than_blobs(monkeypatch):
    """The held flags go to the blobs the crossings are made from, not to the seeds (a subset of them when
    only ball-like or moving blobs seed): a flag shifted onto another blob kept the tracked ball's crossing,
    and the kernel read flags past the short array (garbage memory: runs of one recording differed)."""
    from dataclasses import replace

    from scene_helpers import balls_at

    from stereotrack.config import TrackerSettings
    from stereotrack.evidence.gather import Seeds
    from stereotrack.particles import proposal

    rig = default_rig()
    balls = np.array([[-0.2, 1.2, 0.1], [0.1, 1.6, -0.1], [0.3, 2.2, 0.1]])
    masks, _ = disc_masks(rig, balls)
    views = []
    for v in evidence(rig, masks):
        assert len(v.blobs) == 3
        first = int(np.argmin(v.blobs.centres[:, 1] * 1e4 + v.blobs.centres[:, 0]))  # leave out one blob: seeds are a subset
        keep = np.arange(3) != first
        views.append(replace(v, seeds=Seeds(v.blobs.centres[keep], v.blobs.radii[keep], v.origins[keep], v.directions[keep])))
    # the tracked ball: one whose blob is a seed in both views
    uv = [cam.project(balls)[0] for cam in rig.cameras]
    seeded = [i for i in range(3) if all(np.linalg.norm(u[i] - v.seeds.centres, axis=1).min() < 1 for u, v in zip(uv, views))]
    assert seeded
    tracked = seeded[0]
    made = []

    def spy(*args, **kwargs):
        made.append(ray_crossings(*args, **kwargs))
        return made[-1]

    monkeypatch.setattr(proposal, "ray_crossings", spy)
    rp = proposal.RayProposal(TrackerSettings(), RADIUS)
    rp(views, 400, balls_at(balls[tracked : tracked + 1]), np.random.default_rng(0))
    crossings = made[-1]
    assert np.linalg.norm(crossings - balls[tracked], axis=1).min(initial=np.inf) > 0.01  # the tracked ball's blobs make none
    for i in range(3):
        if i != tracked:  # every untracked ball's blobs still cross
            assert np.linalg.norm(crossings - balls[i], axis=1).min() < 0.01


def test_ray_crossings_refuse_skip_flags_that_are_not_one_per_blob():
    rig = default_rig()
    masks, _ = disc_masks(rig, np.array([[-0.2, 1.2, 0.1], [0.1, 1.6, -0.1]]))
    views = evidence(rig, masks)
    with pytest.raises(ValueError, match="one flag per blob"):
        ray_crossings(views, RADIUS, 0.2, 5.0, [np.zeros(1, bool), np.zeros(2, bool)])
