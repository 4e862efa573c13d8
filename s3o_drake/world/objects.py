"""The objects of a task (the dishes of the restaurant, the cans and the apple of the tidy
home) and where one is put down: the schema's dataclasses (they mirror the YAML,
`world/scenario.py`), and the height of the surface an object stands on."""

from collections.abc import Iterable
from dataclasses import dataclass, field

from s3o_drake.world.map import Table


@dataclass
class PlaceSpot:
    """Where an object whose goal is `place` is put down: on `table` at `position`, or on
    top of the object named `onto` (whose goal is `stay`); the other fields stay empty.
    (Not `on`: YAML 1.1 reads that key as the boolean true.)"""

    table: str = ""
    position: list[float] = field(default_factory=list)
    """[x, y] of the object's centre when put down (m)."""
    onto: str = ""


@dataclass
class Dish:
    """An object on the top of `table` (a dish of the restaurant): collected by default."""

    name: str = ""
    table: str = ""
    position: list[float] = field(default_factory=lambda: [0.0, 0.0])
    """[x, y] of the dish's centre in the world (m); z is the table's height."""
    kind: str = "plate"
    """plate | bowl | cup | can | apple (furniture.DISH_SHAPES)"""
    goal: str = "collect"
    """collect (onto the tray) | place (held, then put down at `place`) | stay (choices.Goal)"""
    place: PlaceSpot = field(default_factory=PlaceSpot)
    elevation: float = 0.0
    """Height (m) above the table's top of the surface the object stands on: 0, the top
    itself; for an object put onto another, that object's height (world/goals.py)."""


def surface_height(tables: Iterable[Table], dish: Dish) -> float:
    """World z (m) of the surface `dish` stands on: its table's top plus its elevation."""
    table = next(t for t in tables if t.name == dish.table)
    return table.height + dish.elevation
