"""The compared methods, as a registry (`REGISTRY`, `Method`), planned under one time budget.

`plan_task(known, method=..., heatmaps=..., seed=...)` plans from what the robot knows (a
`KnownWorld`) with Fea^m given; the planning pipeline (`pipeline.plan_from`) computes Fea^m
and calls it. It runs

- **S3O-GROP*** : the top-K S3O state spaces, searched in an order drawn from the
  normalised top-K scores (weighted sampling *without* replacement, so that each of them is
  searched once and, when the budget cuts the search, the likelier ones were searched
  first), and with `planner.search_plain_voronoi` the unmerged space after them when it is
  not among them; per state space the clingo task planner gives `n_sequences` task-level
  sequences and one GROP* (CMA-ES) runs per sequence;
- **S3O-GROP**  : the same with GROP (Fea^m-weighted sampling) per sequence;
- **V-GROP*** / **V-GROP**: the plain Voronoi state space (no merging), searched as many
  times as S3O searches state spaces (K iterations, fresh seeds), so that every method
  spends the same number of motion searches;
- **V-PETLON**  : plain Voronoi, random obstacle-free positions, the navigation-optimal
  order, K draws, the cheapest kept; Fea^m only scores it (`petlon.py`);
- **S3O-Random**: K state spaces drawn uniformly among all candidates, GROP* on each.
- **S3O-Random-Paper**: the paper's ablation as its text describes it ("uniformly samples
  state spaces from all possible candidates"): one state space drawn uniformly among all
  candidates, GROP* on it alone, with the searches S3O-GROP* spreads over its top K. Ours
  (S3O-Random) draws K and keeps the plan of highest utility, so a poor draw loses to a
  good one beside it.

The plan of highest utility wins (V-PETLON: least navigation cost). Every method commands
only stops that are free as planned (Fea^m 0 elsewhere, `feasibility/stops.py`).

Costs for the task planner: `task_costs.py`.

One location grid per plan. Fea^m is evaluated once on the 5 cm location grid of the
plan's Voronoi partition (built with the abstraction for the S3O methods, on the plain
partition for V-GROP*/V-GROP; V-PETLON, which never samples a grid, builds none). Fea^t,
the representative points and the motion searches read its locations, cached per (group,
dishes); the result carries it.

Budget. `time_budget` (default `scenario.planner.time_budget`) is a cap, not a target:
planning stops when every iteration is searched. One deadline (`world.deadline`, on the
planner's clock) is checked between stages, before every state space, sequence and PETLON
draw, and inside GROP*/GROP between generations; clingo gets the remaining time as its
limit. When it expires the best plan so far is returned with `complete=False`. If it
expires before any plan exists a `PlanningTimeoutError` says in which stage. Stages that
cannot be interrupted (building the navigation map, the Voronoi partition and Fea^t,
clingo's grounding) may overrun a tiny budget by their own duration.

Workers. With `workers > 1` the motion searches (one per task-level sequence) run in that
many worker processes while this process goes on with the next state space's task
planning. The workers are forked once the navigation map, the abstraction and Fea^m exist,
so they inherit them (and the location grid) instead of rebuilding or unpickling them;
only a sequence, its regions and its locations' groups travel to a worker, and a
`MotionResult` back. They never call Drake. Where fork is not available (not Linux), or
this process may not have children (a daemonic process: a Dask worker, a process pool's
worker), the searches run in this process.

Determinism. All randomness comes from generators seeded with (seed, purpose, iteration,
sequence), and results are compared in submission order, so the same seed gives the same
plan whatever the number of workers (unless the budget cuts the search, when how far each
got depends on the machine).
"""

from __future__ import annotations

import dataclasses
import gc
import multiprocessing
import time
from collections.abc import Callable
from concurrent.futures import Future, ProcessPoolExecutor
from dataclasses import dataclass
from functools import partial

import numpy as np
from shapely.geometry.base import BaseGeometry

