"""V-PETLON, the baseline without feasibility.

PETLON plans in the plain Voronoi state space (one location per dish) and knows nothing
about Fea^m: for each dish it takes a random obstacle-free base position near it (a
uniform draw from the dish's Voronoi cell, i.e. free of mapped and perceived obstacles
and within reach, where the base facing the dish is collision-free (`free`, the known
world's free-stop test of `feasibility/stops.py`), and drivable from the start on the
navigation map), and then the
task-level order that is optimal for navigation (the clingo task planner with the path
lengths between those positions as costs). Several such draws are made and the one with
the least navigation cost is kept: PETLON optimises cost, never feasibility.

Fea^m is used only to *score* the chosen plan, with the same utility as GROP*
(`motion_search.SequenceProblem`, the code GROP* scores with), so the methods are comparable.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from functools import partial

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from s3o_drake.abstraction.motion_feasibility import MotionFeasibility
from s3o_drake.abstraction.voronoi import lattice_in
from s3o_drake.planning.motion.grop import MotionResult, SequenceProblem
from s3o_drake.planning.navigation.map import NavigationMap
from s3o_drake.planning.task.costs import COST_SCALE
from s3o_drake.planning.task.planner import (
    START,
    TaskPlanningTimeoutError,
    TaskPlanResult,
    plan_problem,
)
from s3o_drake.planning.time_model import CostModel
from s3o_drake.world.deadline import Deadline
from s3o_drake.world.settings import PlanningSettings

DRAWS_PER_POSITION = 100
"""Rejection rounds (of 32 points each) to find a drivable point of a cell."""
LATTICE_AFTER = 10
"""Rounds without a point after which the cell's lattice is tested (`random_position`)."""

#: Which base positions (n, 2) facing a dish are collision-free: (points, dish) -> bool (n,).
FreeTest = Callable[[np.ndarray, str], np.ndarray]


@dataclass
class PetlonResult:
    """The kept draw: its task plan and its motion result (utility scored with Fea^m)."""

    motion: MotionResult
    task: TaskPlanResult
    positions: dict[str, np.ndarray]
    """The drawn base position per location."""
    navigation_cost: float
    """Σ path length / v of the kept plan (s): what PETLON minimised."""
    task_time: float
    motion_time: float
    draws: int


class _ExpiredError(Exception):
    """The deadline passed while drawing a goal."""


def random_position(region: BaseGeometry, nav: NavigationMap, start: np.ndarray,
                    rng: np.random.Generator,
                    free: Callable[[np.ndarray], np.ndarray] | None = None,
                    deadline: Deadline | None = None) -> np.ndarray | None:
    """A uniform point of `region` that the base can drive to from `start`, and where
    `free` (points (n, 2) -> bool (n,); None: any) holds, or None.

    Uniform by rejection in the bounding box; a point the navigation map cannot reach
    (e.g. in the band between the inscribed and the circumscribed radius with no straight
    way out) is redrawn, as PETLON's goal sampler would discard an unreachable goal.
    When the first LATTICE_AFTER rounds find nothing, the region's lattice points are
    tested: none passing ends the search (a cell with no free point cost all
    DRAWS_PER_POSITION rounds, seconds in a crowded scene: the soak's V-PETLON spent its
    5 s budget on them in 30 of 54 scenes); else the rounds go on, and if they all miss (a
    sliver of free space in a large box, task_017's bowl_2: one lattice point in sixteen,
    in a box 50 times the cell's area) the point is drawn among the passing lattice points.
    Raises `_ExpiredError` when `deadline` passes first.
    """
    if region.is_empty or region.area <= 0:
        return None
    x0, y0, x1, y1 = region.bounds
    passing: np.ndarray | None = None
    for k in range(DRAWS_PER_POSITION):
        if deadline is not None and deadline.passed():
            raise _ExpiredError
        if k == LATTICE_AFTER:
            passing = _passing_lattice(region, nav, start, free)
            if not len(passing) and len(lattice_in(region)):
                return None
        P = np.column_stack([rng.uniform(x0, x1, 32), rng.uniform(y0, y1, 32)])
        P = P[shapely.contains_xy(region, P[:, 0], P[:, 1])]
        if len(P) and free is not None:
            P = P[free(P)]
        if len(P) == 0:
            continue
        lengths = nav.path_lengths(np.broadcast_to(start, P.shape), P)
        ok = np.flatnonzero(np.isfinite(lengths))
        if len(ok):
            return P[ok[0]].copy()
    if passing is None:
        passing = _passing_lattice(region, nav, start, free)
    return passing[rng.integers(len(passing))].copy() if len(passing) else None


