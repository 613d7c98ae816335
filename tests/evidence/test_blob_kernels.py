"""The evidence stage's compiled blob kernels (blob_kernels.py) against OpenCV and numpy; the streak ones: test_streaks.py."""

import cv2
import numpy as np

from stereotrack.evidence import blob_kernels as evidence_kernels
from stereotrack.evidence.blobs import STREAK_ELONGATION, STREAK_FILL, streaks


def test_component_boxes_and_mask_moments_match_opencv():
    rng = np.random.default_rng(3)
    mask = (cv2.GaussianBlur(rng.random((120, 160)), (0, 0), 4) > 0.52).astype(np.uint8)
    n, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
    assert n > 3
    area, boxes = evidence_kernels.component_boxes(labels, n)
    assert np.array_equal(area, stats[1:, cv2.CC_STAT_AREA])
    assert np.array_equal(boxes[:, :2], stats[1:, :2]) and np.array_equal(boxes[:, 2:] - boxes[:, :2], stats[1:, 2:4])
    count, centre, size, second = evidence_kernels.mask_moments(mask, boxes, 1)  # scale 1: each box grown by one pixel
    for i, (x0, y0, x1, y1) in enumerate(boxes):
        x0, y0, x1, y1 = max(x0 - 1, 0), max(y0 - 1, 0), min(x1 + 1, 160), min(y1 + 1, 120)
        m = cv2.moments(mask[y0:y1, x0:x1], binaryImage=True)
        assert count[i] == m["m00"]
        assert np.allclose(centre[i], (x0 + m["m10"] / m["m00"], y0 + m["m01"] / m["m00"]))
        assert np.array_equal(size[i], cv2.boundingRect(mask[y0:y1, x0:x1])[2:])
        assert np.allclose(second[i], (m["mu20"] / m["m00"], m["mu02"] / m["m00"], m["mu11"] / m["m00"]))


def test_component_measures_keep_the_blobs_and_measure_them_as_opencv_does():
    """One call: the components at least min_area (label cells x scale^2) are blobs, numbered in label order, their boxes
    moved by the label box's corner, measured on the full mask; semi-axes of the filled ellipse of those moments."""
    rng = np.random.default_rng(5)
    mask = (cv2.GaussianBlur(rng.random((240, 320)), (0, 0), 4) > 0.53).astype(np.uint8)
    small = np.ascontiguousarray(mask[::2, ::2])
    x0, y0 = 10, 6  # labelled inside a box of the subsampled mask
    n, labels, stats, _ = cv2.connectedComponentsWithStats(small[y0:, x0:], connectivity=8)
    label_blob, boxes, count, centre, size, second, axes, radii, swept = evidence_kernels.component_measures(
        mask, labels, n, x0, y0, 2, 24, small.shape[1], small.shape[0], STREAK_ELONGATION, STREAK_FILL * np.pi
    )
    kept = stats[1:, cv2.CC_STAT_AREA] * 4 >= 24
    assert 3 < kept.sum() < n - 1  # some specks left out
    assert np.array_equal(label_blob, np.r_[-1, np.where(kept, np.cumsum(kept) - 1, -1)])
    assert np.array_equal(boxes[:, :2], stats[1:, :2][kept] + (x0, y0))
    assert np.array_equal(boxes[:, 2:] - boxes[:, :2], stats[1:, 2:4][kept])
    c, ce, si, se = evidence_kernels.mask_moments(mask, boxes, 2)
    assert np.array_equal(count, c) and np.array_equal(centre, ce) and np.array_equal(size, si) and np.array_equal(second, se)
    for (xx, yy, xy), (a, b) in zip(second, axes):  # a filled ellipse of semi-axes a, b: variances a^2 / 4, b^2 / 4
        var = np.linalg.eigvalsh([[xx, xy], [xy, yy]])
        assert np.allclose((a * a / 4, b * b / 4), var[::-1], atol=1e-9)
    assert np.array_equal(radii, 0.5 * size.max(axis=1))
    # shaped like a streak (blobs.streaks) with its box away from the label grid's edges
    inside = (boxes[:, 0] > 0) & (boxes[:, 1] > 0) & (boxes[:, 2] < small.shape[1]) & (boxes[:, 3] < small.shape[0])
    assert np.array_equal(swept, streaks(count, axes) & inside)


def test_component_measures_tell_the_streaks_away_from_the_edge():
    lines = np.zeros((100, 120), np.uint8)  # a streak inside, one touching the left edge, a disc
    cv2.line(lines, (20, 20), (80, 40), 1, 7)
    cv2.line(lines, (0, 80), (50, 80), 1, 7)
    cv2.circle(lines, (95, 75), 8, 1, -1)
    n, labels = cv2.connectedComponents(np.ascontiguousarray(lines[::2, ::2]), connectivity=8)
    label_blob, *_, swept = evidence_kernels.component_measures(
        lines, labels, n, 0, 0, 2, 6, 60, 50, STREAK_ELONGATION, STREAK_FILL * np.pi
    )
    first = label_blob[labels[15, 25]], label_blob[labels[40, 10]], label_blob[labels[37, 47]]  # the inner streak, the edge one, the disc
    assert [bool(swept[b]) for b in first] == [True, False, False]