from s3o_drake.abstraction import (
    Abstraction,
    StateSpace,
    build_abstraction,
    voronoi_partition,
)
from s3o_drake.abstraction.location_grid import LocationGrid
from s3o_drake.abstraction.motion_feasibility import as_motion_feasibility, heatmap_tuple
from s3o_drake.abstraction.voronoi import VoronoiPartition
from s3o_drake.belief.known_world import KnownWorld
from s3o_drake.feasibility.planning_scene import PlanningScene
from s3o_drake.planning.failure_price import priced_planner
from s3o_drake.planning.motion.free_positions import FreeTest, with_free_stops
from s3o_drake.planning.motion.grop import (
    MotionResult,
    SequenceProblem,
    grop,
    grop_star,
    location_regions,
)
from s3o_drake.planning.motion.petlon import petlon
from s3o_drake.planning.navigation.map import DRIVE_MARGIN, NavigationMap
from s3o_drake.planning.plan import (
    Goto,
    Pickup,
    Place,
    PlanAction,
    TaskMotionPlan,
    samples_tuple,
)
from s3o_drake.planning.result import PlanningResult
from s3o_drake.planning.task.costs import dead_dishes, location_costs, representative_points
from s3o_drake.planning.task.planner import (
    TaskPlanningTimeoutError,
    TaskPlanResult,
    plan_problem,
)
from s3o_drake.planning.time_model import CostModel
from s3o_drake.world.angles import facing_yaw
from s3o_drake.world.choices import METHODS
from s3o_drake.world.deadline import Clock, Deadline
from s3o_drake.world.goals import place_target_name
from s3o_drake.world.settings import PlanningSettings

WORKER_SLACK = 0.03
"""Share of the remaining budget by which worker processes stop before the deadline."""
TASK_TIME_LIMIT = 2.0
"""Cap on one clingo call (s), below the remaining budget: issue 22's target per state space.
From about 12 locations on clingo proves no order in seconds, and from 20 on local search's
order is within a few tenths of a percent of the optimum (docs/planning.md)."""
TASK_SHARE = 0.8
"""Share of the remaining budget one clingo call may take: the rest is left to the motion
search of its sequences. On a 30-dish task clingo would otherwise take all of it (it stops
with its best order so far), and the one search left started at the deadline and ran its
first generation past it (the budget test overran by 2-6 %)."""
# Purposes mixed into seeds so that different draws never share a stream.
_ORDER, _SEARCH, _PETLON = 1, 2, 3


class PlanningError(RuntimeError):
    """No plan could be made."""


class PlanningTimeoutError(PlanningError, TimeoutError):
    """The time budget expired before any plan was found."""


@dataclass
class _Best:
    motion: MotionResult
    groups: tuple[tuple[str, ...], ...]
    regions: dict[str, BaseGeometry]
    unreachable: tuple[str, ...]
    score: float | None
    task: TaskPlanResult
    """The task planning of its state space: what clingo proved of its order."""


# What a forked search worker inherits: set just before the pool forks, read by _search_job.
_inherited: dict | None = None


def _search_job(job: tuple) -> MotionResult | None:
    """One motion search; None when the deadline passed before it started, unless it is
    the plan's first (there is no plan without one): a search handed to a worker waits in
    the pool's queue, and would spend its first generation past the deadline."""
    actions, regions, groups, seed_key, first = job
    s = _inherited
    assert s is not None, "search workers must be forked by _Searches"
    if not first and s["deadline"].passed():
        return None
    return s["search"](actions, regions, s["fea"], s["nav"], s["start"], s["planner"],
                       rng=np.random.default_rng(seed_key), deadline=s["deadline"],
                       costs=s["costs"], grid=s["grid"], groups=groups)


