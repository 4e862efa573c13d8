"""Planning one scene with every method, and checking what comes back: the property tests'
and the soak's common step.

`plan_and_check` plans with `plan_from` (Fea^m given, so that the time measured is the
planner's and its budget's) and checks each result: a plan, or a "no plan" that says why;
the plan passes the task-level checker (`check_plan`: every pickup from the location that
holds its dish, the robot there); every goto pose is free in the known world (the
execution's own base check); and the call returned within its budget and 5 %.
`ring_heatmaps` is a cheap Fea^m for it: high on a ring around each dish, as the arm's
reach makes it, so that random scenes of 30 dishes plan in seconds, not minutes of Drake
checks.
"""

import time
import traceback
from collections.abc import Sequence

import numpy as np

from s3o_drake.belief.known_world import KnownWorld
from s3o_drake.feasibility.oracle import Heatmap
from s3o_drake.planning.plan import Goto, TaskMotionPlan
from s3o_drake.planning.task.check import check_plan
from s3o_drake.planning.task.planner import TaskProblem
from s3o_drake.world.choices import METHODS
from s3o_drake.world.deadline import Clock
from s3o_drake.world.goals import place_target_name, placed_object

OVERRUN = 0.05
"""A call that takes more than its budget and this share of it overran."""
RING = (0.45, 0.9)  # Fea^m is high between these distances from the dish (m)


def ring_heatmaps(known: KnownWorld, *, size: float = 3.0, cells: int = 30) -> list[Heatmap]:
    """A cheap Fea^m per dish: 0.9 on the ring RING around it, 0 elsewhere (the planner
    then keeps only the free stops of it)."""
    cell = size / cells
    out = []
    for dish in known.dishes:
        p = np.asarray(dish.position[:2], float)
        h = Heatmap(dish.name, np.zeros((cells, cells)), p[0] - size / 2, p[1] - size / 2,
                    cell)
        r = np.linalg.norm(h.centers() - p, axis=-1)
        out.append(Heatmap(dish.name, np.where((r > RING[0]) & (r < RING[1]), 0.9, 0.0),
                           h.x0, h.y0, cell))
    return out


def plan_problems(p: TaskMotionPlan) -> TaskProblem:
    """The task-level problem a plan claims to solve: its locations, which holds which
    dish, and which the place of each object to place (None: left out as unreachable)."""
    where: dict[str, str | None] = {d: name for name, group in
                                    zip(p.locations, p.groups, strict=True) for d in group}
    for d in p.unreachable:
        where[d] = None
    dishes = {d: loc for d, loc in where.items() if placed_object(d) is None}
    places = {placed_object(d): loc for d, loc in where.items() if placed_object(d)}
    # An object whose place is planned but which is itself in no location is in the hand.
    held = next((o for o in places if o not in dishes), None)
    if held is not None:
        dishes[held] = None
    return TaskProblem(locations=p.locations, dishes=dishes, costs=lambda a, b: 0.0,
                       places=places, held=held)


def plan_faults(known: KnownWorld, p: TaskMotionPlan, base_free) -> list[str]:
    """What is wrong with plan `p` of `known` (empty when nothing): the task-level checker,
    every dish planned or left out, every goto pose free by `base_free` (poses (n, 3) ->
    bools)."""
    faults = []
    try:
        check_plan(plan_problems(p), p.task_actions)
    except Exception as e:  # the checker's verdict, kept as text
        faults.append(f"plan checker: {e}")
    planned = {a.dish for a in p.pickups} | {place_target_name(a.dish) for a in p.places} \
        | set(p.unreachable)
    if planned != set(known.dish_names):
        faults.append(f"dishes planned {sorted(planned)} != known {sorted(known.dish_names)}")
    poses = np.array([a.pose for a in p.actions if isinstance(a, Goto)], float).reshape(-1, 3)
    if len(poses):
        blocked = [i for i, free in enumerate(base_free(poses)) if not free]
        if blocked:
            faults.append(f"goto poses not free: {[poses[i].round(3).tolist() for i in blocked]}")
    return faults


def plan_and_check(known: KnownWorld, *, heatmaps: Sequence[Heatmap], budget: float,
                   base_free, methods: Sequence[str] = METHODS,
                   seed: int | None = None, clock: Clock = time.perf_counter
                   ) -> dict[str, dict]:
    """Per method: `planned`, `error` (why there is no plan), `crash` (an exception, with
    its traceback in `traceback`), `faults` (plan_faults), `seconds`, `cpu` (this process's
    CPU seconds over the same span: a planner that got much less than `seconds` was starved
    by other work, and its wall-time budget with it) and `overrun` (more than OVERRUN over
    `budget`). `clock` measures the budget and `seconds` (`world.deadline`); it plans in
    this process alone, so its CPU time (`time.process_time`) can serve: a budget that the
    machine's other work does not eat."""
    from s3o_drake.feasibility.planning_scene import PlanningScene
    from s3o_drake.planning.pipeline import plan_from  # Drake's import is the caller's

    scene = PlanningScene(known)  # one belief, planned by every method
    out = {}
    for method in methods:
        row: dict = {"planned": False, "error": "", "crash": "", "faults": []}
        start, cpu = clock(), time.process_time()
        try:
            # "oracle": the heatmaps given are not the network's, which plan_from would
            # check again with the oracle for the dishes it leaves out.
            result = plan_from(known, method=method, seed=seed, workers=1, time_budget=budget,
                               heatmaps=list(heatmaps), feasibility="oracle", scene=scene,
                               clock=clock)
            seconds = clock() - start
            row["planned"] = result.plan is not None
            row["error"] = result.error
            if result.plan is None and not result.error:
                row["faults"].append("no plan and no reason")
            if result.plan is not None:
                row["complete"] = result.plan.complete
                row["faults"] += plan_faults(known, result.plan, base_free)
        except Exception as e:  # a crash is what the soak counts
            seconds = clock() - start
            row["crash"] = f"{type(e).__name__}: {e}".splitlines()[0]
            row["traceback"] = traceback.format_exc(limit=8)
        row["seconds"] = seconds
        row["cpu"] = time.process_time() - cpu
        row["overrun"] = seconds > budget * (1 + OVERRUN)
        out[method] = row
    return out
