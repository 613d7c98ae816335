"""The evidence stage's compiled kernels against OpenCV."""

import cv2
import numpy as np

from stereotrack.evidence import kernels as evidence_kernels


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
