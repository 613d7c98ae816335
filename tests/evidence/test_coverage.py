"""A streak's centre from how much of each pixel its ball covered, not from where a colour range cuts its faint ends."""

import cv2
import numpy as np
from scene_helpers import RADIUS, default_rig

from stereotrack.config import Target
from stereotrack.evidence.blobs import find_blobs
from stereotrack.evidence.colour import camera_masks
from stereotrack.evidence.coverage import coverage_centres
from stereotrack.evidence.gather import CameraEvidence, Faint
from stereotrack.evidence.motion import halved

ORANGE = (30, 120, 240)  # BGR: hue 13
BRIGHT = (200, 200, 200)  # the ball's mixtures with a bright wall turn pale sooner (out of the range) ...
DARK = (60, 60, 60)  # ... than with a dark one; the ball differs from them by 290 and 270 grey levels in all
TARGET = Target("orange", (3, 80, 80), (23, 255, 255), RADIUS)


def _streak(start=(114.0, 80.0), end=(126.0, 80.0), radius=3.0, split=120, seed=3, bright=BRIGHT):
    """A ball of ``radius`` pixels swept from ``start`` to ``end`` over the exposure (64 sub-frames, each drawn 8 times
    finer and averaged down), over a wall ``bright`` left of x = ``split`` and dark right of it; and the wall alone."""
    rng = np.random.default_rng(seed)
    h, w, fine = 160, 240, 8
    wall = np.zeros((h, w, 3), np.float64)
    wall[:, :split] = bright
    wall[:, split:] = DARK
    image = np.zeros_like(wall)
    for t in (np.arange(64) + 0.5) / 64:
        u, v = np.add(start, t * np.subtract(end, start))
        disc = np.zeros((h * fine, w * fine), np.uint8)
        cv2.circle(disc, (int(round((u + 0.5) * fine - 0.5)), int(round((v + 0.5) * fine - 0.5))), int(round(radius * fine)), 1, -1)
        share = cv2.resize(disc.astype(np.float64), (w, h), interpolation=cv2.INTER_AREA)[..., None]
        image += share * np.array(ORANGE) + (1 - share) * wall
    image /= 64
    noisy = lambda a: np.clip(a + rng.normal(0, 1.5, a.shape), 0, 255).astype(np.uint8)  # noqa: E731
    return noisy(image), noisy(wall)


def _blobs(image):
    mask = camera_masks("cam", image, (TARGET,), integrals=False).masks["orange"]
    blobs = find_blobs(mask, "components", 6)
    assert len(blobs) == 1
    return blobs


def test_a_streak_centre_is_its_ball_mean_position_where_the_range_cuts_one_end_shorter():
    """Over the dark wall the streak's faint end stays saturated and in range; over the bright one it turns pale and
    leaves it: the mask's centroid falls towards the dark end, the change's stays on the ball's mean position (120, 80)."""
    image, wall = _streak()
    blobs = _blobs(image)
    mask_error = blobs.centres[0] - (120.0, 80.0)
    assert mask_error[0] > 0.6  # the bias this is for: 0.6 px of disparity is 0.35 m at 12 m (fast_ball)
    centre = coverage_centres(blobs, np.array([0]), halved(image), halved(wall))[0]
    assert np.abs(centre - (120.0, 80.0)).max() < 0.25


def test_a_wide_streak_centre_is_measured_too():
    """A near ball's streak, 9 pixels wide: the range cuts its end over the paler wall (170 grey) 1.4-1.7 pixels short,
    its change along the ball's colour puts it within 0.6 of its mean position (fast_ball tune seeds 0-79, streaks over
    8 pixels wide: median error 0.30 -> 0.19 pixels). Before, only streaks under 8 pixels wide were measured."""
    for seed in (0, 1):
        image, wall = _streak(start=(112.0, 80.0), end=(128.0, 80.0), radius=4.5, seed=seed, bright=(170, 170, 170))
        blobs = _blobs(image)
        assert blobs.axes[0, 1] > 4.0  # half its width
        assert blobs.centres[0, 0] - 120.0 > 1.0
        centre = coverage_centres(blobs, np.array([0]), halved(image), halved(wall))[0]
        assert np.abs(centre - (120.0, 80.0)).max() < 0.6


def test_the_centre_is_unmeasured_where_nothing_changed_or_something_else_changed_beside_the_streak():
    image, wall = _streak(split=240)  # all bright
    blobs = _blobs(image)
    ids = np.array([0])
    assert np.abs(coverage_centres(blobs, ids, halved(image), halved(wall))[0] - (120.0, 80.0)).max() < 0.25
    assert np.isnan(coverage_centres(blobs, ids, halved(image), halved(image))).all()  # no change: nothing to measure
    beside = image.copy()
    beside[84:88, 124:134] = (255, 0, 0)  # a blue bar moved in just under the streak's right end
    assert np.isnan(coverage_centres(blobs, ids, halved(beside), halved(wall))).all()


def test_camera_evidence_takes_the_changes_centre_with_a_background_and_the_masks_without():
    image, wall = _streak()
    cam = default_rig(240, 160).cameras[0]
    mask = camera_masks("cam", image, (TARGET,), integrals=False).masks["orange"]
    faint = Faint(np.zeros((80, 120), np.uint8), halved(image), halved(wall), np.zeros(7, np.int64))
    with_background = CameraEvidence.from_mask(cam, mask, faint=faint)
    without = CameraEvidence.from_mask(cam, mask)
    ids = np.array([0])
    assert np.abs(with_background.streak_centres(ids)[0] - (120.0, 80.0)).max() < 0.25
    assert np.array_equal(without.streak_centres(ids), without.blobs.centres[ids])


def test_a_blob_with_unmeasured_moments_keeps_its_mask_centroid():
    image, wall = _streak()
    blobs = _blobs(image)
    blobs.axes[0] = np.nan  # (a blob whose moments could not be measured)
    assert np.isnan(coverage_centres(blobs, np.array([0]), halved(image), halved(wall))).all()
