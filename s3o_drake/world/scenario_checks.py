"""Scenario validation: the rules a scenario's values must meet, beyond their types.

`validate_scenario` checks sizes, names, references, every dish on its table, no furniture
overlapping other furniture or the walls, the robot starting free, and the settings' ranges,
and raises one `ScenarioError` for the first problem, naming its field
(`tables[2].size: expected 3 positive numbers, got [1.2, -0.8]`). The schema itself, the
dataclasses, is `world/scenario.py`, which calls this after loading a file.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import TYPE_CHECKING

from shapely.geometry import Polygon, box

from s3o_drake.world.choices import (
    COST_PROFILES,
    FAILURE_PRICES,
    FEASIBILITY_SOURCES,
    GOALS,
    GROUP_POSITIONS,
    LOCALIZATIONS,
    LOCATION_PRICES,
    METHODS,
    MOTIONS,
    RECOVERY_MODES,
    SHARED_STOPS,
)
from s3o_drake.world.furniture import (
    DISH_KINDS,
    DISH_SHAPES,
    chair_footprint,
    dish_footprint,
    table_footprint,
)
from s3o_drake.world.resources import DEFAULT_ROBOT, DESCRIPTION_FILE
from s3o_drake.world.robot import load_robot
from s3o_drake.world.robot_description import RobotDescriptionError, described_robots
from s3o_drake.world.yaml_checks import quoted

if TYPE_CHECKING:
    from s3o_drake.world.scenario import Scenario


class ScenarioError(ValueError):
    """A problem with a scenario, located by its field path (`dishes[3].table`) and, when it
    was read from a file, the file (`load_scenario`): str() names each once, as
    `file: field: problem`."""

    def __init__(self, path: str, message: str, file: str = ""):
        super().__init__(": ".join(part for part in (file, path, message) if part))
        self.path = path
        self.message = message
        self.file = file

    def __reduce__(self):
        # Raised in a worker process, it crosses back whole (see `FieldError`).
        return type(self), (self.path, self.message, self.file)


_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")
# Overlaps smaller than this (m^2) are numerical contact, not interpenetration.
_AREA_TOL = 1e-6
# The highest surface above a table's top an object may stand on (m): a stack of dishes.
MAX_ELEVATION = 0.3
# Free space the robot needs around its footprint at the start (m).
START_CLEARANCE = 0.02
# Counts in the settings beyond these would not end within any time budget: one CMA-ES
# generation, one location's samples or one action's tries would outlast it. Search
# processes beyond MAX_WORKERS would only wait on each other and the memory.
MAX_COUNT = 10_000
MAX_WORKERS = 64


def _fmt(values) -> str:
    # At most six values: a message is one short line, however long the list in the file.
    shown = [f"{v:g}" if isinstance(v, float) else repr(v) for v in values[:6]]
    return "[" + ", ".join(shown + (["..."] if len(values) > 6 else [])) + "]"


def _numbers(values: list[float], path: str, count: int, what: str = "numbers",
             positive: bool = False) -> None:
    if len(values) != count or (positive and any(v <= 0 for v in values)):
        kind = f"positive {what}" if positive else what
        raise ScenarioError(path, f"expected {count} {kind}, got {_fmt(values)}")


def _at_least(value: float, low: float, path: str, strict: bool = False) -> None:
    if value < low or (strict and value == low):
        relation = "greater than" if strict else "at least"
        raise ScenarioError(path, f"must be {relation} {low:g}, got {value:g}")


def _at_most(value: float, high: float, path: str) -> None:
    if value > high:
        raise ScenarioError(path, f"must be at most {high:g}, got {value:g}")


def _choice(value: str, choices, path: str, what: str) -> None:
    if value not in choices:
        raise ScenarioError(path, f"unknown {what} {quoted(value)} (expected one of: "
                                  f"{', '.join(choices)})")


def _name(name: str, path: str, seen: dict[str, str]) -> None:
    if not _NAME.fullmatch(name):  # match() with $ would let a name end in a newline
        raise ScenarioError(
            path, f"must start with a letter and hold only letters, digits and _, got "
                  f"{quoted(name)}")
    if "__" in name:  # the planner names place targets <object>__place (world/goals.py)
        raise ScenarioError(path, f"must not hold a double underscore, got {quoted(name)}")
    if name in seen:
        raise ScenarioError(path, f"duplicate name {name!r} (also {seen[name]})")
    seen[name] = path


def _inside_room(shape: Polygon, room: Polygon, path: str, what: str) -> None:
    if not shape.within(room):
        raise ScenarioError(path, f"{what} extends outside the room")


def _overlap(shape: Polygon, others: list[tuple[str, str, Polygon]], path: str, what: str):
    for other_name, other_path, other in others:
        if shape.intersection(other).area > _AREA_TOL:
            raise ScenarioError(path, f"{what} overlaps {other_name} ({other_path})")


def room_polygon(scenario: Scenario) -> Polygon:
    """The floor inside the walls."""
    return box(*scenario.room.bounds)


def validate_scenario(scenario: Scenario) -> None:
    """Raises ScenarioError for the first problem found, naming its field."""
    name = scenario.robot.name or DEFAULT_ROBOT  # a scenario made in code names none
    if name not in described_robots():
        raise ScenarioError("robot.name", f"no robot named {quoted(name)} (known: "
                                          f"{', '.join(described_robots())})")
    try:
        robot_value = load_robot(name)
    except RobotDescriptionError as e:  # a description being written: one line, as a field
        raise ScenarioError("robot.name", f"{quoted(name)}: models/{name}/{DESCRIPTION_FILE}: {e}"
                            ) from None
    _validate_settings(scenario)
    room = room_polygon(scenario)
    names: dict[str, str] = {}

    tables: list[tuple[str, str, Polygon]] = []
    for i, table in enumerate(scenario.tables):
        path = f"tables[{i}]"
        _name(table.name, f"{path}.name", names)
        _numbers(table.center, f"{path}.center", 2)
        _numbers(table.size, f"{path}.size", 3, positive=True)
        if not 0.3 <= table.height <= 1.5:
            raise ScenarioError(f"{path}.height", f"must be between 0.3 and 1.5 m, got "
                                                  f"{table.height:g}")
        if table.size[2] >= table.height:
            raise ScenarioError(f"{path}.size", "the top is thicker than the table is high")
        shape = table_footprint(table.center, table.yaw, table.size)
        _inside_room(shape, room, f"{path}.center", f"table {table.name!r}")
        _overlap(shape, tables, path, f"table {table.name!r}")
        tables.append((f"table {table.name!r}", path, shape))

    chairs: list[tuple[str, str, Polygon]] = []
    for i, chair in enumerate(scenario.chairs):
        path = f"chairs[{i}]"
        _name(chair.name, f"{path}.name", names)
        _numbers(chair.pose, f"{path}.pose", 3, what="numbers [x, y, yaw]")
        shape = chair_footprint(chair.pose)
        _inside_room(shape, room, f"{path}.pose", f"chair {chair.name!r}")
        _overlap(shape, tables, f"{path}.pose", f"chair {chair.name!r}")
        _overlap(shape, chairs, f"{path}.pose", f"chair {chair.name!r}")
        chairs.append((f"chair {chair.name!r}", path, shape))

    table_by_name = {t.name: t for t in scenario.tables}
    dishes: list[tuple[str, str, Polygon]] = []
    for i, dish in enumerate(scenario.dishes):
        path = f"dishes[{i}]"
        _name(dish.name, f"{path}.name", names)
        _choice(dish.kind, DISH_KINDS, f"{path}.kind", "kind")
        if dish.table not in table_by_name:
            known = ", ".join(table_by_name) or "none"
            raise ScenarioError(f"{path}.table", f"no table named {quoted(dish.table)} (tables: "
                                                 f"{known})")
        _numbers(dish.position, f"{path}.position", 2)
        if not 0.0 <= dish.elevation <= MAX_ELEVATION:
            raise ScenarioError(f"{path}.elevation", f"must be in [0, {MAX_ELEVATION:g}] m, got "
                                                     f"{dish.elevation:g}")
        table = table_by_name[dish.table]
        shape = dish_footprint(dish.position, dish.kind)
        top = table_footprint(table.center, table.yaw, table.size)
        if not shape.within(top):
            raise ScenarioError(f"{path}.position", f"{_fmt(dish.position)} is not on table "
                                                    f"{dish.table!r} (the whole {dish.kind} "
                                                    "must stand on its top)")
        _overlap(shape, dishes, f"{path}.position", f"{dish.kind} {dish.name!r}")
        dishes.append((f"dish {dish.name!r}", path, shape))
    _validate_goals(scenario, dishes)

    start = scenario.robot.start
    _numbers(start, "robot.start", 3, what="numbers [x, y, yaw]")
    robot = robot_value.footprint(*start).buffer(START_CLEARANCE, join_style="mitre")
    _inside_room(robot, room, "robot.start", f"the robot at {_fmt(start)}")
    _overlap(robot, tables + chairs, "robot.start", f"the robot at {_fmt(start)}")


def _validate_goals(scenario: Scenario, footprints: list[tuple[str, str, Polygon]]) -> None:
    """Each object's goal, and each place: on a table's top clear of the objects standing
    there (other than itself) and of the other places, or on an object left where it is
    that is at least as wide."""
    by_name = {d.name: d for d in scenario.dishes}
    tables = {t.name: t for t in scenario.tables}
    placed: list[tuple[str, str, Polygon]] = []
    for i, dish in enumerate(scenario.dishes):  # every goal first: a place reads another's
        _choice(dish.goal, GOALS, f"dishes[{i}].goal", "goal")
    for i, dish in enumerate(scenario.dishes):
        path = f"dishes[{i}]"
        place = dish.place
        given = bool(place.table or place.position or place.onto)
        if dish.goal != "place":
            if given:
                raise ScenarioError(f"{path}.place", f"only an object whose goal is place has "
                                                     f"one (this one's goal is {dish.goal})")
            continue
        if place.onto:
            if place.table or place.position:
                raise ScenarioError(f"{path}.place", "give either onto, or table and position")
            target = by_name.get(place.onto)
            if target is None or target is dish:
                raise ScenarioError(f"{path}.place.onto", f"no other object named "
                                                        f"{quoted(place.onto)}")
            if target.goal != "stay":
                raise ScenarioError(f"{path}.place.onto", f"{place.onto!r} does not stay where "
                                                          f"it is (its goal is {target.goal})")
            if DISH_SHAPES[dish.kind].radius > DISH_SHAPES[target.kind].radius:
                raise ScenarioError(f"{path}.place.onto", f"the {dish.kind} is wider than the "
                                                        f"{target.kind} {place.onto!r}")
            shape = dish_footprint(target.position, dish.kind)
        else:
            if place.table not in tables:
                known = ", ".join(tables) or "none"
                raise ScenarioError(f"{path}.place.table", f"no table named "
                                                           f"{quoted(place.table)} (tables: "
                                                           f"{known})")
            _numbers(place.position, f"{path}.place.position", 2)
            table = tables[place.table]
            shape = dish_footprint(place.position, dish.kind)
            if not shape.within(table_footprint(table.center, table.yaw, table.size)):
                raise ScenarioError(f"{path}.place.position",
                                    f"{_fmt(place.position)} is not on table "
                                    f"{place.table!r} (the whole {dish.kind} must stand on "
                                    "its top)")
            others = [f for f, d in zip(footprints, scenario.dishes, strict=True)
                      if d is not dish]
            _overlap(shape, others, f"{path}.place.position",
                     f"the place of {dish.kind} {dish.name!r}")
        _overlap(shape, placed, f"{path}.place", f"the place of {dish.kind} {dish.name!r}")
        placed.append((f"the place of {dish.name!r}", f"{path}.place", shape))


def _validate_settings(scenario: Scenario) -> None:
    # Numeric drawers (numpy's SeedSequence) take no negative seed.
    _at_least(scenario.seed, 0, "seed")
    bounds = scenario.room.bounds
    _numbers(bounds, "room.bounds", 4, what="numbers [x_min, y_min, x_max, y_max]")
    if bounds[2] - bounds[0] < 1.0 or bounds[3] - bounds[1] < 1.0:
        raise ScenarioError("room.bounds", f"the room must be at least 1 m x 1 m, got "
                                           f"{_fmt(bounds)}")
    _at_least(scenario.room.wall_height, 0.0, "room.wall_height", strict=True)
    _at_least(scenario.room.wall_thickness, 0.0, "room.wall_thickness", strict=True)

    p = scenario.planner
    _choice(p.method, METHODS, "planner.method", "method")
    _choice(p.feasibility, FEASIBILITY_SOURCES, "planner.feasibility", "source")
    _choice(p.cost_profile, COST_PROFILES, "planner.cost_profile", "profile")
    _choice(p.group_positions, GROUP_POSITIONS, "planner.group_positions", "rule")
    _choice(p.location_price, LOCATION_PRICES, "planner.location_price", "price")
    _choice(p.failure_price, FAILURE_PRICES, "planner.failure_price", "price")
    _choice(p.shared_stop, SHARED_STOPS, "planner.shared_stop", "rating")
    if p.time_model and not Path(p.time_model).is_file():
        raise ScenarioError("planner.time_model", f"no such file: {quoted(p.time_model)}")
    _at_least(p.top_k, 1, "planner.top_k")
    _at_least(p.cma_generations, 1, "planner.cma_generations")
    _at_least(p.cma_population, 2, "planner.cma_population")
    _at_least(p.location_samples, 1, "planner.location_samples")
    _at_least(p.workers, 1, "planner.workers")
    _at_most(p.workers, MAX_WORKERS, "planner.workers")
    for name in ("top_k", "cma_generations", "cma_population", "location_samples"):
        _at_most(getattr(p, name), MAX_COUNT, f"planner.{name}")
    for name in ("delta", "gamma", "reward"):
        _at_least(getattr(p, name), 0.0, f"planner.{name}")
    for name in ("speed", "reach", "time_budget"):
        if getattr(p, name) is not None:  # no reach: the robot's
            _at_least(getattr(p, name), 0.0, f"planner.{name}", strict=True)

    u = scenario.uncertainty
    for name in ("nav_xy_std", "nav_yaw_std", "reach_std", "localization_xy_std",
                 "localization_yaw_std"):
        _at_least(getattr(u, name), 0.0, f"uncertainty.{name}")
    _choice(u.localization, LOCALIZATIONS, "uncertainty.localization", "localization")

    e = scenario.execution
    _choice(e.recovery, RECOVERY_MODES, "execution.recovery", "mode")
    _choice(e.motion, MOTIONS, "execution.motion", "motion")
    if not 0.0 <= e.min_feasibility <= 1.0:
        raise ScenarioError("execution.min_feasibility",
                            f"must be a probability in [0, 1], got {e.min_feasibility:g}")
    _at_least(e.correction_radius, 0.0, "execution.correction_radius")
    _at_least(e.max_corrections, 0, "execution.max_corrections")
    _at_least(e.max_tries, 1, "execution.max_tries")
    _at_least(e.max_replans, 0, "execution.max_replans")
    _at_least(e.replan_budget, 0.0, "execution.replan_budget", strict=True)
    for name in ("max_corrections", "max_tries", "max_replans"):
        _at_most(getattr(e, name), MAX_COUNT, f"execution.{name}")
    if "\0" in scenario.outputs.directory:  # no file system takes it in a path
        raise ScenarioError("outputs.directory", "must not hold a NUL character")

    c = scenario.camera
    tallest = max([t.height for t in scenario.tables] + [scenario.room.wall_height])
    if c.height <= tallest + 0.5:
        raise ScenarioError("camera.height", f"must be at least 0.5 m above the tallest "
                                             f"furniture ({tallest:g} m), got {c.height:g}")
    _at_least(c.pixels_per_meter, 0.0, "camera.pixels_per_meter", strict=True)
    _at_least(c.margin, 0.0, "camera.margin")
    extent = max(bounds[2] - bounds[0], bounds[3] - bounds[1]) + 2 * c.margin
    if extent * c.pixels_per_meter > 4096:
        raise ScenarioError("camera.pixels_per_meter", f"the image would be "
                                                       f"{extent * c.pixels_per_meter:.0f} px "
                                                       "across; at most 4096")

    s = scenario.simulation
    step = scenario.plant.time_step
    if not 0 < step <= 0.05:
        raise ScenarioError("plant.time_step", f"must be in (0, 0.05] s (a discrete plant), "
                                               f"got {step:g}")
    approximations = ("tamsi", "sap", "similar", "lagged")
    _choice(scenario.plant.discrete_contact_approximation, approximations,
            "plant.discrete_contact_approximation", "approximation")
    from pydrake.systems.analysis import GetIntegrationSchemes

    _choice(scenario.simulator.integration_scheme, GetIntegrationSchemes(),
            "simulator.integration_scheme", "scheme")
    _at_least(scenario.simulator.target_realtime_rate, 0.0, "simulator.target_realtime_rate")
    _at_least(s.hold_time, 0.0, "simulation.hold_time")
    _at_least(scenario.visualization.publish_period, 0.0, "visualization.publish_period",
              strict=True)
    _at_least(scenario.visualization.initial_proximity_alpha, 0.0,
              "visualization.initial_proximity_alpha")


