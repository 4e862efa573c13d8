"""What a Drake plant of a room holds: the room, the tables, the chairs, the objects and the
robot and its pose. The simulator's plant holds the true world's (`Scenario.contents`: every
chair); a planner's plant holds a belief's (`KnownWorld.contents`: the mapped chairs and the
perceived ones, the objects that remain). One type for both, so that the plant builder
(`world.builder.populate_plant`) never needs to know which it builds."""

from dataclasses import dataclass

from s3o_drake.world.map import Chair, Room, Table
from s3o_drake.world.objects import Dish
from s3o_drake.world.robot import Robot


@dataclass(frozen=True)
class SceneContents:
    room: Room
    tables: tuple[Table, ...]
    chairs: tuple[Chair, ...]
    dishes: tuple[Dish, ...]
    """The objects on the tables: the task's (and the fixtures something is placed on)."""
    start: tuple[float, float, float]
    """The robot's pose (x, y, yaw): the plant's default positions."""
    robot: Robot
    """The robot in the room."""
    floor_margin: float = 0.0
    """How far (m) the visible floor reaches beyond the room (the camera's margin)."""
    unmapped_chairs_margin: float = 0.0
    """How much further (m) than the scene's padding the arm keeps from the chairs not on
    the map: a belief's chairs are where perception placed them, and may be this far off
    (`belief.known_world.PLACEMENT_ERROR`); the true world's are where they are (0)."""
