"""The planning pipeline: from what the robot knows to a plan, in one call.

`plan_from(known)` computes the Fea^m heatmap of every dish that remains, from the source
the planner's settings name (`planner.feasibility`: "oracle", the Drake check of the known
world, or "fcn", the network on the overhead depth image the KnownWorld carries), then plans
with the method (`planner.plan_task`: one navigation map, the abstraction, clingo, the motion
search). It returns a `PlanningResult`: the plan or the reason there is none, with the
heatmaps, the navigation map, the state spaces and the location grid it was made on.

The ExecutiveSystem, `run`, the benchmarks and the evaluation plan through it; a replan is
the same call with a newer KnownWorld (`KnownWorld.moved`).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Sequence

import numpy as np
import shapely

from s3o_drake.belief.known_world import KnownWorld
from s3o_drake.feasibility.heatmaps import compute_heatmaps
from s3o_drake.feasibility.oracle import Heatmap
from s3o_drake.feasibility.stops import FreeStops
from s3o_drake.planning.methods import PlanningError, PlanningResult, plan_task
from s3o_drake.planning.navigation import DRIVE_MARGIN, NavigationMap
from s3o_drake.planning.task_costs import first_reachable
from s3o_drake.planning.task_planner import TaskPlanningError
from s3o_drake.world.camera import overhead_camera
from s3o_drake.world.robot import INSCRIBED_RADIUS
from s3o_drake.world.scenario import FEASIBILITY_SOURCES, FeasibilitySource, Scenario

STOP_CELL = 0.05
"""Grid spacing (m) of the candidate stops `dishes_without_stops` tries."""

__all__ = ["PlanningResult", "best_stops", "dishes_without_stops", "heatmaps_for",
           "plan_from"]  # the pipeline's API


def heatmaps_for(known: KnownWorld, *, source: str | None = None,
                 progress: bool = False) -> list[Heatmap]:
    """Every remaining dish's Fea^m heatmap, from `source` ("oracle" or "fcn"; default the
    planner's `feasibility`)."""
    source = known.planner.feasibility if source is None else source
    if source not in FEASIBILITY_SOURCES:
        raise ValueError(f"unknown feasibility source {source!r}; known: "
                         f"{', '.join(FEASIBILITY_SOURCES)}")
    if source == FeasibilitySource.FCN:
        if known.overhead is None:
            raise ValueError("planner.feasibility fcn: the network needs the overhead images, "
                             "and this KnownWorld has none")
        # Imported here: torch is heavy, and only this source needs it.
        from s3o_drake.feasibility.fcn import FcnFeasibility, overhead_view, use_one_thread

        view = overhead_view(overhead_camera(known.settings), known.overhead.depth,
                             known.overhead.label, known.overhead.robot_labels)
        use_one_thread()
        return FcnFeasibility.shared().heatmaps(view, list(known.dishes))
    return compute_heatmaps(known.as_scenario(), workers=1, progress=progress,
                            obstacles=known.obstacles)


def best_stops(known: KnownWorld, heatmaps: Sequence[Heatmap] | None = None
               ) -> dict[str, float]:
    """Each remaining dish's highest Fea^m (`heatmaps`, default `heatmaps_for(known)`) over
    the stops a plan may command from where the robot stands: free as planned
    (`FreeStops`) and reachable by a collision-free drive. With a calibrated Fea^m their mean
    is the pickup success that an open-loop plan standing at each dish's own best stop can
    expect: no plan does better in expectation, whatever it trades for time."""
    heatmaps = heatmaps_for(known) if heatmaps is None else heatmaps
    nav = NavigationMap(known.obstacles)
    start = nav.way_out(known.pose[:2])
    best = {}
    for heatmap in FreeStops.of(known).restrict_all(heatmaps):
        centres = heatmap.centers().reshape(-1, 2)
        values = heatmap.values.reshape(-1)
        order = np.argsort(-values, kind="stable")
        order = order[values[order] > 0]
        first = first_reachable(nav, start, centres[order])  # the best that can be reached
        best[heatmap.dish] = 0.0 if first is None else float(values[order[first]])
    return best


def dishes_without_stops(scenario: Scenario, chair_margin: float = 0.0, *,
                         first: bool = False) -> list[str]:
    """The dishes (and place targets) of `scenario` that have no candidate stop: no base
    position within the planner's reach (`planner.reach`) of them that is free as planned
    (`FreeStops`, on a grid of STOP_CELL) and that a drive from the robot's start reaches,
    in the true world (every chair where the scenario puts it). No method can pick such a
    dish; the benchmark's tasks have none (`task_generation.generate_task`, `stops`).

    `chair_margin` (m): the drives are asked on a map whose unmapped chairs are grown by
    it, where perception may put them. A dish whose only way passes a chair within that
    of the drives' clearance is then named too: on the chairs perception finds, millimetres
    off, the planner may find no way there (dense task_030 and task_045, docs/results.md).

    `best_stops` with Fea^m 1 within reach, but cheaper (the generator asks once per chair
    drawn): the collision check, the costly part, is asked only at positions that keep
    the base's inscribed radius from every obstacle (nearer, every yaw collides) and that a
    drive reaches, and only until one free stop is found (`FreeStops.any_free_cell`).

    `first`: return at the first dish found without a stop (a list of one), for a caller
    that asks only whether there is one. The generator's rejected chairs mostly close a
    dish's last drivable way, which the navigation map alone shows: they then cost no
    collision checker."""
    known = KnownWorld.perfect(scenario)
    reach = known.planner.reach
    nav = NavigationMap(known.obstacles_grown(chair_margin))
    start = nav.way_out(known.pose[:2])
    clear = known.obstacles.free_space(INSCRIBED_RADIUS)
    cells = int(np.ceil(2 * reach / STOP_CELL))
    missing, asked = [], []
    for dish in known.dishes:
        p = np.asarray(dish.position[:2], float)
        grid = Heatmap(dish.name, np.zeros((cells, cells)), p[0] - reach, p[1] - reach,
                       STOP_CELL)
        centres = grid.centers()
        ask = (np.linalg.norm(centres - p, axis=-1) <= reach) & shapely.contains_xy(
            clear, centres[..., 0], centres[..., 1])
        ask[ask] = nav.reachable(start, centres[ask])
        if not ask.any():
            if first:
                return [dish.name]
            missing.append(dish.name)
        else:
            asked.append(dataclasses.replace(grid, values=ask.astype(float)))
    stops = FreeStops.of(known) if asked else None
    for grid in asked:
        if not stops.any_free_cell(grid):
            if first:
                return [grid.dish]
            missing.append(grid.dish)
    return sorted(missing)


