"""A lower bound on the execution time of any plan of a task: no plan, however found, and no
execution of it in the simulation, takes less.

An executed pickup succeeds only where the robot stands inside the dish's pickable region,
the support of the true world's Fea^m (the Drake oracle on every chair where the scenario
puts it: the blur of the landing and reach noise reaches 3.5 standard deviations beyond
every pose that picks). The base drives continuously from its start through one pose in
each region, and its navigator never exceeds the cruise speed v. Whatever the order, that
path is a spanning tree of the start and the poses, so it is at least as long as the
minimum spanning tree of the start and the regions with the regions' distances (each no
longer than the poses' distance): the tour bound is that tree's length over v.

Each object is grasped and let go once: its fingers close over their whole stroke and open
again, each stroke timed within the fingers' limits (FINGER_MAX_*; a rest-to-rest motion
takes at least d / v + v / a, `stroke_time`). A dish collected onto the tray takes the arm
from stow, through its grasp, to one of the release configurations over the tray (the
same few in the arm's frame wherever the base stands: `pickup_geometry.tray_arms`) and
back to stow, in rest-to-rest segments within the arm's joint limits. The time of
such segments is at least that of one rest-to-rest stroke over their summed displacement
(`stroke_time` is concave and 0 at 0), so each leg, there and back, takes at least the
slowest joint's stroke between stow and the nearest release configuration. Everything
else (turns, the grasp's own motions, settling, the corners of the drives) only adds time.
TOPPRA keeps the limits at its grid points only; the hand's and the arm's times are taken
at TIMING_SLACK of the analytic figure so that this cannot make the bound too high.

The bound holds for complete runs: an incomplete run may stop early.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Sequence
from dataclasses import dataclass, replace

import numpy as np
import shapely
from scipy.sparse.csgraph import minimum_spanning_tree

from s3o_drake.execution.arm.pickup import FINGER_MAX_ACCELERATION, FINGER_MAX_VELOCITY
from s3o_drake.feasibility.oracle import Heatmap
from s3o_drake.planning.pipeline import PlanningResult
from s3o_drake.planning.plan import Goto, Pickup, TaskMotionPlan
from s3o_drake.world.goals import placed_object
from s3o_drake.world.robot import Robot
from s3o_drake.world.scenario import Scenario


@dataclass(frozen=True)
class LowerBound:
    """A lower bound on a complete execution's time (s), and its parts."""

    tour_length: float
    """m: the minimum spanning tree of the start and the pickable regions."""
    drive_time: float
    """s: `tour_length` at the cruise speed."""
    hand_time: float
    """s: the fingers' strokes, closing and opening once per object."""
    arm_time: float = 0.0
    """s: the arm's legs from stow to over the tray and back, per dish collected."""

    @property
    def total(self) -> float:
        return self.drive_time + self.hand_time + self.arm_time


TIMING_SLACK = 0.95
"""The share of the analytic shortest motion times the bound counts (see the module)."""


def stroke_time(distance: float, velocity: float, acceleration: float) -> float:
    """The shortest rest-to-rest motion (s) over `distance` within the limits."""
    if distance <= 0.0:
        return 0.0
    if distance >= velocity**2 / acceleration:
        return distance / velocity + velocity / acceleration
    return 2.0 * math.sqrt(distance / acceleration)


def finger_stroke_time(*, robot: Robot) -> float:
    """`robot`'s fingers' shortest motion (s) between open and closed (either way): the
    pads' travel within their limits."""
    return stroke_time(robot.finger_travel, FINGER_MAX_VELOCITY, FINGER_MAX_ACCELERATION)


