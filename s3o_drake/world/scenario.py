"""Scenario files: one task, the true world and its settings, as YAML; loading them, their
validation, overrides from the command line.

A scenario is one task: the room, its furniture, the objects to collect or place, the
robot's start, and the settings of the planner, the uncertainty model, the camera, the
simulation, the execution and the outputs. The schema's parts live where they belong
(`map.py`: room, tables, chairs; `objects.py`: the objects; `settings.py`: the parameters);
`Scenario` puts them together as the file has them. `load_scenario` reads a YAML file with
pydrake's `yaml_load_typed` after checking its structure against these dataclasses, then
checks what the types cannot say (`validate_scenario`: sizes positive, names unique,
references resolvable, every dish on its table, no furniture overlapping other furniture or
the walls, the robot starting free), so that every problem is reported as one
`ScenarioError` that names the field (`tables[2].size: expected 3 positive numbers, got
[1.2, -0.8]`).

A Scenario is the truth: the simulator builds it. Planning never receives one; it receives a
`belief.known_world.KnownWorld` made of `map`, `settings`, the task's objects and what
perception reports.

Vectors are lists (yaml_load_typed supports neither tuples nor Literal); units are SI,
angles radians, positions in the world frame W (z up, the floor at z = 0).
"""

import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import yaml
from pydrake.common.yaml import yaml_dump_typed, yaml_load_typed
from pydrake.multibody.plant import MultibodyPlantConfig
from pydrake.systems.analysis import SimulatorConfig
from pydrake.visualization import VisualizationConfig

from s3o_drake.world.contents import SceneContents
from s3o_drake.world.map import Chair, Map, Room, Table
from s3o_drake.world.objects import Dish
from s3o_drake.world.resources import DEFAULT_ROBOT
from s3o_drake.world.robot import Robot, load_robot
from s3o_drake.world.scenario_checks import ScenarioError, validate_scenario
from s3o_drake.world.settings import (
    Camera,
    ExecutionSettings,
    Outputs,
    PlanningSettings,
    RobotSection,
    Settings,
    Simulation,
    Uncertainty,
)
from s3o_drake.world.yaml_checks import (
    FieldError,
    check_structure,
    load_yaml,
)

PLANT_TIME_STEP = 0.01
"""The plant's step (s) unless the scenario says otherwise (`Scenario.plant`)."""
PUBLISH_PERIOD = 0.2
"""The Meshcat recording's frame period (s) unless the scenario says otherwise
(`Scenario.visualization`). The page interpolates between frames, so 5 frames per second
look smooth at the robot's speeds (0.4 m/s; the arm up to π rad/s); a five-minute
execution's playback page stays near 6.5 MB (docs/execution.md), and each frame costs
simulation time."""


def _visualization() -> VisualizationConfig:
    return VisualizationConfig(publish_period=PUBLISH_PERIOD, publish_contacts=False,
                               publish_inertia=False, enable_meshcat_creation=False)


