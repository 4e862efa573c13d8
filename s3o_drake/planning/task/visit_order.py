"""The visit-order side of the task planner, for problems that only collect onto an
unlimited tray (`visits_only`): order.lp chooses only the order of the locations to visit,
`visit_hints` are local search's best orders (first_order.py), `hinted_models` are
clingo's models of them, and `visit_actions` writes the canonical plan of an order.
`visit_matrix` is the ordering problem as a cost matrix, as clingo reads it: the start,
then the locations to visit.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from importlib import resources

import clingo
import numpy as np

from s3o_drake.planning.task.first_order import good_orders
from s3o_drake.planning.task.problem import Action, TaskProblem, sym_str

ORDER = "order.lp"  # the visit-order encoding, for problems that only collect
LOCATIONS = "locations.lp"  # what both encodings share: nodes, reachability, dishes
HINT_LIMIT = 1.0
"""Seconds local search may take at most (`visit_hints`): idle it takes 0.1 s at 15-20
locations, but it shares the cores with the motion searches."""


def visits_only(problem: TaskProblem) -> bool:
    """Whether `problem` only collects onto an unlimited tray (no capacity, depot, places or
    held object): then a plan is fixed by its visiting order, and clingo solves the
    visit-order encoding (order.lp)."""
    return (problem.capacity is None and problem.depot is None and not problem.places
            and problem.held is None)


def visit_matrix(problem: TaskProblem, unreachable: Sequence[str] = ()
                 ) -> tuple[list[str], np.ndarray]:
    """The ordering problem that order.lp solves, as (nodes, costs): the start, then the
    locations that hold a dish to collect (not those of `unreachable` dishes), in name
    order; costs[i, j] is the drive i -> j rounded as clingo's facts are (inf: none, and
    into the start, which no open path enters)."""
    lost = set(unreachable)
    visits = sorted({loc for d, loc in problem.dishes.items()
                     if loc is not None and d not in lost and loc != problem.start})
    nodes = [problem.start, *visits]
    costs = np.array([[0.0 if a == b else np.inf if b == problem.start
                       else round(c) if (c := problem.cost(a, b)) is not None
                       else np.inf for b in nodes] for a in nodes])
    return nodes, costs


def visit_hints(nodes: Sequence[str], costs: np.ndarray, count: int,
                deadline: float) -> list[list[str]]:
    """Up to `count` distinct good visiting orders (location names) of the ordering
    problem `visit_matrix` gives (`nodes`, `costs`), the cheapest first, from
    `good_orders`' local search; none below 3 locations to visit (clingo proves those at
    once). The search gets half the time left, at most HINT_LIMIT."""
    if len(nodes) < 4:
        return []
    limit = min(HINT_LIMIT, 0.5 * max(deadline - time.perf_counter(), 0.0))
    return [[nodes[i] for i in order] for order in good_orders(costs, count, limit)]


Model = tuple[tuple[clingo.Symbol, ...], list[int], bool]
"""A clingo model as the task planner keeps it: (shown symbols, cost, proven optimal)."""


def hinted_models(problem: TaskProblem, facts: str, orders: Sequence[Sequence[str]],
                  deadline: float) -> list[Model | None]:
    """clingo's model of each visiting order of `orders`, as (symbols, cost, False): order.lp
    solved under the assumption that the order's `at_step` atoms hold (a domain heuristic
    that preferred them was not always followed: on a 14-location problem its first model
    swapped two locations, 47 % dearer); None for an order that is no plan, or past the
    deadline. A Control of its own, grounded once, so that the main search keeps no trace
    of the hints."""
    if not orders:
        return []
    ctl = clingo.Control(["--opt-mode=opt", "--seed=0", "--parallel-mode=1", "--warn=none"])
    for name in (LOCATIONS, ORDER):
        ctl.add("base", [], resources.files("s3o_drake.planning.task").joinpath(name).read_text())
    ctl.add("base", [], facts)
    ctl.ground([("base", [])])
    models: list[Model | None] = []
    for order in orders:
        assumptions = [(clingo.Function("at_step", [clingo.String(loc), clingo.Number(k)]),
                        True) for k, loc in enumerate(order, 1)]
        with ctl.solve(assumptions=assumptions, yield_=True, async_=True) as handle:
            handle.resume()
            first = handle.model() if handle.wait(
                max(0.0, deadline - time.perf_counter())) else None
            models.append(None if first is None else (tuple(first.symbols(shown=True)),
                                                      list(first.cost), False))
            handle.cancel()
    return models


def visit_actions(problem: TaskProblem, symbols: Sequence[clingo.Symbol],
                  unreachable: Sequence[str]) -> tuple[Action, ...]:
    """The canonical plan of a visiting order (order.lp's `at_step/2`): first the dishes
    where the robot stands, then per location a goto and its dishes, in name order."""
    order = sorted((s.arguments[1].number, sym_str(s.arguments[0]))
                   for s in symbols if s.name == "at_step")
    lost = set(unreachable)
    dishes: dict[str, list[str]] = {}
    for dish in sorted(problem.dishes):
        loc = problem.dishes[dish]
        if loc is not None and dish not in lost:
            dishes.setdefault(loc, []).append(dish)
    actions: list[Action] = [("pickup", d) for d in dishes.get(problem.start, [])]
    for _, loc in order:
        actions.append(("goto", loc))
        actions.extend(("pickup", d) for d in dishes[loc])
    return tuple(actions)