def tray_leg_time(plant, *, robot: Robot, positions=None) -> float:
    """The arm's shortest rest-to-rest leg (s) between its stow configuration and a release
    configuration over the tray (the nearest of every grasp kind's), within the arm's joint
    limits of `robot` in `plant` (its positions among the plant's at `positions`, a
    `PositionMap`; default: they are the plant's): the slowest joint's stroke."""
    from s3o_drake.execution.arm.pickup import segment_limits
    from s3o_drake.feasibility.pickup_geometry import tray_arms

    v, a = segment_limits(plant, "stow", robot=robot, positions=positions)
    v, a = np.asarray(v)[robot.arm_positions], np.asarray(a)[robot.arm_positions]
    legs = [max(stroke_time(abs(float(d)), float(vj), float(aj))
                for d, vj, aj in zip(np.asarray(arm) - robot.arm_stow, v, a, strict=True))
            for grasp in ("top", "side") for arm in tray_arms(grasp, robot=robot)]
    return min(legs)


def pickable_region(heatmap: Heatmap) -> shapely.Geometry:
    """The union of the heatmap's cells where Fea^m > 0 (empty where it has none)."""
    rows, cols = np.nonzero(heatmap.values > 0.0)
    x0 = heatmap.x0 + cols * heatmap.cell
    y0 = heatmap.y0 + rows * heatmap.cell
    return shapely.union_all(shapely.box(x0, y0, x0 + heatmap.cell, y0 + heatmap.cell))


def tour_length(start: Sequence[float], regions: Sequence[shapely.Geometry]) -> float:
    """The minimum spanning tree's length (m) of the start point and the regions, each
    edge the two's shortest distance: no path from the start through a point of every
    region is shorter."""
    nodes = [shapely.Point(float(start[0]), float(start[1])), *regions]
    n = len(nodes)
    if n <= 1:
        return 0.0
    i, j = np.triu_indices(n, k=1)
    d = shapely.distance(np.array(nodes, dtype=object)[i], np.array(nodes, dtype=object)[j])
    # Every spanning tree has n - 1 edges, so adding 1 m to each edge changes no tree's
    # rank; it keeps regions that touch (distance 0) joined, where a 0 would mean no edge.
    weights = np.zeros((n, n))
    weights[i, j] = d + 1.0
    tree = minimum_spanning_tree(weights)
    return max(0.0, float(tree.sum()) - (n - 1))


def lower_bound(scenario: Scenario, heatmaps: Sequence[Heatmap] | None = None) -> LowerBound:
    """The bound for `scenario`: its objects' pickable regions from `heatmaps` (default:
    the Drake oracle on the true world, `compute_heatmaps(scenario)`, the maps a study's
    difficulty measures), at the planner's cruise speed. A dish with no pickable region
    makes every complete run impossible: its bound is infinite."""
    if heatmaps is None:
        from s3o_drake.feasibility.heatmaps import compute_heatmaps

        heatmaps = compute_heatmaps(scenario, progress=False)
    # An object that stays is never picked; a place target is visited like a dish.
    moved = {d.name for d in scenario.dishes if d.goal != "stay"}
    heatmaps = [h for h in heatmaps if h.dish in moved or placed_object(h.dish) is not None]
    regions = [pickable_region(h) for h in heatmaps]
    if any(r.is_empty for r in regions):
        return LowerBound(math.inf, math.inf, math.inf)
    from s3o_drake.feasibility.scene import FeasibilityScene

    length = tour_length(scenario.contents.start, regions)
    names = [h.dish for h in heatmaps]
    objects = sum(placed_object(name) is None for name in names)  # not the place targets
    placed = {d.name for d in scenario.dishes if d.goal == "place"}
    collected = sum(placed_object(name) is None and name not in placed for name in names)
    robot = scenario.robot_value
    if collected:
        scene = FeasibilityScene(scenario.contents)
        legs = tray_leg_time(scene.plant, robot=robot, positions=scene.positions)
    else:
        legs = 0.0
    return LowerBound(tour_length=length, drive_time=length / scenario.planner.speed,
                      hand_time=TIMING_SLACK * 2 * objects * finger_stroke_time(robot=robot),
                      arm_time=TIMING_SLACK * 2 * collected * legs)


# --- the reference planner and the rations it lifts -------------------------------------

