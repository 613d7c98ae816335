"""A white ball's crowded shading patch is kept where another camera shows the same ball (evidence/stereo_patches.py)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from scene_helpers import RADIUS, default_rig

from stereotrack.evidence.stereo_patches import paired

SCALE = 2  # the background's grid: every cell is 2 x 2 pixels


def _draw(maps, cam_index, cam, point, radius=RADIUS, shift=(0.0, 0.0)):
    """Draws into ``maps[cam_index]`` (on the background's grid) the disc a ball of ``radius`` at ``point`` shows
    ``cam``, moved by ``shift`` pixels; returns its centre on that grid."""
    uv, front, depth = cam.view(np.asarray(point, float)[None])
    r = cam.apparent_radius(radius, depth[0]) / SCALE
    centre = (uv[0] + shift - 0.5 * (SCALE - 1)) / SCALE
    cv2.circle(maps[cam_index], tuple(int(round(c)) for c in centre), max(int(round(r)), 1), 1, -1)
    return centre


def _empty(rig):
    return [np.zeros((cam.height // SCALE, cam.width // SCALE), np.uint8) for cam in rig.cameras]


def _kept(found, centre):
    x, y = (int(round(c)) for c in centre)
    return bool(found[y, x])


@pytest.mark.parametrize("partner", ["crowded", "alone"])
def test_a_crowded_patch_is_kept_where_the_other_camera_shows_the_same_ball(partner):
    """Two balls at rest 1.5-2.5 m away, each a crowded patch in camera 0. The first has its partner in camera 1 (crowded
    there too, or alone and kept already): both are kept. The second has none, and stays out."""
    rig = default_rig()
    crowded, alone = _empty(rig), _empty(rig)
    near, far = np.array([0.2, 1.5, 0.1]), np.array([-0.3, 2.5, -0.2])
    a0 = _draw(crowded, 0, rig.cameras[0], near)
    a1 = _draw(crowded if partner == "crowded" else alone, 1, rig.cameras[1], near)
    b0 = _draw(crowded, 0, rig.cameras[0], far)
    found = paired(crowded, alone, rig.cameras, RADIUS, 0.3, 6.0, SCALE)
    assert _kept(found[0], a0) and not _kept(found[0], b0)
    assert _kept(found[1], a1) == (partner == "crowded")  # an alone patch is in the map already
    assert found[1].sum() == (crowded[1].sum() if partner == "crowded" else 0)


@pytest.mark.parametrize(
    "what",
    ["off its epipolar line", "twice as wide as a ball there", "half as wide", "nearer than d_min"],
)
def test_a_pair_that_is_not_one_ball_is_not_kept(what):
    """Patches in the two views that are not one ball of the target's size in range stay out: one 8 pixels off the
    other's epipolar line (the cameras sit side by side: rows apart; the ball is 11 pixels in radius), one of a ball twice or half the target's radius
    (their depth from the views disagrees with their width), a pair whose depth is under d_min."""
    rig = default_rig()
    crowded, alone = _empty(rig), _empty(rig)
    point = np.array([0.1, 1.8, 0.0])
    radius = {"twice as wide as a ball there": 2 * RADIUS, "half as wide": 0.5 * RADIUS}.get(what, RADIUS)
    shift = np.array([0.0, 8.0]) if what == "off its epipolar line" else np.zeros(2)
    _draw(crowded, 0, rig.cameras[0], point, radius)
    _draw(crowded, 1, rig.cameras[1], point, radius, shift)
    d_min = 2.0 if what == "nearer than d_min" else 0.3
    found = paired(crowded, alone, rig.cameras, RADIUS, d_min, 6.0, SCALE)
    assert found[0].sum() == 0 and found[1].sum() == 0
    # ... and the same pair drawn as one ball of the target's size, in range, is kept
    crowded = _empty(rig)
    c0, c1 = _draw(crowded, 0, rig.cameras[0], point), _draw(crowded, 1, rig.cameras[1], point)
    found = paired(crowded, alone, rig.cameras, RADIUS, 0.3, 6.0, SCALE)
    assert _kept(found[0], c0) and _kept(found[1], c1)


def test_two_patches_kept_already_are_not_given_again_and_nothing_gives_nothing():
    """Patches alone in both views are the shading map's already: pairing them adds nothing. No patches: empty maps."""
    rig = default_rig()
    crowded, alone = _empty(rig), _empty(rig)
    point = np.array([0.0, 1.6, 0.05])
    _draw(alone, 0, rig.cameras[0], point), _draw(alone, 1, rig.cameras[1], point)
    found = paired(crowded, alone, rig.cameras, RADIUS, 0.3, 6.0, SCALE)
    assert all(f.shape == c.shape and f.dtype == np.uint8 and f.sum() == 0 for f, c in zip(found, crowded))


@pytest.mark.parametrize("on_a_surface", [True, False])
def test_a_pair_judged_a_patch_of_the_surface_it_is_seen_on_is_not_kept(on_a_surface):
    """Two views agree on any real thing, a pale piece of a poster too: a pair that ``scenery`` (the tracker asks
    objects/surface.py) judges a patch of the surface it is seen on stays out. It is asked about the point the pair
    gives, within half a radius of the ball's centre (the discs are drawn to a cell)."""
    rig = default_rig()
    crowded, alone = _empty(rig), _empty(rig)
    point = np.array([-0.2, 2.0, 0.15])
    c0, c1 = _draw(crowded, 0, rig.cameras[0], point), _draw(crowded, 1, rig.cameras[1], point)
    asked = []
    found = paired(crowded, alone, rig.cameras, RADIUS, 0.3, 6.0, SCALE, lambda p: asked.append(p) or on_a_surface)
    assert len(asked) == 1 and np.linalg.norm(asked[0] - point) < 0.5 * RADIUS
    assert _kept(found[0], c0) != on_a_surface and _kept(found[1], c1) != on_a_surface
