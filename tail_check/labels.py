"""Connected regions of a mask, labelled without OpenCV's per-label statistics.

``connectedComponentsWithStats`` computes a box, an area and a centroid for every label,
which on a working image costs ten times the labelling itself; the detector needs the
areas of all labels (a histogram of the label image) and boxes of the few it keeps.
"""

from __future__ import annotations

import cv2
import numpy as np
from numpy.typing import NDArray

__all__ = ["label_areas", "label_box", "label_centroid", "label_regions"]

BBox = tuple[int, int, int, int]


def label_regions(mask_u8: NDArray[np.uint8]) -> tuple[int, NDArray[np.uint16]]:
    """8-connected labels of a 0/1 mask (OpenCV's Grana algorithm, 16-bit labels).

    Labelling without OpenCV's statistics is about 10x faster on a working image, and
    the labels are the same; :func:`label_areas` and :func:`label_box` give the
    statistics that are needed, for the labels that need them.
    """
    n, labels = cv2.connectedComponentsWithAlgorithm(mask_u8, 8, cv2.CV_16U, cv2.CCL_GRANA)
    return int(n), np.asarray(labels, dtype=np.uint16)


def label_areas(labels: NDArray[np.uint16], n: int) -> NDArray[np.int64]:
    """Pixels per label 0..n-1 (a histogram of the labels)."""
    counts = cv2.calcHist([labels], [0], None, [n], [0, n])
    return np.asarray(counts.ravel(), dtype=np.int64)


def label_box(labels: NDArray[np.uint16], label: int) -> BBox:
    """Bounding box (x, y, w, h) of one label."""
    # A scalar operand, which OpenCV's stubs do not describe.
    x, y, w, h = cv2.boundingRect(cv2.compare(labels, label, cv2.CMP_EQ))  # type: ignore[call-overload]
    return int(x), int(y), int(w), int(h)


def label_centroid(labels: NDArray[np.uint16], label: int, box: BBox) -> tuple[float, float]:
    """Centroid (x, y) of one label inside its bounding box ``box``: the mean of its pixels'
    coordinates, as OpenCV's statistics give it (integer sums over the area, one rounding)."""
    x, y, w, h = box
    ys, xs = np.nonzero(labels[y : y + h, x : x + w] == label)
    area = len(xs)
    return (int(xs.sum()) + x * area) / area, (int(ys.sum()) + y * area) / area
