"""The robot's start and the parameters of a scenario: planning, the uncertainty model, the
camera, the simulation, the execution's recovery and the outputs. The dataclasses mirror the
YAML (`world/scenario.py`); `Settings` gathers them for what the robot is given (with the
`Map`), apart from the true world.
"""

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from s3o_drake.world.robot import Robot


@dataclass
class RobotSection:
    """The scenario's `robot`: which robot, and where it starts."""

    name: str = ""
    """Which robot: its folder under models/ (`world/robot_description.py`). A file that
    names none is for the UR5e (`resources.DEFAULT_ROBOT`), whose name the loaded scenario
    then holds."""
    start: list[float] = field(default_factory=lambda: [1.0, 1.0, 0.0])
    """[x, y, yaw] of the base at the start."""


@dataclass
class PlanningSettings:
    """Planning settings; defaults are the paper's."""

    method: str = "S3O-GROP*"
    top_k: int = 5
    cma_generations: int = 20
    cma_population: int = 10
    cost_profile: str = "robot"
    """The utility's costs (planning/time_model.py): "robot", the execution's predicted
    time (the base navigator's motion profile along the path, turns included, and the
    recorded pickup and command times of models/ur5e/time_model.yaml); or "paper", the paper's
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
    reach: float | None = None
    """How far from the base centre the robot can pick a dish (m); none: what the robot's
    description says (the UR5e's 1.0 m, the Panda's 0.9 m), as `reach_for` reads it."""
    location_samples: int = 100
    """N: positions drawn from a location to estimate its task-level feasibility."""
    group_positions: str = "shared"
    """How Fea^t of a merged location draws its N positions (abstraction/task_feasibility.py):
    "shared", by the group's joint value, every dish evaluated at the same positions (the
    one stop that serves the group: what the execution does); "per_dish", for each dish by
    its own Fea^m (the paper's code). Measured level, 20 tasks x 3 seeds per room
    (docs/abstraction.md)."""
    search_plain_voronoi: bool = True
    """S3O-GROP* and S3O-GROP also search the unmerged state space when it is not among
    their top K, so that S3O never searches less than the Voronoi methods."""
    location_price: str = "paper"
    """The ranking's price of a location, c in Score - c|L|: "paper", γ / λ of the fields
    below (λ as `failure_price` sets it); "search", the γ of the motion search's cost
    profile over λ. "search" was measured 3 % slower in the dense room (docs/abstraction.md)."""
    failure_price: str = "execution"
    """What a pickup's chance of failing costs the utility, λ (1 - Fea^m): "execution", λ
    below in open loop (a failed pickup loses the dish) and with recovery the recovery's
    recorded time per expected failure (models/ur5e/failure_price.yaml: `s3o failure-price`);
    "paper", λ whatever the execution does. With recovery, "execution" was measured 4-8 %
    faster at the same completion (docs/abstraction.md)."""
    shared_stop: str = "execution"
    """How the utility and the ranking rate a pickup at a stop that serves several dishes
    (abstraction/shared_stop.py): "execution", in open loop Fea^m times the share of it
    that executed pickups at such stops achieved (models/ur5e/shared_stop.yaml: `s3o
    shared-stop`), and with recovery Fea^m as it is (the recovery's recorded price of a
    failure holds the recoveries at shared stops); "paper", Fea^m as it is."""
    time_budget: float = 300.0
    """Wall-clock cap on planning (s)."""
    time_model: str = ""
    """The time model file the "robot" cost profile reads (planning/time_model.py); empty:
    the robot's (models/<robot>/time_model.yaml). `s3o build time-model` plans with the
    model it is making."""
    workers: int = 2
    feasibility: str = "fcn"
    """Source of the Fea^m heatmaps: "fcn" (the network in models/ur5e/fcn/, from the overhead
    depth image) or "oracle" (the Drake check under the noise model, on the known world).
    The default is measured: on 6 held-out tasks S3O-GROP* completed 3 with the network and
    none with the oracle, collected 85% against 64% of the dishes, and planned in 4.9 s
    against 8.5 s (`s3o bench compare-feasibility --count 6`): CMA-ES
    maximising the oracle's 5-sample estimates picks spots that were lucky (docs/fcn.md)."""

    def reach_for(self, robot: "Robot") -> float:
        """How far from the base centre `robot` can pick a dish (m): `reach`, or where the
        scenario gives none, the robot's description's."""
        return robot.reach if self.reach is None else self.reach


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
    localization: str = "at_stops"
    """Where the localisation's error enters the run (`choices.Localization`): "at_stops",
    the executive adds the error above where it judges a stop; "reported", the robot
    localises on its own side (odometry corrected by its scanner's scans matched to its
    map; the error above only at the start), reports its pose with what error remains, and
    the controllers drive by that report (docs/execution.md)."""


@dataclass
class Camera:
    """The overhead camera, above the room's centre looking straight down."""

    height: float = 10.0
    pixels_per_meter: float = 50.0
    """Image resolution at floor level; the field of view covers the room and the margin."""
    margin: float = 0.3


@dataclass
class Simulation:
    time_step: float | None = None
    """The plant's step (s), as files from before the scenario held Drake's
    `MultibodyPlantConfig` give it: read into `plant.time_step` (Scenario), where it lives
    now; the two may not disagree."""
    hold_time: float = 1.0
    """How long the simulation runs on after the plan has ended (s), so that the playback
    shows the robot at rest with what it collected."""
    publish_period: float | None = None
    """The Meshcat recording's frame period (s), as files from before the scenario held
    Drake's `VisualizationConfig` give it: read into `visualization.publish_period`
    (Scenario), where it lives now; the two may not disagree."""


@dataclass
class ExecutionSettings:
    """What execution does when an action fails (see `Recovery`), and its limits."""

    recovery: str = "replan"
    """none | retry | replan. `run` uses it as given; `evaluate` runs its own --recovery
    (default none, the paper's protocol)."""
    motion: str = "smooth"
    """smooth | stop_and_go (`choices.Motion`): whether the base drives through its path's
    corners and the arm moves while the base drives, or the paper's motion, the base
    stopping at every corner and the arm moving only with the base at rest. The planner
    plans with the motion the execution makes."""
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


@dataclass(frozen=True)
class Settings:
    """The parameters of a run: one seed drives every random draw."""

    seed: int
    planner: PlanningSettings
    uncertainty: Uncertainty
    camera: Camera
    simulation: Simulation
    execution: ExecutionSettings
    outputs: Outputs
