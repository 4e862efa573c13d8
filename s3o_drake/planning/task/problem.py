"""The task planner's problem and answers: a `TaskProblem` (locations, dishes, start,
costs), the `TaskPlan`s found for it and the `TaskPlanResult` that holds them, the ASP facts
clingo reads (`problem_facts`) and a bound on the cost of every plan (`cost_lower_bound`).
The planner itself is task_planner.py; the visit-order side of it, visit_order.py.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import clingo
import numpy as np

from s3o_drake.planning.plan import TaskOrder

START = "start"
"""The pseudo-location the robot starts from when it does not stand in a location."""


Action = tuple[str, str]
"""("goto", location), ("pickup", dish), ("place", object) or ("unload", depot)."""

CostSpec = (
    Callable[[str, str], float | None]
    | Mapping[tuple[str, str], float]
    | Sequence[Sequence[float]]
    | np.ndarray
)
"""Navigation costs: a callable cost(from, to), a mapping {(from, to): cost}, or a matrix
indexed by `TaskProblem.nodes` (the locations, then the start if it is not a location).
None, inf or NaN (or a missing mapping entry) means "cannot drive there"."""



@dataclass(frozen=True)
class TaskProblem:
    """A task-level problem: locations, where each dish is, the start and the costs.

    Costs are rounded to integers (clingo optimises integers); scale them before (e.g.
    seconds x 10) so that rounding does not matter.
    """

    locations: tuple[str, ...]
    dishes: Mapping[str, str | None]
    """Dish -> location id; None for a dish whose location is empty (not reachable)."""
    costs: CostSpec
    start: str = START
    capacity: int | None = None
    """Dishes the tray holds at once; None: unlimited."""
    depot: str | None = None
    """A node where `unload` empties the tray; with it the goal is "all dishes unloaded"."""
    places: Mapping[str, str | None] = field(default_factory=dict)
    """Object -> the location of its place target, for the objects put down (`place`)
    rather than collected: picked, such an object is held in the gripper, which holds one
    at a time, until `place` puts it down there; None: the target has no location."""
    held: str | None = None
    """The object to place that the gripper holds at the start (picked already: it stands
    at no location, `dishes` maps it to None)."""

    @property
    def nodes(self) -> tuple[str, ...]:
        """Row/column order of a cost matrix: the locations, then the start, then the depot
        (each only if not already a location)."""
        extra = [n for n in (self.start, self.depot) if n is not None and n not in self.locations]
        return tuple(self.locations) + tuple(dict.fromkeys(extra))

    def cost(self, a: str, b: str) -> float | None:
        """Navigation cost a -> b from whichever form `costs` has; None if impossible."""
        c = self.costs
        if callable(c):
            value = c(a, b)
        elif isinstance(c, Mapping):
            value = c.get((a, b))
        else:
            nodes = self.nodes
            value = c[nodes.index(a)][nodes.index(b)]
        if value is None:
            return None
        value = float(value)
        return value if math.isfinite(value) else None


@dataclass(frozen=True)
class TaskPlan:
    """One task-level sequence and its navigation cost."""

    actions: tuple[Action, ...]
    cost: int
    optimal: bool
    """True if clingo proved this plan optimal among the sequences not found before it
    (for the first plan: the optimum; for the k-th: the k-th best)."""

    @property
    def gotos(self) -> tuple[str, ...]:
        """The visiting order: what makes two plans different."""
        return tuple(arg for name, arg in self.actions if name == "goto")


@dataclass(frozen=True)
class TaskPlanResult:
    """The plans found, best first, and what could not be planned."""

    plans: tuple[TaskPlan, ...]
    unreachable: tuple[str, ...] = ()
    """Dishes left out because their location is empty or cannot be reached."""
    complete: bool = True
    """True if the enumeration ran to its end (N plans, or no more sequences exist) within
    the time limit and every plan is proven optimal in its rank."""
    elapsed: float = 0.0
    stats: dict[str, float] = field(default_factory=dict)
    lower_bound: int = 0
    """No order costs less (the best plan's cost when it is proven optimal, else
    `cost_lower_bound`'s bound), for the gap of an order the clock cut short."""
    asked: int = 1
    """The sequences asked for (`n_plans`): fewer in `plans` when the clock cut the
    enumeration or no more distinct ones exist."""
    problem: TaskProblem | None = None
    """The problem solved (for a reference to measure the orders against)."""

    @property
    def best(self) -> TaskPlan:
        return self.plans[0]

    def order_of(self, actions: Sequence[Action]) -> TaskOrder | None:
        """What clingo proved of the order `actions` (one of `plans`; None if not)."""
        plan = next((p for p in self.plans if p.actions == tuple(actions)), None)
        if plan is None:
            return None
        return TaskOrder(cost=plan.cost, optimal=plan.optimal, lower_bound=self.lower_bound,
                         found=len(self.plans), asked=self.asked)


def cost_lower_bound(problem: TaskProblem, unreachable: Sequence[str] = ()) -> int:
    """A bound below the navigation cost of every plan of `problem`: each location that a
    plan must drive into (it holds a dish to pick, or the place of an object to put down,
    or is the depot; not where the robot stands) is entered at least once, and the drive
    in costs at least the cheapest drive into it (rounded as clingo's costs are)."""
    lost = set(unreachable)
    need = {loc for d, loc in problem.dishes.items() if loc is not None and d not in lost}
    need |= {loc for o, loc in problem.places.items() if loc is not None and o not in lost}
    if problem.depot is not None and need:
        need.add(problem.depot)
    need.discard(problem.start)
    total = 0
    for loc in need:
        into = [round(c) for f in problem.nodes if f != loc
                and (c := problem.cost(f, loc)) is not None]
        total += min(into, default=0)
    return total


def quote(name: str) -> str:
    return '"' + str(name).replace("\\", "\\\\").replace('"', '\\"') + '"'


def problem_facts(problem: TaskProblem) -> str:
    """The problem as ASP facts, in a fixed order so the solver's answer is deterministic."""
    lines = [f"location({quote(loc)})." for loc in sorted(problem.locations)]
    lines.append(f"start({quote(problem.start)}).")
    for dish in sorted(problem.dishes):
        lines.append(f"dish({quote(dish)}).")
        loc = problem.dishes[dish]
        if loc is not None:
            if loc not in problem.locations:
                raise ValueError(f"dish {dish!r}: unknown location {loc!r}")
            lines.append(f"at({quote(dish)}, {quote(loc)}).")
    if problem.held is not None:
        if problem.held not in problem.places or problem.dishes.get(problem.held, "") is not None:
            raise ValueError(f"held: {problem.held!r} is no object to place at no location")
        lines.append(f"held({quote(problem.held)}).")
    for dish in sorted(problem.places):
        loc = problem.places[dish]
        if dish not in problem.dishes:
            raise ValueError(f"place of {dish!r}: unknown dish")
        if loc is None:
            lines.append(f"unplaceable({quote(dish)}).")
        elif loc not in problem.locations:
            raise ValueError(f"place of {dish!r}: unknown location {loc!r}")
        else:
            lines.append(f"place_at({quote(dish)}, {quote(loc)}).")
    if problem.capacity is not None:
        if problem.capacity < 1:
            raise ValueError(f"capacity must be >= 1, got {problem.capacity}")
        lines.append(f"capacity({int(problem.capacity)}).")
    if problem.depot is not None:
        lines.append(f"depot({quote(problem.depot)}).")
    nodes = sorted(set(problem.nodes))
    for a in nodes:
        for b in nodes:
            if a == b or (b == problem.start and b not in problem.locations and b != problem.depot):
                continue
            c = problem.cost(a, b)
            if c is not None:
                if c < 0:
                    raise ValueError(f"negative navigation cost {a!r} -> {b!r}: {c}")
                lines.append(f"dist({quote(a)}, {quote(b)}, {round(c)}).")
    return "\n".join(lines) + "\n"



def sym_str(s: clingo.Symbol) -> str:
    return s.string if s.type == clingo.SymbolType.String else str(s)