class _Searches:
    """Motion searches run here (workers <= 1) or in forked worker processes; results
    come back in submission order."""

    def __init__(self, workers: int, search: Callable[..., MotionResult], fea, nav, start,
                 planner, deadline: Deadline, costs: CostModel, grid: LocationGrid,
                 free: FreeTest):
        global _inherited
        self._free = free
        # Workers stop a little early: collecting their results and letting them go takes
        # time too, and the budget must hold for the whole call.
        # A daemonic process (a Dask worker) that starts a pool fails with "daemonic
        # processes are not allowed to have children": it searches here, to the same plan.
        parallel = workers > 1 and "fork" in multiprocessing.get_all_start_methods() \
            and not multiprocessing.current_process().daemon
        slack = WORKER_SLACK * max(0.0, deadline.remaining()) if parallel else 0.0
        self._shared = dict(search=search, fea=fea, nav=nav, start=start, planner=planner,
                            deadline=deadline.sooner(slack), costs=costs, grid=grid)
        self._pool: ProcessPoolExecutor | None = None
        self._pending: list[tuple[object, Future | MotionResult | None]] = []
        if parallel:
            _inherited = self._shared
            self._pool = ProcessPoolExecutor(max_workers=workers,
                                             mp_context=multiprocessing.get_context("fork"))

    def submit(self, key: object, actions, regions, groups, seed_key: list[int],
               first: bool) -> None:
        """Starts the search of `actions` (`_search_job`; `first`: the plan's first)."""
        job = (actions, regions, groups, seed_key, first)
        if self._pool is None:
            global _inherited
            _inherited = self._shared
            self._pending.append((key, _search_job(job)))
        else:
            # A submission may fork the workers. What they inherit is frozen out of their
            # garbage collection, as CPython advises before a fork: they never free it, and
            # collecting it crashed a child (docs/reliability.md). Freezing is O(1).
            gc.freeze()
            try:
                self._pending.append((key, self._pool.submit(_search_job, job)))
            finally:
                gc.unfreeze()

    def results(self) -> list[tuple[object, MotionResult]]:
        """Every submitted search's (key, result), in submission order; searches that
        had not started when the deadline passed are dropped."""
        out = []
        for key, item in self._pending:
            if isinstance(item, Future):
                if self._shared["deadline"].passed() and item.cancel():
                    continue
                item = item.result()
            if item is not None:
                out.append((key, item))
        return out

    def cut(self) -> bool:
        """Whether the searches' deadline (the workers' is a little early) has passed: a
        search may then have been cut short, or dropped."""
        return self._shared["deadline"].passed()

    def with_free_stops(self, result: MotionResult, regions) -> MotionResult:
        """`result` with its stops moved where they are not free (`free_positions.py`)."""
        s = self._shared
        problem = SequenceProblem(result.actions, regions, s["fea"], s["nav"], s["start"],
                                  s["planner"], None, s["costs"])
        return with_free_stops(result, problem, self._free)

    def close(self) -> None:
        global _inherited
        if self._pool is not None:
            # The results are in: no need to wait for the workers to exit.
            self._pool.shutdown(wait=False, cancel_futures=True)
        _inherited = None


Spaces = list[tuple[tuple[tuple[str, ...], ...], float | None]]
"""The state spaces a method searches, one per iteration: (groups, the paper's Score)."""


def _plain_spaces(abstraction: Abstraction | None, partition: VoronoiPartition,
                  rng: np.random.Generator, iterations: int,
                  planner: PlanningSettings) -> Spaces:
    """V-: the plain Voronoi space, searched every iteration with fresh seeds."""
    return [(tuple((d,) for d in partition.dishes), None)] * iterations


def _top_k_spaces(abstraction: Abstraction | None, partition: VoronoiPartition,
                  rng: np.random.Generator, iterations: int,
                  planner: PlanningSettings) -> Spaces:
    """S3O: the top K in an order drawn from their scores (`_order`), and with
    `search_plain_voronoi` the unmerged space after them when it is not among them."""
    assert abstraction is not None
    spaces = [(s.groups, s.score) for s in _order(abstraction, rng)]
    plain = abstraction.plain_voronoi
    if planner.search_plain_voronoi and all(g != plain.groups for g, _ in spaces):
        # Searched last: the top K keep their seeds and their share of the budget.
        spaces.append((plain.groups, plain.score))
    return spaces


def _random_spaces(abstraction: Abstraction | None, partition: VoronoiPartition,
                   rng: np.random.Generator, iterations: int,
                   planner: PlanningSettings) -> Spaces:
    """S3O-Random: K state spaces drawn uniformly among all candidates."""
    assert abstraction is not None
    return [(s.groups, s.score) for s in
            (abstraction.random_candidate(rng) for _ in range(iterations))]


