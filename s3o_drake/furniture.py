"""Dimensions and 2D footprints of the furniture and the dishes.

One source of truth for sizes: the world builder fills the SDFormat templates in
`models/furniture/` from these numbers, and the scenario checks and the navigation
map use the footprints computed here, so what the planner avoids is what the plant
collides with.
"""

from dataclasses import dataclass

import numpy as np
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
}
DISH_KINDS = tuple(DISH_SHAPES)


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
