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
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import yaml
from pydrake.common.yaml import yaml_dump_typed, yaml_load_typed

from s3o_drake.world.choices import (  # noqa: F401 (re-exported: the fields hold these values)
    COST_PROFILES,
    FEASIBILITY_SOURCES,
    METHODS,
    RECOVERY_MODES,
    FeasibilitySource,
    Goal,
    Recovery,
)
from s3o_drake.world.scenario_checks import (  # noqa: F401 (re-exported: callers catch and call them)
    START_CLEARANCE,
    ScenarioError,
    room_polygon,
    validate_scenario,
)
from s3o_drake.world.yaml_checks import (
    FieldError,
    check_structure,
    load_yaml,
)


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
class Place:
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
    place: Place = field(default_factory=Place)
    elevation: float = 0.0
    """Height (m) above the table's top of the surface the object stands on: 0, the top
    itself; for an object put onto another, that object's height (world/goals.py)."""


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
    group_positions: str = "per_dish"
    """How Fea^t of a merged location draws its N positions (abstraction/task_feasibility.py):
    "per_dish", for each dish by its own Fea^m (the paper's code); "shared", by the group's
    joint value, every dish evaluated at the same positions (the one stop that serves it)."""
    search_plain_voronoi: bool = False
    """S3O-GROP* and S3O-GROP also search the unmerged state space when it is not among
    their top K."""
    location_price: str = "paper"
    """The ranking's price of a location, c in Score - c|L|: "paper", γ / λ of the fields
    below; "search", the γ / λ of the motion search's cost profile."""
    failure_price: str = "paper"
    """What a pickup's chance of failing costs the utility, λ (1 - Fea^m): "paper", λ below
    whatever the execution does; "execution", λ in open loop (a failed pickup loses the
    dish) and the recovery's recorded time per failure with recovery
    (models/failure_price.yaml)."""
    time_budget: float = 300.0
    """Wall-clock cap on planning (s)."""
    workers: int = 2
    feasibility: str = "fcn"
    """Source of the Fea^m heatmaps: "fcn" (the network in models/fcn/, from the overhead
    depth image) or "oracle" (the Drake check under the noise model, on the known world).
    The default is measured: on 6 held-out tasks S3O-GROP* completed 3 with the network and
    none with the oracle, collected 85% against 64% of the dishes, and planned in 4.9 s
    against 8.5 s (`s3o bench compare-feasibility --count 6`): CMA-ES
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
    detour: bool = True
    """When no stop within correction_radius reaches min_feasibility, a correction may
    drive round to the dish's best stop anywhere on its heatmap."""
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


def surface_height(scenario: Scenario, dish: Dish) -> float:
    """World z (m) of the surface `dish` stands on: its table's top plus its elevation."""
    table = next(t for t in scenario.tables if t.name == dish.table)
    return table.height + dish.elevation


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


def with_overrides(scenario: Scenario, overrides: Sequence[str]) -> Scenario:
    """The scenario with fields replaced, each override `PATH=VALUE` (`planner.top_k=8`,
    `tables[0].height=0.8`; VALUE is YAML), validated like the file: a bad path or value is
    a ScenarioError naming the field."""
    if not overrides:
        return scenario
    data = load_yaml(dump_scenario(scenario))
    for item in overrides:
        path, sep, value = item.partition("=")
        path = path.strip()
        if not sep or not path:
            raise ScenarioError("--set", f"expected PATH=VALUE, got {item!r}")
        try:
            parsed = load_yaml(value) if value.strip() else ""
        except FieldError as e:
            raise ScenarioError(path, f"not a YAML value: {e.message}") from None
        parts = [p for p in re.split(r"\.|\[(\d+)\]", path) if p]
        node = data
        for k, part in enumerate(parts):
            where = ".".join(parts[:k + 1])
            last = k == len(parts) - 1
            if isinstance(node, list):
                if not part.isdigit() or int(part) >= len(node):
                    raise ScenarioError(path, f"no item {part} in {where.rsplit('.', 1)[0]} "
                                              f"({len(node)} items)")
                key: int | str = int(part)
            elif isinstance(node, dict):
                if not last and part not in node:
                    raise ScenarioError(path, f"unknown field {part!r}")
                key = part
            else:
                raise ScenarioError(path, f"{where.rsplit('.', 1)[0]} has no fields")
            if last:
                node[key] = parsed
            else:
                node = node[key]
    return parse_scenario(yaml.safe_dump(data, sort_keys=False))


def dump_scenario(scenario: Scenario) -> str:
    """The scenario as YAML text that `parse_scenario` reads back to an equal Scenario."""
    return yaml_dump_typed(scenario)


def scenario_stem(path: str | Path) -> str:
    """The name a scenario's outputs go under: its file name without the extension."""
    return Path(path).stem