def _one_random_space(abstraction: Abstraction | None, partition: VoronoiPartition,
                      rng: np.random.Generator, iterations: int,
                      planner: PlanningSettings) -> Spaces:
    """S3O-Random-Paper: one state space drawn uniformly, searched every iteration."""
    assert abstraction is not None
    drawn = abstraction.random_candidate(rng)
    return [(drawn.groups, drawn.score)] * iterations


@dataclass(frozen=True)
class Method:
    """One compared method: whether it builds S3O's abstraction, how it chooses the state
    spaces it searches, and the motion search it runs on each of their task-level sequences.
    V-PETLON (no `spaces`, no `search`) draws its own goals (`motion/petlon.py`)."""

    name: str
    abstraction: bool
    spaces: Callable[..., Spaces] | None
    search: Callable[..., MotionResult] | None


REGISTRY: dict[str, Method] = {m.name: m for m in (
    Method("S3O-GROP*", True, _top_k_spaces, grop_star),
    Method("S3O-GROP", True, _top_k_spaces, grop),
    Method("V-GROP*", False, _plain_spaces, grop_star),
    Method("V-GROP", False, _plain_spaces, grop),
    Method("V-PETLON", False, None, None),
    Method("S3O-Random", True, _random_spaces, grop_star),
    Method("S3O-Random-Paper", True, _one_random_space, grop_star),
)}
"""The methods by name (`choices.METHODS` names them without importing this module)."""


def method_of(name: str) -> Method:
    """The registered method `name`; ValueError naming the known ones otherwise."""
    if name not in REGISTRY:
        raise ValueError(f"unknown planning method {name!r}; known: {', '.join(METHODS)}")
    return REGISTRY[name]


def _order(abstraction: Abstraction, rng: np.random.Generator) -> list[StateSpace]:
    """The top-K state spaces in an order drawn from their normalised scores (weighted
    sampling without replacement); zero-probability ones follow in rank order."""
    p = np.asarray(abstraction.probabilities, dtype=float)
    positive = np.flatnonzero(p > 0)
    order = list(rng.choice(positive, size=len(positive), replace=False,
                            p=p[positive] / p[positive].sum())) if len(positive) else []
    order += [k for k in range(len(p)) if p[k] <= 0]
    return [abstraction.top_k[int(k)] for k in order]


def _assemble(method: str, seed: int, best: _Best, known: KnownWorld, nav: NavigationMap,
              costs: CostModel, timing: dict[str, float], planning_time: float,
              searches: int, samples: int, complete: bool) -> TaskMotionPlan:
    """The TaskMotionPlan of the winning motion result: poses facing the next dish, paths
    from the navigation map."""
    motion = best.motion
    if not motion.actions:  # every dish lost: nothing to search or to order
        return _stay(method, seed, timing, planning_time, unreachable=best.unreachable)
    dish_xy = {d.name: d.position for d in known.dishes}
    pose = np.asarray(known.pose[:2], dtype=float)
    here = nav.way_out(pose)
    location = "start"
    actions: list[PlanAction] = []
    k = 0
    for i, (name, arg) in enumerate(motion.actions):
        if name == "goto":
            y = np.asarray(motion.positions[k], dtype=float)
            # Facing the next object to pick, or the place of the next one to put down.
            nxt = next((a if n == "pickup" else place_target_name(a)
                        for n, a in motion.actions[i + 1:] if n in ("pickup", "place")), None)
            path = nav.path(here, y)
            if path is None:
                raise PlanningError(f"goto {arg}: no path from {here.tolist()} to {y.tolist()}")
            if k == 0 and not np.array_equal(here, pose):  # backing out first
                path = np.vstack([pose, path])
            yaw = facing_yaw(y, dish_xy[nxt]) if nxt is not None else facing_yaw(path[-2], y)
            actions.append(Goto(location=arg, pose=(float(y[0]), float(y[1]), float(yaw)),
                                path=tuple((float(p[0]), float(p[1])) for p in path),
                                length=float(motion.leg_lengths[k])))
            here, location, k = y, arg, k + 1
        elif name == "place":
            actions.append(Place(dish=arg, location=location,
                                 feasibility=float(motion.feasibility[place_target_name(arg)])))
        else:
            actions.append(Pickup(dish=arg, location=location,
                                  feasibility=float(motion.feasibility[arg])))
    names = tuple(f"l{j}" for j in range(len(best.groups)))
    return TaskMotionPlan(method=method, seed=int(seed), groups=best.groups, locations=names,
                          actions=tuple(actions), utility=float(motion.utility),
                          predicted_time=float(motion.predicted_time),
                          planning_time=float(planning_time), timing=dict(timing),
                          unreachable=best.unreachable, score=best.score, searches=searches,
                          samples=samples, complete=complete,
                          early_samples=samples_tuple(motion.early),
                          late_samples=samples_tuple(motion.late),
                          order=best.task.order_of(motion.actions),
                          expected_time=costs.expected_time(motion.predicted_time, actions))


