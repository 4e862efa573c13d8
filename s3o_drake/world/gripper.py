"""How the gripper holds an object of each kind: whole, or pinched at the rim, and how far
the reach may miss it.

One rule for the grasps and Fea^m (feasibility/: which grasp a kind gets, the chance that
a reach catches the dish) and for the simulated robot's grasps (world/object_tracker.py:
whether the fingers catch a dish, and where a held object sits between them).
"""

import math

import numpy as np

from s3o_drake.world.furniture import DISH_SHAPES
from s3o_drake.world.robot import Robot

#: A dish is held whole when it is this much narrower than the full opening (m).
OPENING_MARGIN = 0.03
#: How far inside the rim the fingers pinch a wide dish (m).
RIM_INSET = 0.01
#: Friction coefficient between pads and dish (the world's default contact friction).
PAD_FRICTION = 0.5


def holds_whole(kind: str, *, robot: Robot) -> bool:
    """Whether `robot`'s opening spans an object of `kind` (a cup, a can, an apple): the
    fingers close on its sides and centre it between them; else (a plate, a bowl) the rim
    is pinched."""
    return 2 * DISH_SHAPES[kind].radius <= 2 * robot.finger_travel - OPENING_MARGIN


def grasp_tolerance(kind: str, *, robot: Robot) -> float:
    """How far (m, horizontally) the real dish may be from where `robot`'s gripper aims and
    still be held, for a dish of `kind`.

    Held whole (a cup): the fingers open twice the finger travel wide and close on the dish's
    sides, so the dish's centre may be off by the half-clearance travel - radius
    (0.025 m for a cup) before a finger comes down on it instead of beside it; the same
    number is used along the pads' width, where a dish further off is pushed aside by the
    pads' edges rather than centred.

    Pinched at the rim (plate, bowl): the fingers open along the bearing with the near rim
    RIM_INSET beyond the grasp point; the dish coming nearer by travel - RIM_INSET
    puts the rim under the outer pad (going away leaves more room). Sideways, the flat pads
    meet the round rim at an angle asin(e / radius); past the friction angle atan(μ) the
    squeezed rim slips out, so e <= radius μ / sqrt(1 + μ²) (0.054 m for a plate, 0.036 m for
    a bowl, μ = 0.5). The smaller of the two applies in every direction.
    """
    radius = DISH_SHAPES[kind].radius
    travel = robot.finger_travel
    if holds_whole(kind, robot=robot):
        return travel - radius
    sideways = radius * PAD_FRICTION / math.hypot(1.0, PAD_FRICTION)
    return min(travel - RIM_INSET, sideways)


def caught(reach_noise: np.ndarray, kind: str, *, robot: Robot) -> bool:
    """Whether `robot`'s fingers catch a dish of `kind` when the reach misses it by
    `reach_noise` (m, horizontal)."""
    miss = np.linalg.norm(np.asarray(reach_noise, dtype=float)[:2])
    return bool(miss <= grasp_tolerance(kind, robot=robot))
