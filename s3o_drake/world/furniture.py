"""Dimensions and 2D footprints of the furniture and the dishes.

One source of truth for sizes: the world builder fills the SDFormat templates in
`models/furniture/` from these numbers, and the scenario checks and the navigation
map use the footprints computed here, so what the planner avoids is what the plant
collides with.
"""

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np
import shapely
from scipy import ndimage
from shapely import affinity
from shapely.geometry import Point, Polygon, box
from shapely.ops import unary_union

# Tables: legs are square posts inset from the corners of the top.
TABLE_LEG_WIDTH = 0.05
TABLE_LEG_INSET = 0.06

# Chair (in its own frame: x points from the back to the front edge of the seat).
CHAIR_SEAT_DEPTH = 0.42
CHAIR_SEAT_WIDTH = 0.44
CHAIR_SEAT_HEIGHT = 0.45
CHAIR_SEAT_THICKNESS = 0.04
CHAIR_LEG_WIDTH = 0.035
CHAIR_BACK_THICKNESS = 0.04
CHAIR_BACK_WIDTH = 0.50  # wider than the seat, so the footprint is a T, not a box
CHAIR_BACK_HEIGHT = 0.45  # above the seat
CHAIR_BACK_TILT = 0.12  # rad; the back leans out behind the seat


@dataclass(frozen=True)
class DishShape:
    """A dish as a cylinder: radius and height (m), and its colour (RGBA)."""

    radius: float
    height: float
    rgba: tuple[float, float, float, float]


DISH_SHAPES: dict[str, DishShape] = {
    "plate": DishShape(radius=0.12, height=0.025, rgba=(0.95, 0.95, 0.92, 1.0)),
    "bowl": DishShape(radius=0.08, height=0.06, rgba=(0.55, 0.75, 0.95, 1.0)),
    "cup": DishShape(radius=0.045, height=0.10, rgba=(0.95, 0.80, 0.30, 1.0)),
    # The tidy-home demonstration's objects (scenarios/tidy_home.yaml).
    "can": DishShape(radius=0.033, height=0.12, rgba=(0.80, 0.12, 0.12, 1.0)),
    "apple": DishShape(radius=0.04, height=0.075, rgba=(0.55, 0.80, 0.20, 1.0)),
}
DISH_KINDS = tuple(DISH_SHAPES)
RESTAURANT_KINDS = ("plate", "bowl", "cup")
"""The kinds the restaurant's tasks draw from (`generate`, the soak's random scenes), and the
kinds the Fea^m network was trained on."""
NETWORK_KIND = {"plate": "plate", "bowl": "bowl", "cup": "cup", "can": "cup", "apple": "cup"}
"""The kind the Fea^m network is shown an object as (its kind plane and its footprint
plane): its own, or for an object it was not trained on the kind it is held like (a can
and an apple are held whole, as a cup is). Shown with their own, smaller footprints the
network rated a can and an apple near 0 everywhere (mean 0.001 against the oracle's 0.23,
on two_dishes with the dishes swapped); shown as cups, within 0.04 of the oracle (mean
absolute difference), as cups themselves are (0.035). The height plane shows the object
as it is."""
DISH_MASS = {"plate": 0.4, "bowl": 0.3, "cup": 0.25, "can": 0.015, "apple": 0.2}
"""Mass (kg) of each kind (an empty can)."""


def _place(shape: Polygon, x: float, y: float, yaw: float) -> Polygon:
    rotated = affinity.rotate(shape, yaw, origin=(0.0, 0.0), use_radians=True)
    return affinity.translate(rotated, x, y)


def table_footprint(center: list[float], yaw: float, size: list[float]) -> Polygon:
    """The table top's outline in the world (the legs stand inside it)."""
    half_x, half_y = size[0] / 2, size[1] / 2
    return _place(box(-half_x, -half_y, half_x, half_y), center[0], center[1], yaw)


def table_leg_offsets(size: list[float]) -> list[tuple[float, float]]:
    """Leg centres in the table frame."""
    dx = size[0] / 2 - TABLE_LEG_INSET
    dy = size[1] / 2 - TABLE_LEG_INSET
    return [(sx * dx, sy * dy) for sx in (-1, 1) for sy in (-1, 1)]


def chair_leg_offsets() -> list[tuple[float, float]]:
    """Leg centres in the chair frame."""
    dx = CHAIR_SEAT_DEPTH / 2 - CHAIR_LEG_WIDTH
    dy = CHAIR_SEAT_WIDTH / 2 - CHAIR_LEG_WIDTH
    return [(sx * dx, sy * dy) for sx in (-1, 1) for sy in (-1, 1)]


