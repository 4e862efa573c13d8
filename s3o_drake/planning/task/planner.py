"""The clingo task planner: task-level sequences of `goto`/`pickup` actions.

The domain (fluents, actions, preconditions, effects, goal, objective) is declarative, in
`domain.lp` beside this file; Python only writes the problem facts, runs clingo under a
time limit and reads the answer sets back. A problem that only collects onto an unlimited
tray (the restaurant's) is solved by `order.lp` instead, which chooses only the order of
the locations to visit (`visits_only`): the same answers, without the time steps, so that
clingo proves the order of 30 dishes in 8 locations in 0.02 s where `domain.lp` proved
nothing in 10 s. Both load `locations.lp`, the reachability they share.

The planner minimises the total navigation cost between locations (integers the caller
computes, e.g. path-length seconds x 10) and returns the N best distinct sequences, because
the motion search (GROP*) works on several sequences per state space, not only the
optimum.

Distinct sequences. The domain puts every plan in a canonical form: the dishes of one
location are picked up in name order, the robot never leaves a location while a dish it
could carry is still there, and it only drives to a location where there is something to
do. A plan is then fixed by its order of `goto`s, so N answers are N different visiting
orders. The next-best sequence is found by adding a constraint that forbids each sequence
found so far (multi-shot clingo) and minimising again.

Unreachable dishes. A dish without a location (its Voronoi cell is empty) or whose location
cannot be reached from the start with finite costs cannot be planned. The domain derives
`unreachable/1` at grounding time. By default (`on_unreachable="skip"`) the planner plans for
the other dishes and reports the rest in `TaskPlanResult.unreachable`, so that one bad dish
does not cost the whole task (issue 5, item 7); `on_unreachable="raise"` raises a
`TaskPlanningError` that names them. A problem with no plan at all always raises.

Time limit. Grounding is small (O(h·|L|²) cost rules); solving runs asynchronously and is
cancelled when the limit expires, the best model found so far is kept, and every plan says
whether clingo proved it optimal. If not even one plan was found in time, a
`TaskPlanningError` says so.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from importlib import resources
from typing import Literal

import clingo
import numpy as np

from s3o_drake.planning.task.exact_order import assignment_bound
from s3o_drake.planning.task.problem import (
    START,
    Action,
    CostSpec,
    TaskPlan,
    TaskPlanResult,
    TaskProblem,
    cost_lower_bound,
    problem_facts,
    sym_str,
)
from s3o_drake.planning.task.visit_order import (
    LOCATIONS,
    ORDER,
    hinted_models,
    visit_actions,
    visit_hints,
    visit_matrix,
    visits_only,
)

__all__ = [
    "START",
    "Action",
    "CostSpec",
    "TaskPlan",
    "TaskPlanResult",
    "TaskPlanningError",
    "TaskPlanningTimeoutError",
    "TaskProblem",
    "cost_lower_bound",
    "horizon",
    "plan_problem",
    "plan_tasks",
    "problem_facts",
    "visits_only",
]

DOMAIN = "domain.lp"
BOUND = "#external bounded(b). :- bounded(b), #sum { C, K : cost(K, C) } >= b."
"""With a hinted order of cost b, order.lp's first search looks only for cheaper orders:
when it exhausts them, the hint is proven optimal."""
STALL = 0.3
"""With a hinted order, clingo's search stops after this long (s) without a cheaper order,
below LARGE locations to visit, where it proves orders: on the scale benchmark's tasks,
every state space of the 10-dish tasks (8 locations, median) and half of those of the
15-dish tasks (10)..."""
LARGE = 12
LARGE_STALL = 0.05
"""...and from LARGE locations on after this long: there it proved no order in 2 s, and
in 83 state spaces of 5-40 dish tasks (and 48 more of the scale benchmark at 0.1 s) it
never found an order cheaper than local search's (docs/planning.md). 0.1 s made the
main process's task planning a quarter of a 40-dish plan's time."""


class TaskPlanningError(RuntimeError):
    """No task plan: unreachable dishes (with `on_unreachable="raise"`), no plan at all,
    or no plan found within the time limit."""


class TaskPlanningTimeoutError(TaskPlanningError):
    """No task plan found within the time limit (one may exist)."""


def horizon(problem: TaskProblem, targets: int | None = None) -> int:
    """Steps enough for any canonical plan.

    Unlimited tray: one goto per non-empty location plus one pickup per dish (each location
    is visited once). With a capacity, a location may be visited again and the depot once
    per trip: at most 2·n + 2·ceil(n / capacity), which also covers plans with more than the
    minimum number of trips as long as they do not use more steps.
    """
    located = [loc for loc in problem.dishes.values() if loc is not None]
    n = len(located) if targets is None else targets
    # Each object to place adds its place, and may need two drives more: to its place and
    # back to where the gripper was needed (a location visited again).
    p = sum(loc is not None for loc in problem.places.values())
    if problem.capacity is None:
        h = n + len(set(located)) + 3 * p
        return h + (2 if problem.depot is not None else 0)
    trips = math.ceil(n / problem.capacity) if n else 0
    return 2 * n + 2 * trips + 3 * p


def _actions(symbols: Sequence[clingo.Symbol]) -> tuple[Action, ...]:
    steps = []
    for s in symbols:
        if s.name != "occurs":
            continue
        act, t = s.arguments
        arg = sym_str(act.arguments[0]) if act.arguments else ""
        if act.name == "unload":
            arg = ""
        steps.append((t.number, (act.name, arg)))
    return tuple(a for _, a in sorted(steps))


def plan_tasks(problem: TaskProblem, *, n_plans: int = 1, time_limit: float = 5.0,
               on_unreachable: Literal["skip", "raise"] = "skip") -> TaskPlanResult:
    """The `n_plans` cheapest distinct task-level sequences, best first, within `time_limit` s.

    Plans come in non-decreasing cost when every one is proven optimal in its rank; when
    the time limit cuts the search, the plans found are still valid and sorted by cost, and
    `complete`/`TaskPlan.optimal` say what was proven. Same input, same output (one
    solver thread, fixed seed, facts in sorted order) whenever the search completes; a
    search cut by the clock returns whatever it had reached, which depends on the machine.
    Grounding and the solver's set-up cannot be interrupted (about 0.03 s at 12 locations,
    0.09 s at 20), so a limit below that overruns by the difference.
    """
    t0 = time.perf_counter()
    deadline = t0 + time_limit
    facts = problem_facts(problem)
    ctl = clingo.Control(["--opt-mode=opt", "--models=0", "--seed=0", "--parallel-mode=1",
                          "--heuristic=Domain",
                          "-c", f"h={horizon(problem)}", "--warn=none"])
    by_order = visits_only(problem)
    for name in (LOCATIONS, ORDER if by_order else DOMAIN):
        ctl.add("base", [], resources.files("s3o_drake.planning.task").joinpath(name).read_text())
    ctl.add("base", [], facts)
    ctl.ground([("base", [])])
    t_ground = time.perf_counter() - t0

    unreachable = sorted(
        sym_str(a.symbol.arguments[0])
        for a in ctl.symbolic_atoms.by_signature("unreachable", 1) if a.is_fact)
    bad_depot = [sym_str(a.symbol.arguments[0])
                 for a in ctl.symbolic_atoms.by_signature("depot_unreachable", 1) if a.is_fact]
    if bad_depot:
        raise TaskPlanningError(f"depot {bad_depot[0]!r} cannot be reached from "
                                f"{problem.start!r}")
    if unreachable and on_unreachable == "raise":
        where = ", ".join(f"{d!r} (location {problem.dishes[d]!r})" for d in unreachable)
        raise TaskPlanningError(f"no plan reaches dish(es) {where}: the location is empty "
                                f"or cannot be reached from {problem.start!r}")

    # Local search's best orders (visit_order.py): clingo takes the best as its first
    # model, then searches only for cheaper ones, without the hint (it would slow proofs).
    # The ordering problem as a matrix, once: for the hints and the bound of a cut search.
    matrix = visit_matrix(problem, unreachable) if by_order else None
    hints = visit_hints(*matrix, n_plans, deadline) if matrix is not None else []
    models = hinted_models(problem, facts, hints, deadline)
    hinted = models[0] if models else None
    bounded = None
    stall = None if hinted is None else STALL if len(hints[0]) < LARGE else LARGE_STALL
    if hinted is not None:
        ctl.add("bound", ["b"], BOUND)
        ctl.ground([("bound", [clingo.Number(hinted[1][0])])])
        bounded = clingo.Function("bounded", [clingo.Number(hinted[1][0])])
        ctl.assign_external(bounded, True)

    plans: list[TaskPlan] = []
    complete = True
    for k in range(n_plans):
        remaining = deadline - time.perf_counter()
        if remaining <= 0:
            complete = False
            break
        best: list[tuple[tuple[clingo.Symbol, ...], list[int], bool]] = []
        last = [time.perf_counter()]

        def on_model(model: clingo.Model, best=best, last=last) -> None:
            best.append((tuple(model.symbols(shown=True)), list(model.cost),
                         model.optimality_proven))
            last[0] = time.perf_counter()

        with ctl.solve(on_model=on_model, async_=True) as handle:
            finished = _wait(handle, deadline, last, stall)
            if not finished:
                handle.cancel()
            result = handle.get()
        if k == 0 and hinted is not None:
            ctl.assign_external(bounded, False)
            if not best:  # nothing cheaper than the hint; exhausted, none exists
                best.append((hinted[0], hinted[1], finished and result.unsatisfiable))
        if not best:
            if finished and result.unsatisfiable:
                if k == 0:
                    raise TaskPlanningError(_no_plan_message(problem, unreachable))
                break  # fewer than n_plans distinct sequences exist
            complete = False
            break
        symbols, cost, proven = best[-1]
        proven = proven or (finished and result.exhausted)
        actions = visit_actions(problem, symbols, unreachable) if by_order else \
            _actions(symbols)
        plans.append(TaskPlan(actions=actions, cost=int(cost[0]) if cost else 0,
                              optimal=bool(proven)))
        if not proven:
            complete = False
            break  # a cut search: the next "best" would not be meaningful
        if k + 1 < n_plans:
            _forbid(ctl, k, symbols, "at_step" if by_order else "occurs")
    if not complete and plans and len(plans) < n_plans:
        # The search was cut: the next sequences are local search's next-best orders.
        plans += _hinted_plans(problem, models, plans, n_plans, unreachable)

    if not plans:
        raise TaskPlanningTimeoutError(
            f"no task plan found within the time limit of {time_limit:g} s "
            f"({len(problem.locations)} locations, {len(problem.dishes)} dishes)")
    plans.sort(key=lambda p: p.cost)
    # Each plan is proven in its rank or ends the enumeration, so the first is the best.
    bound = plans[0].cost if plans[0].optimal else min(
        _lower_bound(problem, unreachable, None if matrix is None else matrix[1]),
        plans[0].cost)
    stats = {"ground_s": t_ground}
    if hinted is not None:
        stats["hint"] = float(hinted[1][0])  # local search's order, for the benchmark
    return TaskPlanResult(plans=tuple(plans), unreachable=tuple(unreachable),
                          complete=complete, elapsed=time.perf_counter() - t0,
                          stats=stats, lower_bound=bound, asked=n_plans, problem=problem)


def _lower_bound(problem: TaskProblem, unreachable: Sequence[str],
                 costs: np.ndarray | None) -> int:
    """`cost_lower_bound`, or for a visiting order (its `visit_matrix` costs) the
    assignment bound, which is tighter (exact_order.py): on random problems of 20-40
    locations, some 15 % below the optimum where the cheapest drive into each location is
    40-50 % below."""
    bound = cost_lower_bound(problem, unreachable)
    if costs is not None:
        bound = max(bound, math.ceil(assignment_bound(costs) - 1e-6))
    return bound


def _wait(handle: clingo.SolveHandle, deadline: float, last: list[float],
          stall: float | None) -> bool:
    """Waits for the solve to finish until `deadline`, or with `stall`, until that long
    passes without a new model (`last[0]`: when the last came); whether it finished."""
    while True:
        now = time.perf_counter()
        until = deadline if stall is None else min(deadline, last[0] + stall)
        if now >= until:
            return handle.wait(0)
        if handle.wait(min(0.05, until - now)):
            return True


def _hinted_plans(problem: TaskProblem, models: Sequence, plans: Sequence[TaskPlan],
                  n_plans: int, unreachable: Sequence[str]) -> list[TaskPlan]:
    """Up to `n_plans - len(plans)` more plans, unproven: clingo's models of the hinted
    orders (`hinted_models`) that no plan of `plans` has, in the hints' order."""
    taken = {p.gotos for p in plans}
    more: list[TaskPlan] = []
    for model in models:
        if len(plans) + len(more) >= n_plans:
            break
        if model is None:
            continue
        plan = TaskPlan(actions=visit_actions(problem, model[0], unreachable),
                        cost=int(model[1][0]), optimal=False)
        if plan.gotos not in taken:
            taken.add(plan.gotos)
            more.append(plan)
    return more


