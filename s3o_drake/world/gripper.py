"""How the gripper holds an object of each kind: whole, or pinched at the rim.

One rule for the grasps (feasibility/grasps.py: which grasp a kind gets, and how far the
reach may miss it) and for the object tracker (world/object_tracker.py: where a held
object sits between the fingers).
"""

from s3o_drake.world.furniture import DISH_SHAPES
from s3o_drake.world.robot import Robot

#: A dish is held whole when it is this much narrower than the full opening (m).
OPENING_MARGIN = 0.03


def holds_whole(kind: str, *, robot: Robot) -> bool:
    """Whether `robot`'s opening spans an object of `kind` (a cup, a can, an apple): the
    fingers close on its sides and centre it between them; else (a plate, a bowl) the rim
    is pinched."""
    return 2 * DISH_SHAPES[kind].radius <= 2 * robot.finger_travel - OPENING_MARGIN