def test_the_subsampled_mask_is_numpys_strided_copy_and_skips_the_rows_said_empty():
    rng = np.random.default_rng(16)
    every = np.zeros(0, np.uint8)
    for (h, w), scale in (((480, 640), 2), ((121, 163), 2), ((7, 9), 3), ((5, 4), 1)):
        mask = (rng.random((h, w)) < 0.3).astype(np.uint8)
        small, labels, x0, y0, x1, y1 = evidence_kernels.subsampled(mask, scale, every)
        assert np.array_equal(small, mask[::scale, ::scale])
        ys, xs = np.nonzero(small)
        assert (x0, y0, x1, y1) == (xs.min() // 2 * 2, ys.min() // 2 * 2, xs.max() + 1, ys.max() + 1)
        assert labels.shape == small.shape and labels.dtype == np.int32
        rows = (rng.random(h) < 0.5).astype(np.uint8)  # rows marked 0 are not read: they come out empty
        masked = mask * rows[:, None]
        small, _, *box = evidence_kernels.subsampled(mask, scale, rows)
        assert np.array_equal(small, masked[::scale, ::scale]) and tuple(box) == evidence_kernels.subsampled(masked, scale, every)[2:]
    empty = evidence_kernels.subsampled(np.zeros((6, 8), np.uint8), 2, every)
    assert empty[2:] == (0, 0, 0, 0) and not empty[1].any()


def test_the_subsampled_masks_label_image_is_zero_outside_the_box_of_its_set_pixels():
    """What the labeller does not write (blobs._components labels inside the box only) is zero."""
    for _ in range(3):  # after other label images were freed: no memory that happens to be zero
        evidence_kernels.subsampled(np.ones((40, 60), np.uint8) * 7, 2, np.zeros(0, np.uint8))[1][:] = -1
    mask = np.zeros((40, 60), np.uint8)
    mask[13:21, 26:39] = 1  # subsampled: rows 7-10, columns 13-19; the box starts at even cells (6, 12)
    small, labels, x0, y0, x1, y1 = evidence_kernels.subsampled(mask, 2, np.zeros(0, np.uint8))
    assert (x0, y0, x1, y1) == (12, 6, 20, 11)
    outside = np.ones(labels.shape, bool)
    outside[y0:y1, x0:x1] = False
    assert not labels[outside].any()


def _uneven_numpy(mask, centres, major, axes):
    """The numpy expression blobs._uneven was before it was compiled: the reference."""
    along = np.linspace(-0.6, 0.6, 7)[None, :, None] * axes[:, :1, None]
    across = np.linspace(-1.2, 1.2, 13)[None, None, :] * axes[:, 1:, None]
    ux, uy = major[:, :1, None], major[:, 1:, None]
    x = np.rint(centres[:, :1, None] + ux * along - uy * across).astype(int).clip(0, mask.shape[1] - 1)
    y = np.rint(centres[:, 1:, None] + uy * along + ux * across).astype(int).clip(0, mask.shape[0] - 1)
    width = (mask[y, x] > 0).sum(axis=2) * (0.2 * axes[:, 1:])
    narrowest, widest = width.min(axis=1), width.max(axis=1)
    return (narrowest < 0.7 * widest) & (widest - narrowest > 3.0)


def test_uneven_is_the_numpy_expression_it_replaced():
    """Random blobs on random masks (some reaching past the edges, some on pixel halves where rint rounds to even):
    the compiled uneven gives numpy's verdict on every one, and finds both verdicts often."""
    from stereotrack.evidence.blobs import _ACROSS, _ALONG

    rng = np.random.default_rng(18)
    verdicts = []
    for _ in range(40):
        h, w = rng.integers(20, 120, 2)
        mask = (cv2.GaussianBlur(rng.random((h, w)), (0, 0), rng.uniform(1, 5)) > rng.uniform(0.45, 0.55)).astype(np.uint8)
        m = int(rng.integers(0, 30))
        centres = rng.uniform(-10, [w + 10, h + 10], (m, 2))
        centres[: m // 3] = np.round(centres[: m // 3]) + 0.5  # halves: rint's ties
        angle = rng.uniform(0, np.pi, m)
        major = np.column_stack([np.cos(angle), np.sin(angle)])
        axes = np.sort(rng.uniform(0.3, 30, (m, 2)), axis=1)[:, ::-1].copy()
        got = evidence_kernels.uneven(mask, centres, major, axes, _ALONG, _ACROSS)
        assert np.array_equal(got, _uneven_numpy(mask, centres, major, axes))
        verdicts.extend(got)
    assert 0 < np.mean(verdicts) < 1
