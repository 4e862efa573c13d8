"""Obstacle blobs in the top-view grid: one per chair (belief/chair_perception.py, step 2).

The obstacle cells' connected components are joined when close and still small enough
for one chair (`blobs`): the floor the camera sees under a seat's edge can cut a backrest
off its seat. The other way round, chairs that touch make one component, too large for
one chair: `split` parts its points into as many chairs as its area holds (dense task_080
and task_084: two touching chairs were perceived as one between them, and the chair that
was not on the map blocked the robot's drives).
"""

import math

import cv2
import numpy as np

from s3o_drake.world.furniture import chair_footprint

MAX_GAP = 0.3
"""Blobs this close (m) may be one chair: the strip under a seat that the camera sees
from the side is at most 0.45 m x 0.67 (the largest off-axis ratio in the restaurant)."""
MAX_CHAIR_SPAN = 0.65
"""Longest side (m) of a blob's rectangle that one chair can make (0.50 m, plus margin)."""


def blobs(obstacle: np.ndarray, cell: float) -> np.ndarray:
    """Labels (int32, 0 = none) of the obstacle cells, one per object.

    The obstacle cells' connected components, joined greedily (closest pair first) while
    two are within MAX_GAP and their union still fits in a chair (MAX_CHAIR_SPAN): the
    floor the camera sees under a seat's edge can cut a backrest off its seat. Two chairs
    together are larger than one, so they stay apart.
    """
    closed = cv2.morphologyEx(obstacle.astype(np.uint8), cv2.MORPH_CLOSE,
                              np.ones((3, 3), np.uint8))
    count, parts = cv2.connectedComponents(closed, connectivity=8)
    parts = np.where(obstacle, parts, 0)
    groups = [np.stack(np.nonzero(parts == k), axis=1) for k in range(1, count)]
    groups = [g for g in groups if len(g)]

    def span(cells: np.ndarray) -> float:
        return span_of(cells[:, ::-1]) * cell

    def gap(a: np.ndarray, b: np.ndarray) -> float:
        # Bounding boxes first: most pairs are far apart.
        lo = np.maximum(a.min(axis=0), b.min(axis=0))
        hi = np.minimum(a.max(axis=0), b.max(axis=0))
        if np.any((lo - hi) * cell > MAX_GAP):
            return math.inf
        d = np.min(np.linalg.norm(a[:, None, :] - b[None, :, :], axis=2)) - 1
        return max(float(d), 0.0) * cell

    while True:
        pairs = sorted((gap(groups[i], groups[j]), i, j)
                       for i in range(len(groups)) for j in range(i + 1, len(groups)))
        for d, i, j in pairs:
            if d > MAX_GAP:
                break
            union = np.concatenate([groups[i], groups[j]])
            if span(union) <= MAX_CHAIR_SPAN:
                groups = [g for k, g in enumerate(groups) if k not in (i, j)] + [union]
                break
        else:
            break
        if d > MAX_GAP:
            break
    labels = np.zeros(obstacle.shape, dtype=np.int32)
    for k, cells in enumerate(groups, start=1):
        labels[cells[:, 0], cells[:, 1]] = k
    return labels


CHAIR_AREA = chair_footprint([0.0, 0.0, 0.0]).area
"""Top-view area (m^2) of one chair, seat and backrest."""
SPLIT_ITERATIONS = 20
"""Rounds of k-means when a blob is split (it settles in a few)."""


def span_of(xy: np.ndarray) -> float:
    """Longest side of the minimum-area rectangle round points (n, 2)."""
    _, (w, h), _ = cv2.minAreaRect(np.asarray(xy, dtype=np.float32))
    return float(max(w, h))


def split(points: np.ndarray, area: float) -> list[np.ndarray]:
    """One blob's points (n, 3, world frame) as the points of each chair in it: the blob
    itself when one chair can make it (its rectangle's longest side at most
    MAX_CHAIR_SPAN), else k groups by k-means on x, y, with k its top-view `area` (m^2)
    over one chair's, at least 2. The groups start as k equal slices along the blob's
    longest axis, so that the result is the same every time."""
    xy = np.asarray(points, dtype=float)[:, :2]
    if len(xy) < 2 or span_of(xy) <= MAX_CHAIR_SPAN:
        return [points]
    k = max(2, round(area / CHAIR_AREA))
    centred = xy - xy.mean(axis=0)
    axis = np.linalg.svd(centred, full_matrices=False)[2][0]
    order = np.argsort(centred @ axis, kind="stable")
    labels = np.empty(len(xy), dtype=int)
    labels[order] = np.arange(len(xy)) * k // len(xy)
    for _ in range(SPLIT_ITERATIONS):
        centres = np.array([xy[labels == j].mean(axis=0) for j in range(k)])
        nearest = np.argmin(np.linalg.norm(xy[:, None] - centres[None], axis=2), axis=1)
        if np.array_equal(nearest, labels) or len(np.unique(nearest)) < k:
            break
        labels = nearest
    return [points[labels == j] for j in range(k)]
