"""What a task wants done with its objects, beyond collecting them: the place targets.

An object whose goal is `place` (`scenario.Dish.goal`, `choices.Goal`) is picked, held in
the gripper and put down at its place: on a table's top at a position, or on top of an
object that stays where it is (the apple onto the plate of the tidy-home demonstration).
`place_targets` resolves each place to where the object will stand: the table, the
position (x, y) and the height of the surface it stands on (the table's top, or the top of
the object it is put onto).

For planning, a place target is an object of its own (S3O's abstraction gives it a cell,
a Fea^m heatmap and a location, which may merge it with pick targets), named by
`place_target_name`: the object's name and PLACE_SUFFIX, which no scenario name can end
with (`scenario_checks`).
"""

from __future__ import annotations

from dataclasses import dataclass

from s3o_drake.choices import Goal
from s3o_drake.furniture import DISH_SHAPES
from s3o_drake.scenario import Dish, Scenario, surface_height

PLACE_SUFFIX = "__place"
"""Ends the name of a place target (`place_target_name`); names in a scenario hold no
double underscore, so none can clash."""


def place_target_name(name: str) -> str:
    """The name of object `name`'s place target."""
    return name + PLACE_SUFFIX


def placed_object(target: str) -> str | None:
    """The object whose place target is named `target`, or None for any other name."""
    return target[:-len(PLACE_SUFFIX)] if target.endswith(PLACE_SUFFIX) else None


@dataclass(frozen=True)
class PlaceTarget:
    """Where object `name` (of `kind`) is to stand once put down: on `table`, its centre
    at `position` (x, y; m), on a surface at height `surface` (m: the table's top, or the
    top of the object `onto` it is put on)."""

    name: str
    kind: str
    table: str
    position: tuple[float, float]
    surface: float
    onto: str = ""

    @property
    def target(self) -> str:
        """The place target's own name (`place_target_name`)."""
        return place_target_name(self.name)

    def as_dish(self, table_height: float) -> Dish:
        """The place target as an object of the held object's kind standing there (on a
        table whose top is at `table_height`): what the feasibility of putting it down is
        judged on, a pick of it from there."""
        return Dish(name=self.target, table=self.table, position=list(self.position),
                    kind=self.kind, elevation=self.surface - table_height)


def place_targets(scenario: Scenario) -> list[PlaceTarget]:
    """The place target of each object whose goal is place, in the scenario's order (the
    scenario is valid: `scenario_checks` has resolved every place)."""
    by_name = {d.name: d for d in scenario.dishes}
    heights = {t.name: t.height for t in scenario.tables}
    out = []
    for dish in scenario.dishes:
        if dish.goal != Goal.PLACE.value:
            continue
        place = dish.place
        if place.onto:
            under = by_name[place.onto]
            out.append(PlaceTarget(dish.name, dish.kind, under.table,
                                   (float(under.position[0]), float(under.position[1])),
                                   surface_height(scenario, under)
                                   + DISH_SHAPES[under.kind].height,
                                   onto=under.name))
        else:
            out.append(PlaceTarget(dish.name, dish.kind, place.table,
                                   (float(place.position[0]), float(place.position[1])),
                                   heights[place.table]))
    return out