RESTARTS = 3
"""Seeds the long search plans from; the plan of highest utility is kept."""
ALL_CANDIDATES = 1_000_000
"""A top K no abstraction reaches: every candidate state space is searched."""
SEARCH_FACTOR = 10
"""The long search's CMA-ES generations, times the planner's."""
REFERENCE_BUDGET = 600.0
"""s: the reference planner's budget per task."""
RATIONS = ("true_chairs", "oracle", "all_candidates", "long_search")
"""What the real planner rations: the perceived chairs (against the true ones), the
network's Fea^m (against the Drake oracle's, which has no sampling error: an expectation),
the top K state spaces (against every candidate), and its motion search (against ten
times the generations, from several seeds)."""


def rationed_scenario(scenario: Scenario, lifted: Collection[str]) -> Scenario:
    """`scenario` with the planner settings of the rations `lifted` lifted (the chairs
    are the planner's input: `plan_rationed`), and the reference's budget when all are.
    Every plan is made for the open loop that judges it (the product of its pickups'
    Fea^m) and executes it: a failed pickup loses its dish, priced at the planner's λ, not
    at the recovery's time (`failure_price.failure_reward`) that a task file asking for
    recovery would otherwise set."""
    unknown = set(lifted) - set(RATIONS)
    if unknown:
        raise ValueError(f"unknown ration(s) {sorted(unknown)}; known: {', '.join(RATIONS)}")
    planner = scenario.planner
    changes: dict[str, object] = {}
    if "oracle" in lifted:
        changes["feasibility"] = "oracle"
    if "all_candidates" in lifted:
        changes["top_k"] = ALL_CANDIDATES
    if "long_search" in lifted:
        changes["cma_generations"] = SEARCH_FACTOR * planner.cma_generations
    if set(lifted) == set(RATIONS):
        changes["time_budget"] = max(planner.time_budget, REFERENCE_BUDGET)
    return replace(scenario, planner=replace(planner, **changes),
                   execution=replace(scenario.execution, recovery="none"))


def plan_rationed(scenario: Scenario, lifted: Collection[str], *, seed: int,
                  images: tuple | None = None) -> PlanningResult:
    """S3O-GROP*'s plan of `scenario` with the rations `lifted` (all of them: the reference
    plan). The chairs are perceived from the overhead images (`images`: `render_overhead`'s
    four, rendered here when not given) unless "true_chairs" is lifted; with
    "long_search" the plan is made from RESTARTS seeds (`seed` first) and the one of
    highest utility kept."""
    from s3o_drake.belief.chair_perception import perceive_known_world, scenario_unmapped_chairs
    from s3o_drake.belief.known_world import Briefing
    from s3o_drake.planning.pipeline import plan_from
    from s3o_drake.world.builder import render_overhead

    scenario = rationed_scenario(scenario, lifted)
    color, depth, label, robot_labels = images if images is not None else \
        render_overhead(scenario)
    known = perceive_known_world(
        Briefing.of(scenario), (color, depth, label), pose=scenario.robot.start,
        dishes=[d.name for d in scenario.dishes], robot_labels=robot_labels,
        perceive=scenario_unmapped_chairs(scenario) if "true_chairs" in lifted else None)
    seeds = [seed + k for k in range(RESTARTS if "long_search" in lifted else 1)]
    results = [plan_from(known, method="S3O-GROP*", seed=s) for s in seeds]
    planned = [r for r in results if r.plan is not None]
    if not planned:
        return results[0]
    return max(planned, key=lambda r: r.plan.utility)


def judged_completion(plan: TaskMotionPlan, truth: Sequence[Heatmap]) -> float:
    """The plan's chance of picking every dish by the true world's Fea^m (`truth`: the
    Drake oracle's maps of the scenario, `compute_heatmaps`) at the stops it commands:
    every plan judged by the same model, whatever Fea^m it was made with. 0 with a dish
    left out."""
    if plan.unreachable:
        return 0.0
    maps = {h.dish: h for h in truth}
    chance, stop = 1.0, None
    for action in plan.actions:
        if isinstance(action, Goto):
            stop = np.asarray(action.pose[:2], dtype=float)
        elif isinstance(action, Pickup):
            chance *= maps[action.dish].value_at(stop)
    return float(chance)
