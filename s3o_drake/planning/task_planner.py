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
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from importlib import resources
from typing import Literal

import clingo
import numpy as np

from s3o_drake.planning.first_order import first_order
from s3o_drake.planning.plan import TaskOrder

START = "start"
"""The pseudo-location the robot starts from when it does not stand in a location."""

DOMAIN = "domain.lp"
ORDER = "order.lp"  # the visit-order encoding, for problems that only collect
LOCATIONS = "locations.lp"  # what both encodings share: nodes, reachability, dishes

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


class TaskPlanningError(RuntimeError):
    """No task plan: unreachable dishes (with `on_unreachable="raise"`), no plan at all,
    or no plan found within the time limit."""


class TaskPlanningTimeoutError(TaskPlanningError):
    """No task plan found within the time limit (one may exist)."""


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


def _quote(name: str) -> str:
    return '"' + str(name).replace("\\", "\\\\").replace('"', '\\"') + '"'


def problem_facts(problem: TaskProblem) -> str:
    """The problem as ASP facts, in a fixed order so the solver's answer is deterministic."""
    lines = [f"location({_quote(loc)})." for loc in sorted(problem.locations)]
    lines.append(f"start({_quote(problem.start)}).")
    for dish in sorted(problem.dishes):
        lines.append(f"dish({_quote(dish)}).")
        loc = problem.dishes[dish]
        if loc is not None:
            if loc not in problem.locations:
                raise ValueError(f"dish {dish!r}: unknown location {loc!r}")
            lines.append(f"at({_quote(dish)}, {_quote(loc)}).")
    if problem.held is not None:
        if problem.held not in problem.places or problem.dishes.get(problem.held, "") is not None:
            raise ValueError(f"held: {problem.held!r} is no object to place at no location")
        lines.append(f"held({_quote(problem.held)}).")
    for dish in sorted(problem.places):
        loc = problem.places[dish]
        if dish not in problem.dishes:
            raise ValueError(f"place of {dish!r}: unknown dish")
        if loc is None:
            lines.append(f"unplaceable({_quote(dish)}).")
        elif loc not in problem.locations:
            raise ValueError(f"place of {dish!r}: unknown location {loc!r}")
        else:
            lines.append(f"place_at({_quote(dish)}, {_quote(loc)}).")
    if problem.capacity is not None:
        if problem.capacity < 1:
            raise ValueError(f"capacity must be >= 1, got {problem.capacity}")
        lines.append(f"capacity({int(problem.capacity)}).")
    if problem.depot is not None:
        lines.append(f"depot({_quote(problem.depot)}).")
    nodes = sorted(set(problem.nodes))
    for a in nodes:
        for b in nodes:
            if a == b or (b == problem.start and b not in problem.locations and b != problem.depot):
                continue
            c = problem.cost(a, b)
            if c is not None:
                if c < 0:
                    raise ValueError(f"negative navigation cost {a!r} -> {b!r}: {c}")
                lines.append(f"dist({_quote(a)}, {_quote(b)}, {round(c)}).")
    return "\n".join(lines) + "\n"


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


def _sym_str(s: clingo.Symbol) -> str:
    return s.string if s.type == clingo.SymbolType.String else str(s)