def _stay(method: str, seed: int, timing: dict[str, float], planning_time: float, *,
          unreachable: tuple[str, ...] = ()) -> TaskMotionPlan:
    """The plan with no actions: nothing left to collect, or nothing any stop can pick."""
    return TaskMotionPlan(method=method, seed=int(seed), groups=(), locations=(), actions=(),
                          utility=0.0, predicted_time=0.0, planning_time=float(planning_time),
                          timing=dict(timing), unreachable=unreachable)


def plan_task(known: KnownWorld, *, method: str, heatmaps, seed: int,
              scene: PlanningScene | None = None,
              time_budget: float | None = None, n_sequences: int = 3, workers: int = 1,
              feasibility_time: float = 0.0, drive_margin: float = DRIVE_MARGIN,
              clock: Clock = time.monotonic) -> PlanningResult:
    """Plans the collection of the known world's dishes from its pose with the named
    method (see the module docstring).

    `heatmaps`: Fea^m (a `MotionFeasibility`, a mapping dish -> Heatmap or a list of
    Heatmaps); `feasibility_time` is how long computing them took (s), added to the
    breakdown and the planning time; `drive_margin` is the navigation map's. `clock`
    measures the budget and the times reported (`world.deadline`). Raises
    ValueError for an unknown method, `PlanningTimeoutError` when the budget expires before
    any plan, `PlanningError` (or `TaskPlanningError`) when no dish can be planned.
    """
    spec = method_of(method)
    t_start = clock()
    # λ as the execution's mode prices a pickup's failure (`failure_price.py`): every part
    # of the plan reads the planner settings from here on. The result names the world as
    # the caller knew it.
    asked = known
    priced = priced_planner(known.settings, robot=known.robot)
    if priced is not known.planner:
        known = dataclasses.replace(known, settings=dataclasses.replace(known.settings,
                                                                        planner=priced))
    budget = known.planner.time_budget if time_budget is None else float(time_budget)
    deadline = Deadline(t_start + budget, clock)
    planner = known.planner
    start = np.asarray(known.pose[:2], dtype=float)
    timing = {"feasibility": float(feasibility_time), "navigation": 0.0, "abstraction": 0.0,
              "task_planning": 0.0, "motion_search": 0.0}
    searches = samples = 0
    best: _Best | None = None
    complete = True
    if not known.dishes:  # nothing to collect: the empty plan is the optimal one
        empty = _stay(method, seed, timing, feasibility_time + clock() - t_start)
        return PlanningResult(known=asked, method=method, seed=int(seed), plan=empty,
                              planning_time=empty.planning_time)

    def expired(stage: str, fatal: bool = True, spent: bool = False) -> bool:
        """Whether the deadline passed, or the stage `spent` its share of the budget (the
        plan is then incomplete); raises when it did and `fatal` and no plan exists."""
        nonlocal complete
        if not spent and not deadline.passed():
            return False
        complete = False
        if fatal and best is None:
            raise PlanningTimeoutError(f"{method}: the time budget of {budget:g} s expired during "
                                  f"{stage}, before any plan was found")
        return True

    t = clock()  # only stops free as planned are commanded (feasibility/stops.py)
    scene = PlanningScene(known) if scene is None else scene
    stops = scene.free_stops
    model_heatmaps = heatmap_tuple(heatmaps)
    fea = as_motion_feasibility(heatmaps := stops.restrict_source(
        heatmaps, lambda: expired("the free stops")))
    timing["feasibility"] += clock() - t
    expired("the free stops")

    t = clock()
    nav = NavigationMap(known.obstacles, robot=known.robot, drive_margin=drive_margin)
    # Where the robot stands may be no base position of the known map (after a blocked
    # drive it stands against a chair the map knows only roughly): planning starts from
    # the nearest driveable point, and the first drive backs out to it.
    start = nav.way_out(start)
    costs = CostModel.for_known(known, start=start)
    # The graph routes' motion times, once, before search workers fork and inherit them.
    nav.route_table(costs.base)
    timing["navigation"] = clock() - t
    expired("the navigation map")

    t = clock()
    abstraction: Abstraction | None = None
    grid: LocationGrid | None = None
    if spec.abstraction:
        # One price for a location: the ranking's γ / λ is the paper's, or the search's own.
        location_cost = costs.gamma / costs.reward \
            if planner.location_price == "search" and costs.reward > 0 else None
        abstraction = build_abstraction(
            known, fea, seed=seed, time_limit=max(0.0, min(5.0, deadline.remaining())),
            drivable=partial(nav.reachable, start), location_cost=location_cost)
        partition: VoronoiPartition = abstraction.partition
        grid = abstraction.grid
    else:
        partition = voronoi_partition(known, feasibility=fea, deadline=deadline,
                                      drivable=partial(nav.reachable, start))
        if spec.spaces is not None:  # PETLON draws its goals uniformly: it reads no grid
            grid = LocationGrid.of(partition, fea, drivable=partial(nav.reachable, start))
    timing["abstraction"] = clock() - t
    expired("the abstraction")
    if not set(partition.dishes) - set(partition.unreachable):
        # No free stop picks any dish: the plan is to stay, and no search runs.
        empty = _stay(method, seed, timing, feasibility_time + clock() - t_start,
                      unreachable=tuple(sorted(partition.unreachable)))
        return PlanningResult(known=asked, scene=scene, method=method, seed=int(seed),
                              plan=empty, navigation=nav, heatmaps=heatmap_tuple(heatmaps),
                              model_heatmaps=model_heatmaps, partition=partition,
                              abstraction=abstraction, planning_time=empty.planning_time)
    cells = dict(zip(partition.dishes, partition.cells, strict=True))
    iterations = max(planner.top_k, 1)

    if spec.spaces is None:  # V-PETLON
        groups = tuple((d,) for d in partition.dishes)
        regions = location_regions(groups, cells)
        result = petlon(groups, regions, fea, nav, start, planner,
                        rng=np.random.default_rng([seed, _PETLON]), draws=iterations,
                        unreachable=partition.unreachable, deadline=deadline, costs=costs,
                        free=stops.goal_test(model_heatmaps, heatmap_tuple(heatmaps)),
                        places=known.places)
        timing["task_planning"] += result.task_time
        timing["motion_search"] += result.motion_time
        complete = result.draws == iterations
        unreachable = tuple(sorted(set(result.task.unreachable) | set(partition.unreachable)))
        best = _Best(result.motion, groups, regions, unreachable, None, result.task)
        made = _assemble(method, seed, best, known, nav, costs, timing,
                         clock() - t_start + feasibility_time, result.draws,
                         result.draws, complete)
        return PlanningResult(known=asked, scene=scene, method=method, seed=int(seed),
                              plan=made,
                              heatmaps=heatmap_tuple(heatmaps), navigation=nav,
                              model_heatmaps=model_heatmaps, partition=partition,
                              planning_time=made.planning_time)

    # The state spaces to search, one per iteration.
    spaces = spec.spaces(abstraction, partition, np.random.default_rng([seed, _ORDER]),
                         iterations, planner)
    search = spec.search

    tasks: dict[tuple[tuple[str, ...], ...], tuple[TaskPlanResult, dict[str, BaseGeometry]]] = {}
    assert grid is not None
    searches_run = _Searches(workers, search, fea, nav, start, planner, deadline, costs, grid,
                             stops.free_facing)
    try:
        best, searches, samples = _search_spaces(
            spaces, tasks, searches_run, cells, partition, grid, nav, start, planner,
            n_sequences, seed, deadline, timing, expired, known.places)
    finally:
        searches_run.close()
    if searches_run.cut():
        complete = False
    if best is None:
        expired("the motion search")
        raise PlanningError(f"{method}: no valid plan (every motion search ended outside its "
                            f"regions or on an undrivable leg)")
    made = _assemble(method, seed, best, known, nav, costs, timing,
                     clock() - t_start + feasibility_time, searches, samples, complete)
    return PlanningResult(known=asked, scene=scene, method=method, seed=int(seed), plan=made,
                          navigation=nav,
                          heatmaps=heatmap_tuple(heatmaps), partition=partition, grid=grid,
                          model_heatmaps=model_heatmaps, abstraction=abstraction,
                          planning_time=made.planning_time,
                          task_plans=tuple((g, task) for g, (task, _) in tasks.items()))


