"""Connected regions of a mask and their boxes, areas and centroids, as OpenCV gives them.

``cv2.connectedComponentsWithStats`` costs about ten times OpenCV's labelling alone on the
search copy (0.8 ms against 0.08 ms at 480x270), whatever few pixels are set; the masks
searched hold a few hundred. The statistics are summed here over the set pixels only,
from the same labels: the same integers, and the same centroids (integer sums over the
area, one division each, as OpenCV makes them).
"""

from __future__ import annotations

import cv2
import numpy as np


def components(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """8-connected regions of a uint8 mask: the labels (0 off the mask, 1, 2, ... in OpenCV's
    order), and per region (row i - 1 for label i) its (left, top, width, height, area) and
    centroid (x, y): ``cv2.connectedComponentsWithStats(mask, connectivity=8)`` without the
    background's row."""
    count, labels = cv2.connectedComponents(mask, connectivity=8)
    points = cv2.findNonZero(mask)
    if points is None:
        return labels, np.zeros((0, 5), np.int32), np.zeros((0, 2))
    x, y = points.reshape(-1, 2).T  # in raster order
    label = labels[y, x] - 1
    regions = count - 1
    area = np.bincount(label, minlength=regions)
    left, top = np.full(regions, x.max()), np.full(regions, y.max())
    right, bottom = np.zeros(regions, x.dtype), np.zeros(regions, y.dtype)
    np.minimum.at(left, label, x)
    np.minimum.at(top, label, y)
    np.maximum.at(right, label, x)
    np.maximum.at(bottom, label, y)
    stats = np.column_stack([left, top, right - left + 1, bottom - top + 1, area]).astype(np.int32)
    centroids = np.column_stack([np.bincount(label, weights=x, minlength=regions),
                                 np.bincount(label, weights=y, minlength=regions)]) / area[:, None]
    return labels, stats, centroids