@dataclass
class Scenario:
    """One task as its file gives it: the true world (the room, every table, chair and
    object, the robot's start) and the settings. The simulator builds the truth; the robot
    is given `map` and `settings` and the task's objects, and perceives the rest."""

    seed: int = 0
    """Drives every random draw of a run."""
    room: Room = field(default_factory=Room)
    tables: list[Table] = field(default_factory=list)
    chairs: list[Chair] = field(default_factory=list)
    dishes: list[Dish] = field(default_factory=list)
    robot: RobotSection = field(default_factory=RobotSection)
    planner: PlanningSettings = field(default_factory=PlanningSettings)
    uncertainty: Uncertainty = field(default_factory=Uncertainty)
    camera: Camera = field(default_factory=Camera)
    simulation: Simulation = field(default_factory=Simulation)
    simulator: SimulatorConfig = field(default_factory=SimulatorConfig)
    """Drake's simulator settings (`ApplySimulatorConfig`); `run --meshcat` paces it at real
    time whatever `target_realtime_rate` says. The plant is discrete: the integrator has no
    continuous state to advance."""
    plant: MultibodyPlantConfig = field(default_factory=lambda: MultibodyPlantConfig(
        time_step=PLANT_TIME_STEP, discrete_contact_approximation="sap"))
    """Drake's MultibodyPlant settings (`AddMultibodyPlant`). SAP treats the joints' PD
    actuators implicitly; the arm follows its trajectory one step behind (at most π rad/s x
    0.01 s, nothing at the rests where it grasps and releases). At a step of 0.02 s runs were
    1.5x faster but SAP failed to converge in 2 of 16 runs (a robot at rest, no contact), so
    0.01 s it is."""
    visualization: VisualizationConfig = field(default_factory=_visualization)
    """Drake's visualization settings (`ApplyVisualizationConfig`), for the Meshcat that
    `run` records the playback in (and shows live with --meshcat); without a Meshcat (the
    studies' runs) nothing is visualized. The illustration is what the playback records;
    the proximity geometry is shown in a live view only (hidden until toggled: it costs a
    quarter of a step's time); contact forces and inertia are off. Drake's LCM visualizers
    publish nowhere: the project's views are Meshcat's."""
    execution: ExecutionSettings = field(default_factory=ExecutionSettings)
    outputs: Outputs = field(default_factory=Outputs)

    def __eq__(self, other: object) -> bool:
        # Drake's config structs compare by identity: two scenarios are equal when their
        # files say the same.
        if not isinstance(other, Scenario):
            return NotImplemented
        return dump_scenario(self) == dump_scenario(other)

    __hash__ = None  # mutable, as a dataclass with eq is

    def __reduce__(self):
        # Drake's config structs do not pickle: a scenario goes to a worker as its file.
        return parse_scenario, (dump_scenario(self),)

    @property
    def map(self) -> Map:
        """What the robot's map holds: the room, the tables, the mapped chairs."""
        return Map(room=self.room, tables=tuple(self.tables),
                   chairs=tuple(c for c in self.chairs if c.mapped))

    @property
    def robot_value(self) -> Robot:
        """The robot that `robot.name` names (`world.robot.load_robot`)."""
        return load_robot(self.robot.name or DEFAULT_ROBOT)

    @property
    def contents(self) -> SceneContents:
        """The true world as a plant holds it: every chair, every object."""
        return SceneContents(room=self.room, tables=tuple(self.tables),
                             chairs=tuple(self.chairs), dishes=tuple(self.dishes),
                             start=tuple(float(v) for v in self.robot.start),
                             robot=self.robot_value, floor_margin=self.camera.margin)

    @property
    def settings(self) -> Settings:
        return Settings(seed=self.seed, planner=self.planner, uncertainty=self.uncertainty,
                        camera=self.camera, simulation=self.simulation,
                        execution=self.execution, outputs=self.outputs)


def parse_scenario(text: str) -> Scenario:
    """Parses and validates scenario YAML text; raises ScenarioError."""
    try:
        raw = load_yaml(text)
        if raw is None:  # an empty or comment-only file: every field has its default
            raw, text = {}, "{}"
        check_structure(raw, Scenario, "")
        scenario = _older_fields(yaml_load_typed(schema=Scenario, data=text), raw)
        scenario.robot.name = scenario.robot.name or DEFAULT_ROBOT
    except FieldError as e:
        raise ScenarioError(e.path, e.message) from None
    except (RuntimeError, ValueError) as e:  # the checks should have caught it; keep one line
        raise ScenarioError("", str(e).splitlines()[0]) from None
    validate_scenario(scenario)
    return scenario


#: Fields that moved into Drake's configs: where older files (the shipped generated tasks)
#: give them, and where they live now.
_MOVED = (("simulation", "time_step", "plant"), ("simulation", "publish_period", "visualization"))


def _older_fields(scenario: Scenario, raw: dict) -> Scenario:
    """The fields of older files read into the Drake config that holds them now (`_MOVED`);
    given in both places, they must agree. Afterwards only the config holds them."""
    for section, name, config in _MOVED:
        given = (raw.get(section) or {}).get(name)
        if given is None:
            continue
        now = getattr(getattr(scenario, config), name)
        if name in (raw.get(config) or {}) and now != given:
            raise FieldError(f"{section}.{name}", f"{given:g} s, but {config}.{name} says "
                                                  f"{now:g} s: set one")
        setattr(getattr(scenario, config), name, float(given))
        setattr(getattr(scenario, section), name, None)
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
