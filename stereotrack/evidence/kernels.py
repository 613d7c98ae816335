"""Compiled loops of the evidence stage: connected-component boxes and blob moments (``blobs.py``).

See ``stereotrack/kernels.py`` for how kernels are compiled, cached and warmed up.
"""

from __future__ import annotations

import numpy as np

from ..kernels import kernel


@kernel
def component_boxes(labels, n):
    """Pixel count and bounding box (x0, y0, x1, y1, end exclusive) of components 1..n-1 of a label image."""
    area = np.zeros(n, np.int64)
    box = np.empty((n, 4), np.int64)
    box[:, 0] = labels.shape[1]
    box[:, 1] = labels.shape[0]
    box[:, 2] = 0
    box[:, 3] = 0
    for y in range(labels.shape[0]):
        for x in range(labels.shape[1]):
            c = labels[y, x]
            if c == 0:
                continue
            area[c] += 1
            box[c, 0] = min(box[c, 0], x)
            box[c, 1] = min(box[c, 1], y)
            box[c, 2] = max(box[c, 2], x + 1)
            box[c, 3] = max(box[c, 3], y + 1)
    return area[1:], box[1:]


@kernel
def mask_moments(mask, boxes, scale):
    """Per box (x0, y0, x1, y1) of a ``scale``-times subsampled copy of a 0/1 mask: pixel count,
    centroid (x, y), the bounding box of the set pixels (width, height) in the full mask, and their
    central second moments (xx, yy, xy), inside the box grown by one subsampled cell (the
    subsampling's slack). An empty box gets its own centre and size 0."""
    h, w = mask.shape
    m = boxes.shape[0]
    count = np.zeros(m)
    centre = np.empty((m, 2))
    size = np.zeros((m, 2))
    second = np.zeros((m, 3))
    for b in range(m):
        x0, y0 = max(boxes[b, 0] * scale - scale, 0), max(boxes[b, 1] * scale - scale, 0)
        x1, y1 = min(boxes[b, 2] * scale + scale, w), min(boxes[b, 3] * scale + scale, h)
        sx = 0.0
        sy = 0.0
        sxx = 0.0
        syy = 0.0
        sxy = 0.0
        lo_x, lo_y, hi_x, hi_y = x1, y1, x0 - 1, y0 - 1
        for y in range(y0, y1):
            for x in range(x0, x1):
                if mask[y, x]:
                    count[b] += 1.0
                    dx, dy = float(x - x0), float(y - y0)  # about the box corner: no loss of precision
                    sx += dx
                    sy += dy
                    sxx += dx * dx
                    syy += dy * dy
                    sxy += dx * dy
                    lo_x, hi_x = min(lo_x, x), max(hi_x, x)
                    lo_y, hi_y = min(lo_y, y), max(hi_y, y)
        if count[b] > 0:
            n = count[b]
            mx, my = sx / n, sy / n
            centre[b, 0] = x0 + mx
            centre[b, 1] = y0 + my
            size[b, 0] = hi_x - lo_x + 1
            size[b, 1] = hi_y - lo_y + 1
            second[b, 0] = sxx / n - mx * mx
            second[b, 1] = syy / n - my * my
            second[b, 2] = sxy / n - mx * my
        else:
            centre[b, 0] = 0.5 * (x0 + x1)
            centre[b, 1] = 0.5 * (y0 + y1)
    return count, centre, size, second
