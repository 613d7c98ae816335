import cv2
import numpy as np
import pytest

from stereotrack.config import Target
from stereotrack.errors import StereotrackError
from stereotrack.evidence.colour import box_counts, camera_masks, integral_image, learn_target, target_mask, to_hsv


def hsv_image(h, s, v, shape=(4, 4)):
    img = np.zeros(shape + (3,), np.uint8)
    img[...] = (h, s, v)
    return img


def test_mask_plain_and_wrapping_hue():
    pink = Target("pink", (140, 60, 50), (175, 255, 255))
    red = Target("red", (170, 80, 50), (8, 255, 255))
    assert target_mask(hsv_image(160, 200, 200), pink).all()
    assert not target_mask(hsv_image(100, 200, 200), pink).any()
    assert not target_mask(hsv_image(160, 20, 200), pink).any()  # too grey
    for h in (175, 179, 0, 5):
        assert target_mask(hsv_image(h, 200, 200), red).all(), h
    for h in (20, 100, 160):
        assert not target_mask(hsv_image(h, 200, 200), red).any(), h
    assert target_mask(hsv_image(175, 200, 200), red).max() == 1  # a 0/1 mask, not 0/255


def test_camera_masks_integral_counts_pixels():
    img = np.full((30, 40, 3), 128, np.uint8)
    cv2.circle(img, (20, 15), 6, (180, 60, 255), -1)  # pinkish BGR
    t = Target("pink", (140, 60, 50), (175, 255, 255))
    cm = camera_masks("cam0", img, (t,))
    assert cm.integrals["pink"][-1, -1] == cm.masks["pink"].sum() > 80


@pytest.mark.parametrize("bgr", [(180, 60, 255), (30, 30, 220), (40, 140, 255)])
def test_learn_target_covers_ball_not_background(bgr):
    rng = np.random.default_rng(4)
    img = rng.integers(90, 170, (120, 160, 1), dtype=np.uint8).repeat(3, axis=2)  # grey texture
    ball = np.zeros((120, 160), np.uint8)
    cv2.circle(ball, (80, 60), 15, 1, -1)
    shade = np.clip(rng.normal(1.0, 0.12, (120, 160)), 0.6, 1.2)[..., None]
    coloured = np.clip(np.array(bgr, float) * shade, 0, 255).astype(np.uint8)
    img[ball == 1] = coloured[ball == 1]
    learned = learn_target(img, (62, 42, 36, 36), "ball")
    mask = target_mask(to_hsv(img), learned.target)
    assert mask[ball == 1].mean() > 0.95
    assert mask[ball == 0].mean() < 0.01
    assert learned.background_coverage < 0.01


def test_learn_target_rejects_roi_outside_image():
    with pytest.raises(StereotrackError, match="not inside"):
        learn_target(np.zeros((10, 10, 3), np.uint8), (5, 5, 10, 10), "x")


def test_box_counts_are_the_maps_sums_over_boxes_cut_to_the_map():
    rng = np.random.default_rng(5)
    mask = (rng.random((30, 40)) < 0.3).astype(np.uint8)
    table = integral_image(mask)
    x0, y0 = rng.integers(-5, 40, 50), rng.integers(-5, 30, 50)
    x1, y1 = x0 + rng.integers(0, 20, 50), y0 + rng.integers(0, 20, 50)
    want = [int(mask[max(b, 0) : max(d, 0), max(a, 0) : max(c, 0)].sum()) for a, b, c, d in zip(x0, y0, x1, y1)]
    assert box_counts(table, x0, y0, x1, y1).tolist() == want
    assert box_counts(table, 2.7, 3.2, 9.9, 8.0) == mask[3:8, 2:9].sum()  # pixel coordinates taken towards zero