def legs_section(tables: Iterable, chair_poses: Iterable[Sequence[float]]) -> Polygon:
    """What stands on the floor of the tables and chairs below their tops and seats: the
    outlines of their legs, in the world (a scan at a leg's height sees these)."""
    posts = []
    for table in tables:
        leg = box(-TABLE_LEG_WIDTH / 2, -TABLE_LEG_WIDTH / 2, TABLE_LEG_WIDTH / 2,
                  TABLE_LEG_WIDTH / 2)
        for dx, dy in table_leg_offsets(table.size):
            posts.append(_place(affinity.translate(leg, dx, dy), table.center[0],
                                table.center[1], table.yaw))
    leg = box(-CHAIR_LEG_WIDTH / 2, -CHAIR_LEG_WIDTH / 2, CHAIR_LEG_WIDTH / 2,
              CHAIR_LEG_WIDTH / 2)
    for x, y, yaw in chair_poses:
        for dx, dy in chair_leg_offsets():
            posts.append(_place(affinity.translate(leg, dx, dy), x, y, yaw))
    return unary_union(posts)


def chair_back_offset() -> tuple[float, float]:
    """Centre (x, z) of the tilted backrest in the chair frame, z from the seat top."""
    half_height = CHAIR_BACK_HEIGHT / 2
    x = -CHAIR_SEAT_DEPTH / 2 - np.sin(CHAIR_BACK_TILT) * half_height
    z = np.cos(CHAIR_BACK_TILT) * half_height
    return float(x), float(z)


def chair_footprint(pose: list[float]) -> Polygon:
    """The chair's outline on the floor: the seat plus the wider, leaning backrest."""
    half_d, half_w = CHAIR_SEAT_DEPTH / 2, CHAIR_SEAT_WIDTH / 2
    seat = box(-half_d, -half_w, half_d, half_w)
    # Top view of the tilted back: it spans from the seat's rear edge to its top edge.
    back_x_far = -half_d - np.sin(CHAIR_BACK_TILT) * CHAIR_BACK_HEIGHT - CHAIR_BACK_THICKNESS
    back = box(back_x_far, -CHAIR_BACK_WIDTH / 2, -half_d + CHAIR_BACK_THICKNESS / 2,
               CHAIR_BACK_WIDTH / 2)
    return _place(unary_union([seat, back]), pose[0], pose[1], pose[2])


def dish_footprint(position: list[float], kind: str) -> Polygon:
    """The dish's circular outline."""
    return Point(position[0], position[1]).buffer(DISH_SHAPES[kind].radius, quad_segs=16)


@dataclass(frozen=True)
class DistanceField:
    """Distance (m) from a grid's cell centres to obstacle footprints and the room's walls.

    A cell is occupied when its centre lies within `grow` of an obstacle; the walls are a
    ring of occupied cells just outside `bounds`. Index [i, j] is (x index, y index).
    """

    origin: np.ndarray
    resolution: float
    occupied: np.ndarray
    distance: np.ndarray

    @classmethod
    def of(cls, obstacles, bounds: tuple[float, float, float, float], resolution: float, *,
           grow: float) -> "DistanceField":
        x0, y0, x1, y1 = bounds
        nx, ny = math.ceil((x1 - x0) / resolution), math.ceil((y1 - y0) / resolution)
        gx, gy = np.meshgrid(x0 + (np.arange(nx) + 0.5) * resolution,
                             y0 + (np.arange(ny) + 0.5) * resolution, indexing="ij")
        occupied = np.zeros((nx, ny), dtype=bool)
        if not obstacles.is_empty:
            occupied = shapely.contains_xy(obstacles.buffer(grow), gx, gy)
        padded = np.pad(occupied, 1, constant_values=True)
        distance = ndimage.distance_transform_edt(~padded)[1:-1, 1:-1] * resolution
        return cls(np.array([x0, y0]), float(resolution), occupied, distance)

    def at(self, P: np.ndarray) -> np.ndarray:
        """The distance of the cell holding each point (m, 2); 0 outside the grid."""
        P = np.asarray(P, dtype=float).reshape(-1, 2)
        ij = np.floor((P - self.origin) / self.resolution).astype(int)
        nx, ny = self.distance.shape
        inside = (ij[:, 0] >= 0) & (ij[:, 0] < nx) & (ij[:, 1] >= 0) & (ij[:, 1] < ny)
        out = np.zeros(len(P))
        out[inside] = self.distance[ij[inside, 0], ij[inside, 1]]
        return out
