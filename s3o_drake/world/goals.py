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

import dataclasses
from collections.abc import Container, Sequence
from dataclasses import dataclass

from shapely.geometry import Point

from s3o_drake.world.choices import Goal
from s3o_drake.world.furniture import DISH_SHAPES, dish_footprint, table_footprint
from s3o_drake.world.objects import Dish, surface_height
from s3o_drake.world.scenario import Scenario

PLACE_SUFFIX = "__place"
"""Ends the name of a place target (`place_target_name`); names in a scenario hold no
double underscore, so none can clash."""


def place_target_name(name: str) -> str:
    """The name of object `name`'s place target."""
    return name + PLACE_SUFFIX


def placed_object(target: str) -> str | None:
    """The object whose place target is named `target`, or None for any other name."""
    return target[:-len(PLACE_SUFFIX)] if target.endswith(PLACE_SUFFIX) else None


def shown_name(name: str) -> str:
    """A name as a person reads it: a place target is its object's place ("apple's
    place"), any other name itself."""
    placed = placed_object(name)
    return name if placed is None else f"{placed}'s place"


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
                                   surface_height(scenario.tables, under)
                                   + DISH_SHAPES[under.kind].height,
                                   onto=under.name))
        else:
            out.append(PlaceTarget(dish.name, dish.kind, place.table,
                                   (float(place.position[0]), float(place.position[1])),
                                   heights[place.table]))
    return out


def place_target_dishes(scenario: Scenario) -> list[Dish]:
    """The place target of each object to place as an object of its kind standing there
    (`PlaceTarget.as_dish`), in the scenario's order."""
    heights = {t.name: t.height for t in scenario.tables}
    return [t.as_dish(heights[t.table]) for t in place_targets(scenario)]


def with_place_targets(scenario: Scenario) -> Scenario:
    """`scenario` with its place targets among the dishes (`place_target_dishes`): every
    spot an object is put down at, with the objects."""
    return dataclasses.replace(scenario,
                               dishes=[*scenario.dishes, *place_target_dishes(scenario)])


def surface_below(scenario: Scenario, p_W: Sequence[float], *,
                  ignore: Container[str] = ()) -> float:
    """World z (m) of the highest surface under the point (x, y) of `p_W` (z ignored): the
    top of an object that stays (`Goal.STAY`) whose footprint holds the point, else the top
    of a table whose top holds it, else the floor (0). What an object let go at (x, y)
    comes to stand on; objects named in `ignore` are not surfaces."""
    point = Point(float(p_W[0]), float(p_W[1]))
    heights = [0.0]
    heights += [t.height for t in scenario.tables
                if table_footprint(t.center, t.yaw, t.size).covers(point)]
    heights += [surface_height(scenario.tables, d) + DISH_SHAPES[d.kind].height
                for d in scenario.dishes
                if d.goal == Goal.STAY.value and d.name not in ignore
                and dish_footprint(d.position, d.kind).covers(point)]
    return max(heights)
