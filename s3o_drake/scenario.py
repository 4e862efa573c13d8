"""Scenario files: the schema as dataclasses, and loading them from YAML.

A scenario is one task: the room, its furniture, the dishes to collect, the robot's start,
and the settings of the planner, the uncertainty model, the camera, the simulation and the
outputs. `load_scenario` reads a YAML file with pydrake's `yaml_load_typed` after checking
its structure against these dataclasses, then checks values and geometry
(`s3o_drake.validation`), so that every problem is reported as one `ScenarioError` that
names the field (`tables[2].size: expected 3 positive numbers, got [1.2, -0.8]`).

Vectors are lists (yaml_load_typed supports neither tuples nor Literal); units are SI,
angles radians, positions in the world frame W (z up, the floor at z = 0).
"""

import dataclasses
import math
import typing
from dataclasses import dataclass, field
from pathlib import Path

import yaml
from pydrake.common.yaml import yaml_dump_typed, yaml_load_typed

# The methods of the paper's comparison (DESIGN.md section 2).
METHODS = ("S3O-GROP*", "S3O-GROP", "V-GROP*", "V-GROP", "V-PETLON", "S3O-Random")
# Where the planner's Fea^m heatmaps come from: the Drake check, or the learned network.
FEASIBILITY_SOURCES = ("oracle", "fcn")
# The utility's costs: our robot's recorded time model, or the paper's values.
COST_PROFILES = ("robot", "paper")


class ScenarioError(ValueError):
    """A problem with a scenario, located by its field path (`dishes[3].table`)."""

    def __init__(self, path: str, message: str):
        super().__init__(f"{path}: {message}" if path else message)
        self.path = path
        self.message = message


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
    """Planning settings; defaults are the paper's (DESIGN.md section 2)."""

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
class Outputs:
    directory: str = ""
    """Output folder; empty means out/<scenario file stem>/."""
    playback: bool = True
    overhead: bool = True
    feasibility: bool = True
    """Draw each dish's Fea^m heatmap (feasibility.png)."""
    state_space: bool = True
    """Draw the top-ranked S3O state space over the heatmaps (state_space.png)."""


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
    outputs: Outputs = field(default_factory=Outputs)


def _type_name(value) -> str:
    return "null" if value is None else type(value).__name__


def _check_structure(value, schema, path: str) -> None:
    """Checks raw YAML data against a schema type; raises ScenarioError with the path."""
    origin = typing.get_origin(schema)
    if dataclasses.is_dataclass(schema):
        if not isinstance(value, dict):
            raise ScenarioError(path, f"expected a mapping of fields, got {value!r}")
        fields = {f.name: f for f in dataclasses.fields(schema)}
        hints = typing.get_type_hints(schema)
        for key, item in value.items():
            child = f"{path}.{key}" if path else str(key)
            if key not in fields:
                known = ", ".join(fields)
                raise ScenarioError(child, f"unknown field (known fields: {known})")
            _check_structure(item, hints[key], child)
    elif origin is list:
        (item_type,) = typing.get_args(schema)
        if not isinstance(value, list):
            raise ScenarioError(path, f"expected a list, got {value!r}")
        for i, item in enumerate(value):
            _check_structure(item, item_type, f"{path}[{i}]")
    elif schema is bool:
        if not isinstance(value, bool):
            raise ScenarioError(path, f"expected true or false, got {value!r}")
    elif schema is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ScenarioError(path, f"expected an integer, got {value!r}")
    elif schema is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ScenarioError(path, f"expected a number, got {value!r}")
    elif schema is str:
        if not isinstance(value, str):
            raise ScenarioError(path, f"expected a string, got {_type_name(value)} {value!r}")
    else:  # pragma: no cover - a schema type this checker does not know
        raise TypeError(f"unsupported schema type {schema} at {path}")


def _check_finite(value, path: str) -> None:
    """NaN or inf anywhere is an error, whatever the field."""
    if dataclasses.is_dataclass(value):
        for f in dataclasses.fields(value):
            _check_finite(getattr(value, f.name), f"{path}.{f.name}" if path else f.name)
    elif isinstance(value, list):
        for i, item in enumerate(value):
            _check_finite(item, f"{path}[{i}]")
    elif isinstance(value, float) and not math.isfinite(value):
        raise ScenarioError(path, f"must be a finite number, got {value}")


def parse_scenario(text: str) -> Scenario:
    """Parses and validates scenario YAML text; raises ScenarioError."""
    try:
        raw = yaml.safe_load(text)
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        where = f"line {mark.line + 1}" if mark is not None else "YAML"
        problem = getattr(e, "problem", None) or str(e).splitlines()[0]
        raise ScenarioError(where, f"not valid YAML: {problem}") from None
    if raw is None:
        raw = {}
    _check_structure(raw, Scenario, "")
    try:
        scenario = yaml_load_typed(schema=Scenario, data=text)
    except RuntimeError as e:  # the structure check should have caught it; keep one line
        raise ScenarioError("", str(e).splitlines()[0]) from None
    _check_finite(scenario, "")
    # Imported here: validation needs the schema above.
    from s3o_drake.validation import validate_scenario

    validate_scenario(scenario)
    return scenario


def load_scenario(path: str | Path) -> Scenario:
    """Loads and validates a scenario file; raises ScenarioError naming the field."""
    path = Path(path)
    if not path.is_file():
        raise ScenarioError(str(path), "no such scenario file")
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as e:
        raise ScenarioError(str(path), f"cannot read: {e}") from None
    return parse_scenario(text)


def dump_scenario(scenario: Scenario) -> str:
    """The scenario as YAML text that `parse_scenario` reads back to an equal Scenario."""
    return yaml_dump_typed(scenario)


def scenario_stem(path: str | Path) -> str:
    """The name a scenario's outputs go under: its file name without the extension."""
    return Path(path).stem
