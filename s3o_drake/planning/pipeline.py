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

from s3o_drake.belief.known_world import KnownWorld
from s3o_drake.feasibility.heatmaps import oracle_heatmaps
from s3o_drake.feasibility.oracle import Heatmap
from s3o_drake.feasibility.planning_scene import PlanningScene
from s3o_drake.planning.methods import PlanningError, PlanningResult, plan_task
from s3o_drake.planning.navigation.map import DRIVE_MARGIN, NavigationMap
from s3o_drake.planning.task.costs import first_reachable
from s3o_drake.planning.task.planner import TaskPlanningError
from s3o_drake.world.camera import overhead_camera
from s3o_drake.world.choices import FEASIBILITY_SOURCES, FeasibilitySource
from s3o_drake.world.deadline import Clock

__all__ = ["PlanningResult", "best_stops", "heatmaps_for", "plan_from"]  # the pipeline's API


def heatmaps_for(known: KnownWorld, *, source: str | None = None, progress: bool = False,
                 scene: PlanningScene | None = None) -> list[Heatmap]:
    """Every remaining dish's Fea^m heatmap, from `source` ("oracle" or "fcn"; default the
    planner's `feasibility`); the oracle's on `scene`, the plan's one scene of `known`
    (built here when not given)."""
    source = known.planner.feasibility if source is None else source
    if source not in FEASIBILITY_SOURCES:
        raise ValueError(f"unknown feasibility source {source!r}; known: "
                         f"{', '.join(FEASIBILITY_SOURCES)}")
    if source == FeasibilitySource.FCN:
        if known.overhead is None:
            raise ValueError("planner.feasibility fcn: the network needs the overhead images, "
                             "and this KnownWorld has none")
        # Imported here: torch is heavy, and only this source needs it.
        from s3o_drake.feasibility.learned.fcn import FcnFeasibility, overhead_view, use_one_thread

        view = overhead_view(overhead_camera(known.map.room, known.settings.camera),
                             known.overhead.depth, known.overhead.label,
                             known.overhead.robot_labels)
        use_one_thread()
        return FcnFeasibility.shared(robot=known.robot).heatmaps(view, list(known.dishes))
    scene = PlanningScene(known) if scene is None else scene
    return oracle_heatmaps(scene.oracle, [d.name for d in known.contents.dishes],
                           progress=progress)


def best_stops(known: KnownWorld, heatmaps: Sequence[Heatmap] | None = None,
               scene: PlanningScene | None = None) -> dict[str, float]:
    """Each remaining dish's highest Fea^m (`heatmaps`, default `heatmaps_for(known)`) over
    the stops a plan may command from where the robot stands: free as planned
    (`FreeStops`) and reachable by a collision-free drive. With a calibrated Fea^m their mean
    is the pickup success that an open-loop plan standing at each dish's own best stop can
    expect: no plan does better in expectation, whatever it trades for time."""
    scene = PlanningScene(known) if scene is None else scene
    heatmaps = heatmaps_for(known, scene=scene) if heatmaps is None else heatmaps
    nav = NavigationMap(known.obstacles, robot=known.robot)
    start = nav.way_out(known.pose[:2])
    best = {}
    for heatmap in scene.free_stops.restrict_all(heatmaps):
        centres = heatmap.centers().reshape(-1, 2)
        values = heatmap.values.reshape(-1)
        order = np.argsort(-values, kind="stable")
        order = order[values[order] > 0]
        first = first_reachable(nav, start, centres[order])  # the best that can be reached
        best[heatmap.dish] = 0.0 if first is None else float(values[order[first]])
    return best


