"""Grasp poses of a dish for the 2F-140-class gripper: a top grasp and a side grasp.

The grasp frame G (`Robot.grasp_frame`) has z along the approach and y along the fingers'
opening. Grasps are defined relative to the bearing ψ from the arm's base A to the dish,
so that rotating the shoulder-pan joint by Δψ carries a grasp at one bearing to another:
the reachability map uses that symmetry and is indexed only by the horizontal distance ρ
from A and the height h above A.

- top: approach straight down. A dish narrower than the opening (a cup) is grasped
  whole, fingers across the bearing ("top" with wrist yaw 0); a wider one (plate, bowl)
  is pinched at the rim nearest the robot, fingers along the bearing ("top" with the
  wrist turned by π/2, `wrist_turn`).
- side: approach horizontally along the bearing, fingers across it; only for dishes
  narrow enough to hold and tall enough to leave the fingers off the table (cups).
"""

import math
from dataclasses import dataclass

import numpy as np
from pydrake.math import RigidTransform, RotationMatrix

from s3o_drake.world.furniture import DISH_SHAPES
from s3o_drake.world.gripper import RIM_INSET, holds_whole
from s3o_drake.world.robot import Robot

GRASP_KINDS = ("top", "side")
# The fingers must stay this far above the table top (m); matches the 1 cm clearance of
# the feasibility check plus a little.
TABLE_CLEARANCE = 0.012
# Half the height of a finger pad seen from the side (m), for side grasps.
PAD_HALF_HEIGHT = 0.015

# Rotations of G in the frame whose x axis points along the bearing (z up).
R_BEARING_TOP = RotationMatrix(np.array([[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]]).T)
R_BEARING_SIDE = RotationMatrix(np.array([[0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]]).T)


@dataclass(frozen=True)
class Grasp:
    """One way to grasp a dish, for an arm base at a given place.

    kind: "top" or "side" (the reachability map's index); wrist_turn: the extra rotation
    of wrist 3 (0 or π/2) about the approach axis; rho, height: the grasp point's
    horizontal distance from the arm base A and height above it (m); bearing: direction
    from A to the grasp point in the world (rad); X_WG: the grasp frame's pose in the world.
    """

    kind: str
    wrist_turn: float
    rho: float
    height: float
    bearing: float
    X_WG: RigidTransform


def grasp_point_height(kind: str, table_height: float, grasp: str, *, robot: Robot) -> float:
    """World z of `robot`'s grasp point for a dish of `kind` on a table top at
    `table_height`."""
    shape = DISH_SHAPES[kind]
    if grasp == "top":
        fingertip_below_g = robot.fingertip_offset - robot.grasp_offset
        return table_height + max(0.6 * shape.height, fingertip_below_g + TABLE_CLEARANCE)
    # The hand and wrist follow the grasp point along the approach axis within this radius:
    # in a side grasp they pass over the table top, so they set the lowest grasp height.
    wrist_radius = robot.description.tool.wrist_radius
    return table_height + max(0.5 * shape.height, PAD_HALF_HEIGHT + TABLE_CLEARANCE,
                              wrist_radius + TABLE_CLEARANCE)


def rotation_for(grasp: str, bearing: float) -> RotationMatrix:
    """R_WG of a grasp of this kind (wrist_turn 0) at this bearing."""
    R = R_BEARING_TOP if grasp == "top" else R_BEARING_SIDE
    return RotationMatrix.MakeZRotation(bearing) @ R


def grasps_for(dish_kind: str, p_WD: np.ndarray, table_height: float,
               p_WA: np.ndarray, *, robot: Robot) -> list[Grasp]:
    """`robot`'s grasps of a dish at p_WD (xy of its centre) from its arm base at p_WA (3D).

    In order of preference: top first, side second (when the dish allows one).
    """
    p_WD = np.asarray(p_WD, dtype=float)[:2]
    p_WA = np.asarray(p_WA, dtype=float)
    delta = p_WD - p_WA[:2]
    distance = float(np.hypot(*delta))
    bearing = math.atan2(delta[1], delta[0]) if distance > 1e-9 else 0.0
    u = np.array([math.cos(bearing), math.sin(bearing)])
    whole = holds_whole(dish_kind, robot=robot)

    grasps = []
    # Top: whole dish at its centre, or the near rim.
    inset = 0.0 if whole else DISH_SHAPES[dish_kind].radius - RIM_INSET
    p_xy = p_WD - inset * u
    z = grasp_point_height(dish_kind, table_height, "top", robot=robot)
    turn = 0.0 if whole else math.pi / 2
    R = rotation_for("top", bearing) @ RotationMatrix.MakeZRotation(turn)
    grasps.append(Grasp("top", turn, distance - inset, z - p_WA[2], bearing,
                        RigidTransform(R, [p_xy[0], p_xy[1], z])))
    if whole and DISH_SHAPES[dish_kind].height >= 2 * (PAD_HALF_HEIGHT + TABLE_CLEARANCE):
        z = grasp_point_height(dish_kind, table_height, "side", robot=robot)
        grasps.append(Grasp("side", 0.0, distance, z - p_WA[2], bearing,
                            RigidTransform(rotation_for("side", bearing), [*p_WD, z])))
    return grasps
