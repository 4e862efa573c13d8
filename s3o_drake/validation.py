"""Checks of a scenario's values and geometry, each error naming its field.

Structure and types are checked while loading (`s3o_drake.scenario`); this module checks
what the types cannot say: sizes positive, names unique, references resolvable, and the
geometry consistent (every dish on its table, no furniture overlapping other furniture or
the walls, the robot starting free).
"""

import re

from shapely.geometry import Polygon, box

from s3o_drake.furniture import DISH_KINDS, chair_footprint, dish_footprint, table_footprint
from s3o_drake.robot import footprint_polygon
from s3o_drake.scenario import (
    COST_PROFILES,
    FEASIBILITY_SOURCES,
    METHODS,
    Scenario,
    ScenarioError,
)

_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")
# Overlaps smaller than this (m^2) are numerical contact, not interpenetration.
_AREA_TOL = 1e-6
# Free space the robot needs around its footprint at the start (m).
START_CLEARANCE = 0.02


def _fmt(values) -> str:
    return "[" + ", ".join(f"{v:g}" if isinstance(v, float) else repr(v) for v in values) + "]"


def _numbers(values: list[float], path: str, count: int, what: str = "numbers",
             positive: bool = False) -> None:
    if len(values) != count or (positive and any(v <= 0 for v in values)):
        kind = f"positive {what}" if positive else what
        raise ScenarioError(path, f"expected {count} {kind}, got {_fmt(values)}")


def _at_least(value: float, low: float, path: str, strict: bool = False) -> None:
    if value < low or (strict and value == low):
        relation = "greater than" if strict else "at least"
        raise ScenarioError(path, f"must be {relation} {low:g}, got {value:g}")


def _name(name: str, path: str, seen: dict[str, str]) -> None:
    if not _NAME.match(name):
        raise ScenarioError(
            path, f"must start with a letter and hold only letters, digits and _, got {name!r}")
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
        if dish.kind not in DISH_KINDS:
            raise ScenarioError(f"{path}.kind", f"unknown kind {dish.kind!r} "
                                                f"(expected one of: {', '.join(DISH_KINDS)})")
        if dish.table not in table_by_name:
            known = ", ".join(table_by_name) or "none"
            raise ScenarioError(f"{path}.table", f"no table named {dish.table!r} (tables: "
                                                 f"{known})")
        _numbers(dish.position, f"{path}.position", 2)
        table = table_by_name[dish.table]
        shape = dish_footprint(dish.position, dish.kind)
        top = table_footprint(table.center, table.yaw, table.size)
        if not shape.within(top):
            raise ScenarioError(f"{path}.position", f"{_fmt(dish.position)} is not on table "
                                                    f"{dish.table!r} (the whole {dish.kind} "
                                                    "must stand on its top)")
        _overlap(shape, dishes, f"{path}.position", f"{dish.kind} {dish.name!r}")
        dishes.append((f"dish {dish.name!r}", path, shape))

    start = scenario.robot.start
    _numbers(start, "robot.start", 3, what="numbers [x, y, yaw]")
    robot = footprint_polygon(*start).buffer(START_CLEARANCE, join_style="mitre")
    _inside_room(robot, room, "robot.start", f"the robot at {_fmt(start)}")
    _overlap(robot, tables + chairs, "robot.start", f"the robot at {_fmt(start)}")


def _validate_settings(scenario: Scenario) -> None:
    bounds = scenario.room.bounds
    _numbers(bounds, "room.bounds", 4, what="numbers [x_min, y_min, x_max, y_max]")
    if bounds[2] - bounds[0] < 1.0 or bounds[3] - bounds[1] < 1.0:
        raise ScenarioError("room.bounds", f"the room must be at least 1 m x 1 m, got "
                                           f"{_fmt(bounds)}")
    _at_least(scenario.room.wall_height, 0.0, "room.wall_height", strict=True)
    _at_least(scenario.room.wall_thickness, 0.0, "room.wall_thickness", strict=True)

    p = scenario.planner
    if p.method not in METHODS:
        raise ScenarioError("planner.method", f"unknown method {p.method!r} (expected one of: "
                                              f"{', '.join(METHODS)})")
    if p.feasibility not in FEASIBILITY_SOURCES:
        raise ScenarioError("planner.feasibility", f"unknown source {p.feasibility!r} (expected "
                                                   f"one of: {', '.join(FEASIBILITY_SOURCES)})")
    if p.cost_profile not in COST_PROFILES:
        raise ScenarioError("planner.cost_profile", f"unknown profile {p.cost_profile!r} "
                                                    f"(expected one of: "
                                                    f"{', '.join(COST_PROFILES)})")
    _at_least(p.top_k, 1, "planner.top_k")
    _at_least(p.cma_generations, 1, "planner.cma_generations")
    _at_least(p.cma_population, 2, "planner.cma_population")
    _at_least(p.location_samples, 1, "planner.location_samples")
    _at_least(p.workers, 1, "planner.workers")
    for name in ("delta", "gamma", "reward"):
        _at_least(getattr(p, name), 0.0, f"planner.{name}")
    for name in ("speed", "reach", "time_budget"):
        _at_least(getattr(p, name), 0.0, f"planner.{name}", strict=True)

    u = scenario.uncertainty
    for name in ("nav_xy_std", "nav_yaw_std", "reach_std"):
        _at_least(getattr(u, name), 0.0, f"uncertainty.{name}")

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
    if not 0 < s.time_step <= 0.05:
        raise ScenarioError("simulation.time_step", f"must be in (0, 0.05] s, got "
                                                    f"{s.time_step:g}")
    _at_least(s.hold_time, 0.0, "simulation.hold_time")
    _at_least(s.publish_period, 0.0, "simulation.publish_period", strict=True)