def plan_from(known: KnownWorld, *, method: str | None = None, seed: int | None = None,
              workers: int | None = None, time_budget: float | None = None,
              n_sequences: int = 3, heatmaps: Sequence[Heatmap] | None = None,
              feasibility: str | None = None, progress: bool = False,
              started: float | None = None, drive_margin: float = DRIVE_MARGIN,
              scene: PlanningScene | None = None,
              clock: Clock = time.perf_counter) -> PlanningResult:
    """Plans from `known` (see the module docstring).

    Method, seed, workers, budget and the Fea^m source (`feasibility`) default to the
    planner's settings and the scenario's seed. `heatmaps` given are used as they are (a
    second plan on the same Fea^m). With the network's Fea^m, dishes that the plan would
    leave out as unreachable get the Drake oracle's heatmap instead, and the plan is made
    again with them (within what remains of the budget); those it could not check so, or
    not plan again for, are the result's `unchecked`.
    `clock` measures the budget and the times reported (`world.deadline`); `started` is
    its reading when the caller began (before perceiving), so that the planning time
    counts perception too. `drive_margin` is the navigation
    map's (`navigation.TIGHT_DRIVE_MARGIN` for a squeeze). A plan that cannot be made is a
    result with `plan` None and `error` saying why; an unknown method raises ValueError.
    `scene`: the Drake scene of `known`, when the caller plans the same belief several
    times (built here otherwise, within the budget).
    """
    t0 = clock() if started is None else started
    # One Drake scene of the belief serves the heatmaps, the free stops and the stop checks;
    # building it is part of the budget.
    t_scene = clock()
    scene = PlanningScene(known) if scene is None else scene
    building = clock() - t_scene
    method = known.planner.method if method is None else method
    seed = known.settings.seed if seed is None else int(seed)
    workers = known.planner.workers if workers is None else workers
    if heatmaps is None:
        heatmaps = heatmaps_for(known, source=feasibility, progress=progress, scene=scene)
    maps = tuple(heatmaps) if isinstance(heatmaps, (list, tuple)) else ()
    budget = known.planner.time_budget if time_budget is None else time_budget
    result = _plan(known, scene, method, heatmaps, seed, max(0.0, budget - building),
                   n_sequences, workers, t0, drive_margin, clock)
    source = known.planner.feasibility if feasibility is None else feasibility
    lost = () if result.plan is None else result.plan.unreachable
    exact: dict[str, Heatmap] = {}
    if lost and source == FeasibilitySource.FCN and maps:
        # The network is an approximation: before a dish is left out, the Drake check of
        # the known world decides (a few seconds per dish, and only for these), within
        # the budget: dish by dish while time is left, and the plan made again only if
        # time is left for it (the random-scene soak of issue 19 found the rescue running
        # several times over a small budget).
        for dish in lost:
            if clock() - t0 >= budget:
                break
            exact[dish] = oracle_heatmaps(scene.oracle, [dish])[0]
        maps = tuple(exact.get(h.dish, h) for h in maps)
        left = budget - (clock() - t0)
        if any(h.values.max() > 0.0 for h in exact.values()) and left > 0:
            result = _plan(known, scene, method, maps, seed, left, n_sequences, workers, t0,
                           drive_margin, clock)
    unchecked = ()
    if source == FeasibilitySource.FCN and result.plan is not None:
        unchecked = tuple(d for d in result.plan.unreachable
                          if d not in exact or exact[d].values.max() > 0.0)
    # The plan's own heatmaps: Fea^m restricted to free stops, as the plan was made.
    return dataclasses.replace(result, heatmaps=result.heatmaps or maps,
                               model_heatmaps=result.model_heatmaps or maps,
                               unchecked=unchecked)


def _plan(known: KnownWorld, scene: PlanningScene, method: str, heatmaps, seed: int,
          time_budget: float | None, n_sequences: int, workers: int, t0: float,
          drive_margin: float, clock: Clock) -> PlanningResult:
    """`plan_task`, a PlanningError becoming a result that says why there is no plan;
    `t0` is when planning began, on `clock`."""
    maps = tuple(heatmaps) if isinstance(heatmaps, (list, tuple)) else ()
    try:
        return plan_task(known, scene=scene, method=method, heatmaps=heatmaps, seed=seed,
                         time_budget=time_budget, n_sequences=n_sequences, workers=workers,
                         feasibility_time=clock() - t0,
                         drive_margin=drive_margin, clock=clock)
    except (PlanningError, TaskPlanningError) as e:
        return PlanningResult(known=known, scene=scene, method=method, seed=seed, plan=None,
                              error=f"no plan: {e}", heatmaps=maps,
                              planning_time=clock() - t0)
