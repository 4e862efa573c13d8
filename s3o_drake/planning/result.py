"""What planning from a KnownWorld produces: `PlanningResult`, the plan and what it was made on."""

from __future__ import annotations

from dataclasses import dataclass, field

from s3o_drake.abstraction import Abstraction
from s3o_drake.abstraction.location_grid import LocationGrid
from s3o_drake.abstraction.voronoi import VoronoiPartition
from s3o_drake.belief.known_world import KnownWorld
from s3o_drake.feasibility.planning_scene import PlanningScene
from s3o_drake.planning.navigation.map import NavigationMap
from s3o_drake.planning.plan import TaskMotionPlan


@dataclass(frozen=True)
class PlanningResult:
    """What planning from a KnownWorld produced: the plan, or why there is none, and what
    the plan was made on, so that execution and the pictures use the same things."""

    known: KnownWorld
    """What the robot knew: the plan starts at `known.pose`."""
    method: str
    seed: int
    plan: TaskMotionPlan | None
    error: str = ""
    """Why there is no plan ("" when there is one)."""
    heatmaps: tuple = ()
    """The Fea^m heatmaps the plan was made with: Fea^m 0 where a stop is not free
    (`feasibility/stops.py`)."""
    model_heatmaps: tuple = ()
    """The same before the free-stop rule: the model's Fea^m of a pickup from each position,
    which rates where the robot really stands (the stop check of recovery)."""
    navigation: NavigationMap | None = None
    """The navigation map the plan was costed on; the execution re-paths its drives on it."""
    partition: VoronoiPartition | None = None
    """The plain Voronoi cells of the dishes (every method but the empty plan)."""
    abstraction: Abstraction | None = None
    """S3O's ranked state spaces (the S3O methods; None for the V- methods)."""
    grid: LocationGrid | None = None
    """The location grid Fea^t, the representative points and the motion search read
    (None for V-PETLON, which samples no grid, and the empty plan)."""
    planning_time: float = 0.0
    """Wall time (s) spent: perception, Fea^m and the search (the plan's own figure)."""
    task_plans: tuple = ()
    """clingo's answer for each state space it ordered, as (groups, `TaskPlanResult`), in
    the order planned (GROP and GROP*; the problem solved is in each result)."""
    scene: PlanningScene | None = field(default=None, compare=False, repr=False)
    """The plan's one Drake scene of `known`: the recovery's stop check asks it too."""
    unchecked: tuple[str, ...] = ()
    """Dishes the plan leaves out as unreachable on the network's Fea^m alone: the budget
    left no time for the Drake check of the known world, or for planning again after it
    found a stop (`pipeline.plan_from`). Execution that replans asks again for them."""