def _search_spaces(spaces, tasks, searches_run: _Searches, cells, partition, grid, nav, start,
                   planner, n_sequences, seed, deadline, timing, expired, places):
    """Task planning per state space here, motion searches through `searches_run`; the
    best result (ties: the first submitted), and how many searches and samples ran.
    `expired(stage, fatal)` is plan_task()'s: fatal until a search has been submitted."""
    submitted = False
    for it, (groups, score) in enumerate(spaces):
        if expired("the motion search", not submitted):
            break
        t = deadline.now()
        names = [f"l{k}" for k in range(len(groups))]
        if groups not in tasks:
            regions = location_regions(groups, cells)
            points = representative_points(regions, groups, names, grid, nav, start)
            costs = location_costs(points, nav, start, planner.speed)
            lost = sorted(set(partition.unreachable) | dead_dishes(groups, grid)
                          | {d for n, g in zip(names, groups, strict=True)
                             if points[n] is None for d in g})
            remaining = deadline.remaining()
            if remaining <= 0:
                expired("task planning", not submitted)
                break
            limit = min(TASK_TIME_LIMIT, TASK_SHARE * remaining)
            try:
                tasks[groups] = (plan_problem(groups, costs, unreachable=lost, places=places,
                                              n_plans=n_sequences, time_limit=limit),
                                 regions)
            except TaskPlanningTimeoutError:
                if limit >= TASK_TIME_LIMIT:
                    raise  # clingo's own cap ran out, not the budget
                # The budget's share cut clingo: what is left of the budget is the motion
                # search's, and with no sequence yet there is nothing to search.
                expired("task planning", not submitted, spent=True)
                break
        task, regions = tasks[groups]
        timing["task_planning"] += deadline.now() - t
        unreachable = tuple(sorted(set(task.unreachable) | set(partition.unreachable)))
        for j, sequence in enumerate(task.plans):
            if (j or submitted) and expired("the motion search", False):
                break
            t = deadline.now()
            searches_run.submit((groups, regions, unreachable, score), sequence.actions,
                                regions, dict(zip(names, groups, strict=True)),
                                [seed, _SEARCH, it, j], first=not submitted)
            submitted = True
            timing["motion_search"] += deadline.now() - t
    t = deadline.now()
    best = None
    searches = samples = 0
    found = []
    for n, (key, result) in enumerate(searches_run.results()):
        # A search that started as the deadline passed may have had no time for a sample.
        searches += 1
        samples += result.samples
        if result.valid:
            found.append((result.utility, -n, key, result))
    # The best result with its stops made free (free_positions.py): a move only lowers a
    # result's utility, so results rated below the best moved one need no check (ties:
    # the first submitted).
    for _, _, (groups, regions, unreachable, score), result in sorted(found, reverse=True,
                                                                       key=lambda f: f[:2]):
        if best is not None and result.utility <= best.motion.utility:
            break
        result = searches_run.with_free_stops(result, regions)
        if result.valid and (best is None or result.utility > best.motion.utility):
            best = _Best(result, groups, regions, unreachable, score, tasks[groups][0])
    timing["motion_search"] += deadline.now() - t
    return best, searches, samples