def _forbid(ctl: clingo.Control, k: int, symbols: Sequence[clingo.Symbol],
            atom: str) -> None:
    """Adds a constraint that rules out the visiting order just found (multi-shot): its
    `occurs(goto(L), T)` atoms (domain.lp) or its `at_step(L, K)` atoms (order.lp)."""
    if atom == "occurs":
        fixed = [s for s in symbols if s.name == "occurs" and s.arguments[0].name == "goto"]
        none = ":- #count { L, T : occurs(goto(L), T) } = 0."
    else:
        fixed = [s for s in symbols if s.name == "at_step"]
        none = ":- #count { L, K : at_step(L, K) } = 0."
    body = ", ".join(str(s) for s in fixed)
    part = f"forbid_{k}"
    ctl.add(part, [], f":- {body}." if body else none)
    ctl.ground([(part, [])])


def _no_plan_message(problem: TaskProblem, unreachable: Sequence[str]) -> str:
    reasons = []
    if unreachable:
        reasons.append(f"unreachable dish(es) {', '.join(map(repr, unreachable))}")
    n = sum(1 for loc in problem.dishes.values() if loc is not None)
    if problem.capacity is not None and problem.depot is None and n > problem.capacity:
        reasons.append(f"{n} dishes exceed the tray capacity {problem.capacity} "
                       f"and there is no depot to unload")
    why = "; ".join(reasons) if reasons else "the locations cannot be connected by finite costs"
    return f"no task plan exists: {why}"


