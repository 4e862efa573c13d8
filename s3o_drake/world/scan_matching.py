"""Where the base stands, from a planar scan matched to what the robot knows of the room.

A scanner on the base sees, at its height, the walls and the legs of the tables and chairs.
The robot knows where those are: its map's walls and tables, and the chairs (mapped, and
those its overhead camera perceived). The scan, placed at a candidate pose of the base,
should fall on them. As the likelihood-field model of scan matching does (Thrun, Burgard and
Fox, Probabilistic Robotics, section 6.4), a pose is scored by each scan point's distance to
the nearest known outline, here shapely's exact distance (a distance field on a 1 cm grid
left the pose 2-4 mm off, from where its cells cut the legs). `scipy.optimize.least_squares`
minimises those distances from the pose the robot reported, with a robust loss, so that the
points on what the robot does not know (a chair perception missed, or placed off) weigh
little.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np
import shapely
from scipy import optimize
from shapely.geometry import box

from s3o_drake.world.furniture import legs_section
from s3o_drake.world.map import Room, Table

INLIER_DISTANCE = 0.02
"""Where the robust loss bends (m): a scan point further than this from everything the robot
knows counts less and less, as a point on what it does not know does."""
MAX_POINTS = 200
"""A scan is matched on at most this many of its points, spread evenly along it: each
distance to what the robot knows costs about 13 us a point, and 200 place the base within a
millimetre in the restaurant."""
MIN_POINTS = 20
"""A scan with fewer points than this on known outlines (within 2 INLIER_DISTANCE after
the match) gives no pose: too little of the room was seen to place the base."""


@dataclass(frozen=True)
class ScanMatch:
    """A matched pose `X_WB` (x, y, yaw) of the base, with the number of the scan's points
    that lie within 2 INLIER_DISTANCE of a known outline there (`inliers`), and their root
    mean square distance (m)."""

    X_WB: np.ndarray
    inliers: int
    rms: float


class RoomSection:
    """What the robot knows of the room at its scanner's height: the walls round `room`
    and the legs of `tables` and of the chairs at `chair_poses` (x, y, yaw)."""

    def __init__(self, room: Room, tables: Iterable[Table],
                 chair_poses: Iterable[Sequence[float]]) -> None:
        self.outlines = shapely.union(legs_section(tables, chair_poses),
                                      box(*room.bounds).exterior)
        shapely.prepare(self.outlines)

    def distance(self, p_W: np.ndarray) -> np.ndarray:
        """Each point's distance (m) to the nearest known outline, (N, 2) -> (N,)."""
        return shapely.distance(self.outlines, shapely.points(
            np.asarray(p_W, dtype=float).reshape(-1, 2)))


def range_points(ranges: np.ndarray, bearings: np.ndarray, *, max_range: float,
                p_BS: Sequence[float] = (0.0, 0.0)) -> np.ndarray:
    """The scan's returns as points (x, y) in the base's frame: range r at bearing b from a
    scanner at `p_BS`; returns at or beyond `max_range` (nothing seen) are left out."""
    ranges, bearings = np.asarray(ranges, dtype=float), np.asarray(bearings, dtype=float)
    seen = np.isfinite(ranges) & (ranges < max_range) & (ranges > 0.0)
    r, b = ranges[seen], bearings[seen]
    return np.column_stack([p_BS[0] + r * np.cos(b), p_BS[1] + r * np.sin(b)])


def _placed(p_B: np.ndarray, X_WB: np.ndarray) -> np.ndarray:
    c, s = math.cos(X_WB[2]), math.sin(X_WB[2])
    return np.column_stack([X_WB[0] + c * p_B[:, 0] - s * p_B[:, 1],
                            X_WB[1] + s * p_B[:, 0] + c * p_B[:, 1]])


def match_scan(section: RoomSection, p_B: np.ndarray, *,
               prior: Sequence[float]) -> ScanMatch | None:
    """The base pose at which the scan points `p_B` (N, 2, in the base's frame) fall best
    on `section`, searched from `prior` (x, y, yaw); None when too few points fall on what
    the robot knows there (MIN_POINTS)."""
    p_B = np.asarray(p_B, dtype=float).reshape(-1, 2)
    if len(p_B) < MIN_POINTS:
        return None
    fitted = p_B
    if len(p_B) > MAX_POINTS:  # evenly along the scan
        fitted = p_B[np.linspace(0, len(p_B) - 1, MAX_POINTS).round().astype(int)]
    x0 = np.asarray(prior, dtype=float)[:3]
    # Steps of 1e-5 m and rad: the distances are smooth at that scale, and far finer than
    # what the match resolves.
    fit = optimize.least_squares(lambda X: section.distance(_placed(fitted, X)), x0,
                                 loss="soft_l1", f_scale=INLIER_DISTANCE, diff_step=1e-5)
    d = section.distance(_placed(p_B, fit.x))
    near = d < 2.0 * INLIER_DISTANCE
    if near.sum() < MIN_POINTS:
        return None
    return ScanMatch(fit.x, int(near.sum()), float(np.sqrt(np.mean(d[near] ** 2))))
