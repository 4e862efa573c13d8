"""Scenario files: the schema as dataclasses, loading them from YAML, and their validation.

A scenario is one task: the room, its furniture, the dishes to collect, the robot's start,
and the settings of the planner, the uncertainty model, the camera, the simulation and the
outputs. `load_scenario` reads a YAML file with pydrake's `yaml_load_typed` after checking
its structure against these dataclasses, then checks what the types cannot say
(`validate_scenario`: sizes positive, names unique, references resolvable, every dish on its
table, no furniture overlapping other furniture or the walls, the robot starting free), so
that every problem is reported as one `ScenarioError` that
names the field (`tables[2].size: expected 3 positive numbers, got [1.2, -0.8]`).

Vectors are lists (yaml_load_typed supports neither tuples nor Literal); units are SI,
angles radians, positions in the world frame W (z up, the floor at z = 0).
"""

import re
from dataclasses import dataclass, field
from pathlib import Path

from pydrake.common.yaml import yaml_dump_typed, yaml_load_typed
from shapely.geometry import Polygon, box

from s3o_drake.choices import (  # noqa: F401 (re-exported: the fields hold these values)
    COST_PROFILES,
    FEASIBILITY_SOURCES,
    METHODS,
    RECOVERY_MODES,
    FeasibilitySource,
    Recovery,
)
from s3o_drake.furniture import DISH_KINDS, chair_footprint, dish_footprint, table_footprint
from s3o_drake.robot import footprint_polygon
from s3o_drake.yaml_checks import (
    FieldError,
    check_structure,
    load_yaml,
    quoted,
)


class ScenarioError(ValueError):
    """A problem with a scenario, located by its field path (`dishes[3].table`) and, when it
    was read from a file, the file (`load_scenario`): str() names each once, as
    `file: field: problem`."""

    def __init__(self, path: str, message: str, file: str = ""):
        super().__init__(": ".join(part for part in (file, path, message) if part))
        self.path = path
        self.message = message
        self.file = file


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


@dataclass
class Dish:
    """A dish to collect: standing on the top of `table`."""

    name: str = ""
    table: str = ""
    position: list[float] = field(default_factory=lambda: [0.0, 0.0])
    """[x, y] of the dish's centre in the world (m); z is the table's height."""
    kind: str = "plate"
    """plate | bowl | cup"""


@dataclass
class Robot:
    start: list[float] = field(default_factory=lambda: [1.0, 1.0, 0.0])
    """[x, y, yaw] of the base at the start."""


@dataclass
class Planner:
    """Planning settings; defaults are the paper's."""

    method: str = "S3O-GROP*"
    top_k: int = 5
    cma_generations: int = 20
    cma_population: int = 10
    cost_profile: str = "robot"
    """The utility's costs (planning/time_model.py): "robot", the execution's predicted
    time (the base navigator's motion profile along the path, turns included, and the
    recorded pickup and command times of models/time_model.yaml); or "paper", the paper's
    Cst(goto) = len / v + γ and δ below."""
    delta: float = 5.0
    """δ: constant cost of a pickup (the "paper" cost profile)."""
    gamma: float = 20.0
    """γ: constant cost of starting to drive (the "paper" cost profile)."""
    reward: float = 150.0
    """λ: reward of a successful pickup, weighted by its feasibility."""
    speed: float = 0.4
    """v: the base's cruise speed (m/s): the navigator drives at it, and both cost profiles
    cost navigation with it."""
    reach: float = 1.0
    """How far from the base centre the robot can pick a dish (m)."""
    location_samples: int = 100
    """N: positions drawn from a location to estimate its task-level feasibility."""
    time_budget: float = 300.0
    """Wall-clock cap on planning (s)."""
    workers: int = 2
    feasibility: str = "fcn"
    """Source of the Fea^m heatmaps: "fcn" (the network in models/fcn/, from the overhead
    depth image) or "oracle" (the Drake check under the noise model, on the known world).
    The default is measured: on 6 held-out tasks S3O-GROP* completed 3 with the network and
    none with the oracle, collected 85% against 64% of the dishes, and planned in 4.9 s
    against 8.5 s (`python -m s3o_drake.commands.compare_feasibility --tasks 6`): CMA-ES
    maximising the oracle's 5-sample estimates picks spots that were lucky (docs/fcn.md)."""


@dataclass
class Uncertainty:
    """Gaussian noise of navigation (T^n) and reaching (T^m), as standard deviations."""

    nav_xy_std: float = 0.10
    nav_yaw_std: float = 0.05
    reach_std: float = 0.01
    localization_xy_std: float = 0.02
    """How far off (m, per axis) the robot's estimate of its own pose is after it lands:
    what the recovery's stop check believes (execution.recovery)."""
    localization_yaw_std: float = 0.02
    """The same for the heading (rad)."""


@dataclass
class Camera:
    """The overhead camera, above the room's centre looking straight down."""

    height: float = 10.0
    pixels_per_meter: float = 50.0
    """Image resolution at floor level; the field of view covers the room and the margin."""
    margin: float = 0.3


@dataclass
class Simulation:
    time_step: float = 0.01
    """The discrete plant's step (s). SAP treats the joints' PD actuators implicitly; the arm
    follows its trajectory one step behind (at most π rad/s x 0.01 s, nothing at the rests
    where it grasps and releases). At 0.02 s runs were 1.5x faster but SAP failed to
    converge in 2 of 16 runs (a robot at rest, no contact), so 0.01 s it is."""
    hold_time: float = 1.0
    """How long the simulation runs on after the plan has ended (s), so that the playback
    shows the robot at rest with what it collected."""
    publish_period: float = 0.2
    """Frame period of the Meshcat recording (s). The page interpolates between frames, so
    5 frames per second look smooth at the robot's speeds (0.4 m/s; the arm up to π rad/s);
    a five-minute execution's playback page stays near 6.5 MB (docs/execution.md), and each
    frame costs simulation time."""


