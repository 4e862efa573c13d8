"""The robot's map, as the scenario file gives it: the room, the tables, the chairs (those
with `mapped: true` are on the map; the others are only in the true world, and the robot
knows them only by perceiving them). `Map` is what the robot is given of them.

The dataclasses mirror the YAML (`world/scenario.py`); no `from __future__ import
annotations` here: pydrake's yaml_load_typed reads the annotations at run time.
"""

from dataclasses import dataclass, field


@dataclass
class Room:
    """The room: a rectangle with walls around it."""

    bounds: list[float] = field(default_factory=lambda: [0.0, 0.0, 10.0, 8.0])
    """[x_min, y_min, x_max, y_max] of the floor inside the walls (m)."""
    wall_height: float = 1.0
    wall_thickness: float = 0.1


@dataclass
class Table:
    """A table: always on the robot's map."""

    name: str = ""
    center: list[float] = field(default_factory=lambda: [0.0, 0.0])
    """[x, y] of the top's centre (m)."""
    yaw: float = 0.0
    size: list[float] = field(default_factory=lambda: [1.2, 0.8, 0.04])
    """[length along the table's x, width, thickness] of the top (m)."""
    height: float = 0.75
    """Height of the top surface above the floor (m)."""


@dataclass
class Chair:
    """A chair: an obstacle that is usually not on the map, only seen by the camera."""

    name: str = ""
    pose: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])
    """[x, y, yaw]: the seat's centre and the direction its front faces."""
    mapped: bool = False


@dataclass(frozen=True)
class Map:
    """What the robot is given of the room: its bounds and walls, the tables and the mapped
    chairs (never the unmapped ones)."""

    room: Room
    tables: tuple[Table, ...]
    chairs: tuple[Chair, ...]
    """The mapped chairs."""