def plan_from(known: KnownWorld, *, method: str | None = None, seed: int | None = None,
              workers: int | None = None, time_budget: float | None = None,
              n_sequences: int = 3, heatmaps: Sequence[Heatmap] | None = None,
              feasibility: str | None = None, progress: bool = False,
              started: float | None = None, drive_margin: float = DRIVE_MARGIN
              ) -> PlanningResult:
    """Plans from `known` (see the module docstring).

    Method, seed, workers, budget and the Fea^m source (`feasibility`) default to the
    planner's settings and the scenario's seed. `heatmaps` given are used as they are (a
    second plan on the same Fea^m). With the network's Fea^m, dishes that the plan would
    leave out as unreachable get the Drake oracle's heatmap instead, and the plan is made
    again with them (within what remains of the budget); those it could not check so, or
    not plan again for, are the result's `unchecked`.
    `started` is the `time.perf_counter()` at which the caller began (before perceiving),
    so that the planning time counts perception too. `drive_margin` is the navigation
    map's (`navigation.TIGHT_DRIVE_MARGIN` for a squeeze). A plan that cannot be made is a
    result with `plan` None and `error` saying why; an unknown method raises ValueError.
    """
    t0 = time.perf_counter() if started is None else started
    method = known.planner.method if method is None else method
    seed = known.settings.seed if seed is None else int(seed)
    workers = known.planner.workers if workers is None else workers
    if heatmaps is None:
        heatmaps = heatmaps_for(known, source=feasibility, progress=progress)
    maps = tuple(heatmaps) if isinstance(heatmaps, (list, tuple)) else ()
    result = _plan(known, method, heatmaps, seed, time_budget, n_sequences, workers, t0,
                   drive_margin)
    source = known.planner.feasibility if feasibility is None else feasibility
    lost = () if result.plan is None else result.plan.unreachable
    budget = known.planner.time_budget if time_budget is None else time_budget
    exact: dict[str, Heatmap] = {}
    if lost and source == FeasibilitySource.FCN and maps:
        # The network is an approximation: before a dish is left out, the Drake check of
        # the known world decides (a few seconds per dish, and only for these), within
        # the budget: dish by dish while time is left, and the plan made again only if
        # time is left for it (the random-scene soak of issue 19 found the rescue running
        # several times over a small budget).
        for dish in lost:
            if time.perf_counter() - t0 >= budget:
                break
            exact[dish] = compute_heatmaps(known.as_scenario(), [dish], workers=1,
                                           progress=False, obstacles=known.obstacles)[0]
        maps = tuple(exact.get(h.dish, h) for h in maps)
        left = budget - (time.perf_counter() - t0)
        if any(h.values.max() > 0.0 for h in exact.values()) and left > 0:
            result = _plan(known, method, maps, seed, left, n_sequences, workers, t0,
                           drive_margin)
    unchecked = ()
    if source == FeasibilitySource.FCN and result.plan is not None:
        unchecked = tuple(d for d in result.plan.unreachable
                          if d not in exact or exact[d].values.max() > 0.0)
    # The plan's own heatmaps: Fea^m restricted to free stops, as the plan was made.
    return dataclasses.replace(result, heatmaps=result.heatmaps or maps,
                               model_heatmaps=result.model_heatmaps or maps,
                               unchecked=unchecked)


def _plan(known: KnownWorld, method: str, heatmaps, seed: int, time_budget: float | None,
          n_sequences: int, workers: int, t0: float, drive_margin: float) -> PlanningResult:
    """`plan_task`, a PlanningError becoming a result that says why there is no plan."""
    maps = tuple(heatmaps) if isinstance(heatmaps, (list, tuple)) else ()
    try:
        return plan_task(known, method=method, heatmaps=heatmaps, seed=seed,
                         time_budget=time_budget, n_sequences=n_sequences, workers=workers,
                         feasibility_time=time.perf_counter() - t0,
                         drive_margin=drive_margin)
    except (PlanningError, TaskPlanningError) as e:
        return PlanningResult(known=known, method=method, seed=seed, plan=None,
                              error=f"no plan: {e}", heatmaps=maps,
                              planning_time=time.perf_counter() - t0)