def plan_problem(state_space_groups: Sequence[Sequence[str]], costs: CostSpec, *,
                 unreachable: Sequence[str] = (), start: str = START,
                 location_names: Sequence[str] | None = None,
                 places: Mapping[str, str] | None = None, **kwargs) -> TaskPlanResult:
    """Plans for a state space's groups (`StateSpace.groups`); location k is named
    `location_names[k]` or "l{k}". Dishes in `unreachable` (e.g. `Abstraction.unreachable`)
    get no location and are reported (or raise, per `on_unreachable`). `places` maps each
    object to place to its place target's name (`KnownWorld.places`): the target, a member
    of a group like the dishes, is no dish to pick but where its object is put down. An
    object to place that is itself in no group is the one in the gripper
    (`KnownWorld.held`): it is only put down."""
    names = list(location_names) if location_names is not None else [
        f"l{k}" for k in range(len(state_space_groups))]
    bad = set(unreachable)
    where = {d: (None if d in bad else names[k])
             for k, group in enumerate(state_space_groups) for d in group}
    for d in bad:
        where.setdefault(d, None)
    target_of = dict(places or {})
    targets = set(target_of.values())
    dishes = {d: loc for d, loc in where.items() if d not in targets}
    held = [o for o in target_of if o not in dishes]
    if len(held) > 1:
        raise ValueError(f"places: {held} are in no group, and the gripper holds one object")
    dishes.update({o: None for o in held})
    keys = {"capacity", "depot"}
    problem = TaskProblem(locations=tuple(names), dishes=dishes, costs=costs, start=start,
                          places={o: where.get(t) for o, t in target_of.items()},
                          held=held[0] if held else None,
                          **{k: kwargs.pop(k) for k in list(kwargs) if k in keys})
    return plan_tasks(problem, **kwargs)