@dataclass
class ExecutionSettings:
    """What execution does when an action fails (see `Recovery`), and its limits."""

    recovery: str = "replan"
    """none | retry | replan. `run` uses it as given; `evaluate` runs its own --recovery
    (default none, the paper's protocol)."""
    min_feasibility: float = 0.5
    """A stop whose Fea^m, at the localised pose, is below this is corrected before the
    pickup."""
    correction_radius: float = 0.3
    """How far (m) a corrective move may go from the localised pose."""
    max_corrections: int = 2
    """Corrective moves before one pickup attempt, at most."""
    max_tries: int = 3
    """Pickup attempts per dish and plan, at most."""
    max_replans: int = 4
    """Replans per run, at most."""
    replan_budget: float = 60.0
    """Wall-clock cap (s) on one replan (the first plan has planner.time_budget)."""


@dataclass
class Outputs:
    directory: str = ""
    """Output folder; empty means out/<scenario file stem>/."""
    playback: bool = True
    overhead: bool = True
    feasibility: bool = True
    """Draw each dish's Fea^m heatmap (feasibility.png)."""
    state_space: bool = True
    """Draw the S3O state space the plan searched, with its rank (state_space.png)."""


@dataclass
class Scenario:
    seed: int = 0
    """Drives every random draw of a run."""
    room: Room = field(default_factory=Room)
    tables: list[Table] = field(default_factory=list)
    chairs: list[Chair] = field(default_factory=list)
    dishes: list[Dish] = field(default_factory=list)
    robot: Robot = field(default_factory=Robot)
    planner: Planner = field(default_factory=Planner)
    uncertainty: Uncertainty = field(default_factory=Uncertainty)
    camera: Camera = field(default_factory=Camera)
    simulation: Simulation = field(default_factory=Simulation)
    execution: ExecutionSettings = field(default_factory=ExecutionSettings)
    outputs: Outputs = field(default_factory=Outputs)


# Validation: the rules a scenario's values must meet, each error naming its field.

_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")
# Overlaps smaller than this (m^2) are numerical contact, not interpenetration.
_AREA_TOL = 1e-6
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
        _choice(dish.kind, DISH_KINDS, f"{path}.kind", "kind")
        if dish.table not in table_by_name:
            known = ", ".join(table_by_name) or "none"
            raise ScenarioError(f"{path}.table", f"no table named {quoted(dish.table)} (tables: "
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
        _at_least(getattr(p, name), 0.0, f"planner.{name}", strict=True)

    u = scenario.uncertainty
    for name in ("nav_xy_std", "nav_yaw_std", "reach_std", "localization_xy_std",
                 "localization_yaw_std"):
        _at_least(getattr(u, name), 0.0, f"uncertainty.{name}")

    e = scenario.execution
    _choice(e.recovery, RECOVERY_MODES, "execution.recovery", "mode")
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
    if not 0 < s.time_step <= 0.05:
        raise ScenarioError("simulation.time_step", f"must be in (0, 0.05] s, got "
                                                    f"{s.time_step:g}")
    _at_least(s.hold_time, 0.0, "simulation.hold_time")
    _at_least(s.publish_period, 0.0, "simulation.publish_period", strict=True)


def parse_scenario(text: str) -> Scenario:
    """Parses and validates scenario YAML text; raises ScenarioError."""
    try:
        raw = load_yaml(text)
        if raw is None:  # an empty or comment-only file: every field has its default
            raw, text = {}, "{}"
        check_structure(raw, Scenario, "")
        scenario = yaml_load_typed(schema=Scenario, data=text)
    except FieldError as e:
        raise ScenarioError(e.path, e.message) from None
    except (RuntimeError, ValueError) as e:  # the checks should have caught it; keep one line
        raise ScenarioError("", str(e).splitlines()[0]) from None
    validate_scenario(scenario)
    return scenario


def load_scenario(path: str | Path) -> Scenario:
    """Loads and validates a scenario file; raises ScenarioError naming the file and the field.
    An empty or comment-only file is all defaults, as `{}` is."""
    path = Path(path)
    if path.is_dir():
        raise ScenarioError("", "is a folder, not a scenario file", file=str(path))
    if not path.is_file():
        raise ScenarioError("", "no such scenario file", file=str(path))
    try:
        data = path.read_bytes()
    except OSError as e:
        raise ScenarioError("", f"cannot read: {e.strerror or e}", file=str(path)) from None
    try:
        text = data.decode("utf-8")  # YAML's encoding, whatever the locale's is
    except UnicodeDecodeError as e:
        line = data.count(b"\n", 0, e.start) + 1
        raise ScenarioError(f"line {line}", f"not UTF-8 text (byte 0x{data[e.start]:02x} at "
                                            f"offset {e.start})", file=str(path)) from None
    try:
        return parse_scenario(text)
    except ScenarioError as e:
        raise ScenarioError(e.path, e.message, file=str(path)) from None


def dump_scenario(scenario: Scenario) -> str:
    """The scenario as YAML text that `parse_scenario` reads back to an equal Scenario."""
    return yaml_dump_typed(scenario)


def scenario_stem(path: str | Path) -> str:
    """The name a scenario's outputs go under: its file name without the extension."""
    return Path(path).stem