def _passing_lattice(region: BaseGeometry, nav: NavigationMap, start: np.ndarray,
                     free: Callable[[np.ndarray], np.ndarray] | None) -> np.ndarray:
    """The region's lattice points (`voronoi.lattice_in`) where `free` holds and that the
    base can drive to from `start`."""
    P = lattice_in(region)
    if len(P) and free is not None:
        P = P[free(P)]
    return P[nav.reachable(start, P)] if len(P) else P


def petlon(groups: Sequence[Sequence[str]], regions: Mapping[str, BaseGeometry],
           feasibility: MotionFeasibility, nav: NavigationMap, start_xy: Sequence[float],
           planner: PlanningSettings, *, rng: np.random.Generator, draws: int = 1,
           unreachable: Sequence[str] = (), deadline: Deadline | None = None,
           costs: CostModel | None = None, free: FreeTest | None = None,
           places: Mapping[str, str] | None = None) -> PetlonResult:
    """V-PETLON over the state space `groups` (location k named "l{k}", its region in
    `regions`): `draws` random position sets, each ordered optimally for navigation, the
    cheapest kept. At least one draw is made; `deadline` stops further
    draws; `costs` scores the kept plan (None: the paper's costs); `free` keeps the draws
    to positions where the base facing the location's dish is free (None: any); `places`
    as `plan_problem`'s. Raises `TaskPlanningError` if no dish can be planned."""
    start = np.asarray(start_xy, dtype=float)[:2]
    names = [f"l{k}" for k in range(len(groups))]
    best: PetlonResult | None = None
    task_time = motion_time = 0.0
    done = 0
    for i in range(max(draws, 1)):
        if i and deadline is not None and deadline.passed():
            break
        t0 = time.monotonic()
        try:
            points = {n: random_position(regions[n], nav, start, rng,
                                         None if free is None else partial(free, dish=g[0]),
                                         deadline)
                      for n, g in zip(names, groups, strict=True)}
        except _ExpiredError:
            if best is not None:  # the draws so far stand
                break
            raise TaskPlanningTimeoutError(
                "V-PETLON: the time budget expired while drawing the goals, before any "
                "plan was found") from None
        nodes = [n for n in names if points[n] is not None]
        P = np.array([points[n] for n in nodes] + [start]).reshape(-1, 2)
        keys = [*nodes, START]
        A = np.repeat(P, len(P), axis=0)
        B = np.tile(P, (len(P), 1))
        L = nav.path_lengths(A, B).reshape(len(P), len(P))
        task_costs = {(a, b): L[i_a, i_b] / planner.speed * COST_SCALE
                 for i_a, a in enumerate(keys) for i_b, b in enumerate(keys) if a != b}
        lost = set(unreachable) | {d for n, g in zip(names, groups, strict=True)
                                   if points[n] is None for d in g}
        # The first draw's order gets a moment past the deadline (there is no plan
        # without it); later draws only what remains, and are dropped if it runs out.
        remaining = None if deadline is None else max(deadline.remaining(),
                                                      0.05 if best is not None else 0.5)
        try:
            task = plan_problem(groups, task_costs, unreachable=sorted(lost), places=places,
                                n_plans=1,
                                time_limit=5.0 if remaining is None else min(5.0, remaining))
        except TaskPlanningTimeoutError:
            if best is None:
                raise
            break
        t1 = time.monotonic()
        task_time += t1 - t0
        sequence = task.best.actions
        # Scored only: the problem's grid locations (a search's starts) are never built.
        problem = SequenceProblem(sequence, regions, feasibility, nav, start, planner, None,
                                  costs)
        X = np.array([points[loc] for loc in problem.locations]).reshape(-1, 2)
        motion = problem.result("PETLON", X, 1, 0.0, [], [])
        motion_time += time.monotonic() - t1
        done += 1
        cost = float(motion.leg_lengths.sum() / planner.speed) if motion.valid else math.inf
        if best is None or cost < best.navigation_cost:
            best = PetlonResult(motion=motion, task=task, positions=points, navigation_cost=cost,
                                task_time=0.0, motion_time=0.0, draws=0)
    assert best is not None
    best.task_time, best.motion_time, best.draws = task_time, motion_time, done
    return best