def _actions(symbols: Sequence[clingo.Symbol]) -> tuple[Action, ...]:
    steps = []
    for s in symbols:
        if s.name != "occurs":
            continue
        act, t = s.arguments
        arg = _sym_str(act.arguments[0]) if act.arguments else ""
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
        ctl.add("base", [], resources.files("s3o_drake.planning").joinpath(name).read_text())
    ctl.add("base", [], facts)
    ctl.ground([("base", [])])
    t_ground = time.perf_counter() - t0

    unreachable = sorted(
        _sym_str(a.symbol.arguments[0])
        for a in ctl.symbolic_atoms.by_signature("unreachable", 1) if a.is_fact)
    bad_depot = [_sym_str(a.symbol.arguments[0])
                 for a in ctl.symbolic_atoms.by_signature("depot_unreachable", 1) if a.is_fact]
    if bad_depot:
        raise TaskPlanningError(f"depot {bad_depot[0]!r} cannot be reached from "
                                f"{problem.start!r}")
    if unreachable and on_unreachable == "raise":
        where = ", ".join(f"{d!r} (location {problem.dishes[d]!r})" for d in unreachable)
        raise TaskPlanningError(f"no plan reaches dish(es) {where}: the location is empty "
                                f"or cannot be reached from {problem.start!r}")

    # The first order found with `first_order`'s hint: kept if clingo, searching on
    # without it (the hint would slow its proofs), finds nothing better in time.
    hinted = _hinted_model(problem, facts, unreachable, deadline) if by_order else None

    plans: list[TaskPlan] = []
    complete = True
    for k in range(n_plans):
        remaining = deadline - time.perf_counter()
        if remaining <= 0:
            complete = False
            break
        best: list[tuple[tuple[clingo.Symbol, ...], list[int], bool]] = []

        def on_model(model: clingo.Model, best=best) -> None:
            best.append((tuple(model.symbols(shown=True)), list(model.cost),
                         model.optimality_proven))

        with ctl.solve(on_model=on_model, async_=True) as handle:
            # solve() itself prepares the solver synchronously; wait only for what is left.
            finished = handle.wait(max(0.0, deadline - time.perf_counter()))
            if not finished:
                handle.cancel()
            result = handle.get()
        if k == 0 and hinted is not None and not (best and (best[-1][2] or (
                finished and result.exhausted) or best[-1][1] <= hinted[1])):
            best.append(hinted)
        if not best:
            if finished and result.unsatisfiable:
                if k == 0:
                    raise TaskPlanningError(_no_plan_message(problem, unreachable))
                break  # fewer than n_plans distinct sequences exist
            complete = False
            break
        symbols, cost, proven = best[-1]
        proven = proven or (finished and result.exhausted)
        actions = _visit_actions(problem, symbols, unreachable) if by_order else \
            _actions(symbols)
        plans.append(TaskPlan(actions=actions, cost=int(cost[0]) if cost else 0,
                              optimal=bool(proven)))
        if not proven:
            complete = False
        if k + 1 < n_plans:
            _forbid(ctl, k, symbols, "at_step" if by_order else "occurs")
        if not proven:
            break  # a cut search: the next "best" would not be meaningful

    if not plans:
        raise TaskPlanningTimeoutError(
            f"no task plan found within the time limit of {time_limit:g} s "
            f"({len(problem.locations)} locations, {len(problem.dishes)} dishes)")
    plans.sort(key=lambda p: p.cost)
    # Each plan is proven in its rank or ends the enumeration, so the first is the best.
    bound = plans[0].cost if plans[0].optimal else min(cost_lower_bound(problem, unreachable),
                                                       plans[0].cost)
    return TaskPlanResult(plans=tuple(plans), unreachable=tuple(unreachable),
                          complete=complete, elapsed=time.perf_counter() - t0,
                          stats={"ground_s": t_ground}, lower_bound=bound, asked=n_plans)


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


def visits_only(problem: TaskProblem) -> bool:
    """Whether `problem` only collects onto an unlimited tray (no capacity, depot, places or
    held object): then a plan is fixed by its visiting order, and clingo solves the
    visit-order encoding (order.lp)."""
    return (problem.capacity is None and problem.depot is None and not problem.places
            and problem.held is None)


def _hinted_model(problem: TaskProblem, facts: str, unreachable: Sequence[str],
                  deadline: float) -> tuple[tuple[clingo.Symbol, ...], list[int], bool] | None:
    """The first model, as (symbols, cost, False), of a clingo run told to try
    `first_order`'s order first (a domain heuristic above order.lp's own); None below 3
    locations to visit or without a model in time. A Control of its own: in the main one
    the hint slowed the proofs five-fold at 10 locations (and, conditional on an external
    atom, was not followed)."""
    lost = set(unreachable)
    visits = sorted({loc for d, loc in problem.dishes.items()
                     if loc is not None and d not in lost and loc != problem.start})
    if len(visits) < 3:
        return None
    nodes = [problem.start, *visits]
    costs = np.array([[0.0 if a == b else round(c) if (c := problem.cost(a, b)) is not None
                       else np.inf for b in nodes] for a in nodes])
    finite = costs[np.isfinite(costs)]
    level = int(finite.max()) + 2 if finite.size else 2
    order = first_order(costs, min(0.2, 0.1 * max(deadline - time.perf_counter(), 0.0)))
    ctl = clingo.Control(["--opt-mode=opt", "--seed=0", "--parallel-mode=1",
                          "--heuristic=Domain", "--warn=none"])
    for name in (LOCATIONS, ORDER):
        ctl.add("base", [], resources.files("s3o_drake.planning").joinpath(name).read_text())
    ctl.add("base", [], facts + "\n" + "\n".join(
        f"#heuristic at_step({_quote(nodes[i])}, {k}). [{level}, true]"
        for k, i in enumerate(order, 1)))
    ctl.ground([("base", [])])
    with ctl.solve(yield_=True, async_=True) as handle:
        handle.resume()
        first = handle.model() if handle.wait(max(0.0, deadline - time.perf_counter())) \
            else None
        model = None if first is None else (tuple(first.symbols(shown=True)),
                                            list(first.cost), False)
        handle.cancel()
    return model


def _visit_actions(problem: TaskProblem, symbols: Sequence[clingo.Symbol],
                   unreachable: Sequence[str]) -> tuple[Action, ...]:
    """The canonical plan of a visiting order (order.lp's `at_step/2`): first the dishes
    where the robot stands, then per location a goto and its dishes, in name order."""
    order = sorted((s.arguments[1].number, _sym_str(s.arguments[0]))
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
