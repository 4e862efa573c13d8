"""Motion-level search: base positions for a task-level sequence.

Given one task-level sequence (`TaskPlan.actions`: ("goto", location) / ("pickup", dish)),
the motion search picks one base position (x, y) per `goto` inside that location's region
and scores the whole sequence by its utility Σ R(a):

    R(goto)   = -Cst(goto)                  Cst = time + γ
    R(pickup) = -δ + λ · s_k · Fea^m(y_r, y_o)    y_r: the position of the latest goto

with the costs of the cost profile (`time_model.CostModel`): "robot", the base navigator's
motion along the map's path and the turns at the stop, γ and δ our robot's recorded times;
or "paper", Cst(goto) = len(y, y') / v + γ with len the collision-free path length
(NavigationMap) and δ, γ, v from the planner settings.

s_k is the share of Fea^m that executed pickups at a stop serving k dishes achieved
(`abstraction/shared_stop.py`; 1 for a one-dish stop, and with `planner.shared_stop:
paper`). `Fea^m` is taken as it comes (`MotionFeasibility.values`): the heatmaps already include
the navigation and reaching noise (T^n, T^m) by Monte-Carlo, so Fea^m is the expected
pickup success and no further sampling of T^n is done here. A pickup before any goto is
made from the start position.

Two searches with the same budget (default `cma_generations x cma_population` = 200
samples) and the same result type:

- `grop_star` (GROP*): one CMA-ES (`cma`) over the stacked positions (2 x gotos
  dimensions). Generation 0 is a greedy starting guess (`initial_point`)
  plus population - 1 draws from the Fea^m heatmaps; CMA-ES's mean starts at the best of
  them, so GROP* never ends below its own starting guess and starts in a good basin.
- `grop` (GROP, the baseline): every sample draws each goto's position independently from
  the location's Fea^m heatmap (grid cell centres, probability ∝ Fea^m), best kept.

Both read a location through the plan's location grid (`abstraction/location_grid.py`:
`grid` and `groups`, the dishes whose cells make each location), the grid that Fea^t and
the planner's representative points read: its points, and per point the summed Fea^m of
the dishes picked there under the one joint-feasibility rule, with its named fallbacks
(no joint point: all points weigh; no grid point in a sliver: its representative point).
Called without a grid, each region gets its own on the same lattice
(`location_grid.region_location`).

Regions and penalty. CMA-ES's proposals are resampled until every position lies in its
region (cma's own constraint handling, as in `ask_and_eval`; rejected proposals cost no
evaluation), up to MAX_RESAMPLING rounds per generation. Penalising outside samples alone
(the paper code's way) was measured to stall: with 5 gotos and sigma ~0.4 m almost no
joint sample lands in all five thin Voronoi cells, so every CMA-ES generation after the
first was all-penalty and the search never improved on its start. A sample still outside
after resampling, or whose legs cannot be driven (infinite path length), gets utility
`-PENALTY - Σ distance to the regions - UNREACHABLE_STEP x unreachable legs`; the distance
term slopes CMA-ES back into the regions. Only samples inside all their regions reach
`nav`, in one path query batch per generation.

Predicted execution time: the time model's prediction of the simulated execution
(`time_model`), under either profile. Only a search given no dishes or start pose (costs
None: the paper's costs from the planner settings alone) falls back to the paper's
estimate, Σ len / v plus `pickup_duration` (default δ) per pickup.

Deterministic for a seed: CMA-ES gets its own seed (derived from `seed`), GROP draws from
`numpy.random.default_rng(seed)`, and `nav` is deterministic.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property

import cma
import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry
from shapely.ops import unary_union
from threadpoolctl import ThreadpoolController

from s3o_drake.abstraction.location_grid import GridLocation, LocationGrid, region_location
from s3o_drake.abstraction.motion_feasibility import MotionFeasibility
from s3o_drake.abstraction.shared_stop import stop_shares
from s3o_drake.planning.navigation.map import NavigationMap
from s3o_drake.planning.task.planner import Action
from s3o_drake.planning.time_model import CostModel
from s3o_drake.world.deadline import Deadline
from s3o_drake.world.goals import place_target_name
from s3o_drake.world.settings import PlanningSettings

PENALTY = 1e4
"""Utility offset of an invalid sample (outside a region or not drivable); any valid
sample scores far above it (a real plan's utility is of order ±10^3)."""
UNREACHABLE_STEP = 100.0
"""Extra penalty per leg with an infinite path length, so fewer such legs rank higher."""
SIGMA_FRACTION = 0.03
"""CMA-ES's initial step size as a fraction of the mean region extent. Small on purpose:
generation 0 already starts in a good basin; measured on the restaurant (5 gotos, ring
heatmaps, 6 seeds) the median utility was 393 at 0.25, 412 at 0.05, 437 at 0.03."""
MAX_RESAMPLING = 100
"""At most this many times `popsize` CMA-ES draws per generation to find samples inside
the regions."""
MIN_SIGMA = 0.05
"""Floor on the initial step size (m), for tiny regions."""
_BLAS = ThreadpoolController()
"""numpy's BLAS, held to one thread during a search: CMA-ES decomposes its 20-40
dimensional covariance matrix every generation, and OpenBLAS's threads, on 2 cores shared
with the other search and the task planner, turned each `eigh` from 0.13 ms into 4.9 ms
(a 30-dish plan's searches 5.2 -> 2.9 s, measured on a loaded machine)."""


@dataclass
class MotionResult:
    """The best sample of one motion search over one task-level sequence."""

    method: str
    """"GROP*" or "GROP"."""
    actions: tuple[Action, ...]
    locations: tuple[str, ...]
    """The location of each goto, in order."""
    positions: np.ndarray
    """Base position (x, y) per goto (n_gotos, 2), m."""
    utility: float
    """Σ R(a) of `positions` (≤ -PENALTY + ... when no valid sample was found)."""
    valid: bool
    """True if every position lies in its region and every leg can be driven."""
    predicted_time: float
    """The predicted execution time (s; `SequenceProblem.result`); inf when not valid."""
    leg_lengths: np.ndarray
    """Path length of each goto's leg (n_gotos,), m (inf where not drivable)."""
    feasibility: dict[str, float]
    """Fea^m of each picked dish from the position it is picked at."""
    samples: int
    """Samples evaluated."""
    elapsed: float
    """Wall time of the search (s)."""
    history: list[np.ndarray] = field(default_factory=list, repr=False)
    """The samples of each generation (GROP: each batch of popsize), (pop, n_gotos, 2)."""
    history_utility: list[np.ndarray] = field(default_factory=list, repr=False)
    """Their utilities, (pop,) per generation."""

    @property
    def early(self) -> np.ndarray:
        """Samples of the first generation (the paper's Fig. 4, left)."""
        return self.history[0] if self.history else np.zeros((0, len(self.locations), 2))

    @property
    def late(self) -> np.ndarray:
        """Samples of the last generation (the paper's Fig. 4, right)."""
        return self.history[-1] if self.history else np.zeros((0, len(self.locations), 2))


def initial_point(location: GridLocation, previous: np.ndarray, reward: float,
                  speed: float) -> np.ndarray:
    """The grid point of `location` that maximises λ·ΣFea^m - |previous p| / v: the utility
    of this goto with the straight line standing in for the path length (a cheap lower
    bound), so that of two equally feasible spots the nearer one is the start. Ties go to
    the point nearest the Fea^m-weighted centroid; an all-zero weight gives the region's
    representative point."""
    w, points = location.weight, location.points
    if w.sum() <= 0:
        return location.representative_point()
    centroid = (w[:, None] * points).sum(axis=0) / w.sum()
    score = reward * w - np.linalg.norm(points - previous, axis=1) / speed
    best = np.flatnonzero(score >= score.max() - 1e-9)
    k = best[np.argmin(np.linalg.norm(points[best] - centroid, axis=1))]
    return points[k].copy()


def draw(location: GridLocation, rng: np.random.Generator, n: int) -> np.ndarray:
    """n grid points of `location` drawn ∝ its weight (uniformly if it is 0 everywhere)."""
    w = location.weight
    p = w / w.sum() if w.sum() > 0 else np.full(len(w), 1.0 / len(w))
    return location.points[rng.choice(len(location.points), size=n, p=p)]


class SequenceProblem:
    """One sequence prepared for evaluation: gotos, pickups, regions, costs (`costs`: the
    cost profile and the time prediction; None: the paper's costs from `planner`, with the
    shared stops' shares of the robot `nav` is for), and
    the grid locations of its gotos (`grid` and `groups`: see the module docstring)."""

    def __init__(self, sequence: Sequence[Action], regions: Mapping[str, BaseGeometry],
                 feasibility: MotionFeasibility, nav: NavigationMap,
                 start_xy: Sequence[float], planner: PlanningSettings,
                 pickup_duration: float | None,
                 costs: CostModel | None = None, *, grid: LocationGrid | None = None,
                 groups: Mapping[str, Sequence[str]] | None = None):
        if grid is not None and groups is None:
            raise ValueError("a location grid needs the groups of dishes of the locations")
        self.actions = tuple((str(a), str(b)) for a, b in sequence)
        self.start = np.asarray(start_xy, dtype=float)[:2]
        self.nav = nav
        self.feasibility = feasibility
        self.planner = planner
        self.costs = CostModel.paper(planner, nav.robot) if costs is None else costs
        self.pickup_duration = planner.delta if pickup_duration is None else pickup_duration
        locations: list[str] = []
        picks: list[tuple[int, str]] = []  # (goto index, or -1 for the start; dish)
        for name, arg in self.actions:
            if name == "goto":
                if arg not in regions:
                    raise ValueError(f"goto {arg!r}: no region for this location")
                locations.append(arg)
            elif name == "pickup":
                picks.append((len(locations) - 1, arg))
            elif name == "place":  # rated as a pick of the object standing at its place
                picks.append((len(locations) - 1, place_target_name(arg)))
            else:
                raise ValueError(f"action {name!r} is not supported by the motion search")
        self.locations = tuple(locations)
        self.picks = picks
        self.stop_dishes = [[d for g, d in picks if g == k] for k in range(len(locations))]
        self.start_dishes = [d for g, d in picks if g < 0]
        shares = stop_shares(planner, robot=self.costs.robot)
        # s_k (`shared_stop.py`) of each goto's stop, and of the stop each pick is made from.
        self.stop_shares = [shares.of(len(dishes)) for dishes in self.stop_dishes]
        self.shares = np.array([shares.of(len(self.start_dishes)) if g < 0
                                else self.stop_shares[g] for g, _ in picks], dtype=float)
        self.regions = [regions[loc] for loc in locations]
        for region in self.regions:
            shapely.prepare(region)
        self._grid = grid
        self._groups = groups

    @cached_property
    def grids(self) -> list[GridLocation]:
        """Each goto's grid location with the dishes picked there. Built on first use, so
        that a sequence that is only scored (PETLON's) reads no grid."""
        if self._grid is not None:
            assert self._groups is not None
            return [self._grid.location(self._groups[loc], dishes)
                    for loc, dishes in zip(self.locations, self.stop_dishes, strict=True)]
        return [region_location(region, self.feasibility, dishes)
                for region, dishes in zip(self.regions, self.stop_dishes, strict=True)]

    @cached_property
    def extent(self) -> float:
        """The mean over the gotos' regions of their bounding box's larger side (m)."""
        sides = [max(x1 - x0, y1 - y0) for x0, y0, x1, y1 in (r.bounds for r in self.regions)]
        return float(np.mean(sides))

    @property
    def n(self) -> int:
        return len(self.locations)

    def inside(self, X: np.ndarray) -> np.ndarray:
        """Whether every position of each sample X (m, n, 2) lies in its region (m,)."""
        ok = np.ones(len(X), dtype=bool)
        for k, region in enumerate(self.regions):
            ok &= shapely.intersects_xy(region, X[:, k, 0], X[:, k, 1])
        return ok

    def evaluate(self, X: np.ndarray, *, timed: bool = False
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Utilities (m,), leg lengths (m, n), pickup Fea^m (m, pickups) and, with `timed`
        (or the robot profile, where the costs are the times), predicted execution times
        (m,) (NaN otherwise and where invalid) of samples X (m, n, 2), with one path query
        batch for all valid samples."""
        X = np.asarray(X, dtype=float)
        # With no goto to place (n = 0) the sample count cannot be inferred from the size.
        X = X.reshape(len(X) if self.n == 0 else -1, self.n, 2)
        m = len(X)
        p, costs = self.planner, self.costs
        robot = costs.profile == "robot"
        timed = costs.timed and (timed or robot)
        outside = np.zeros((m, self.n))
        for k, region in enumerate(self.regions):
            hit = shapely.intersects_xy(region, X[:, k, 0], X[:, k, 1])
            if (~hit).any():
                outside[~hit, k] = shapely.distance(shapely.points(X[~hit, k]), region)
                outside[~hit, k] = np.maximum(outside[~hit, k], 1e-9)
        ok = (outside == 0).all(axis=1)
        lengths = np.full((m, self.n), np.inf)
        goto_time = np.full((m, self.n), np.inf)
        start_turns = np.zeros(m)
        if ok.any() and timed:
            lengths[ok], goto_time[ok], start_turns[ok] = costs.goto_times(
                self.nav, X[ok], self.stop_dishes, self.start_dishes)
        elif ok.any() and self.n:
            Y = X[ok]
            prev = np.concatenate([np.broadcast_to(self.start, (len(Y), 1, 2)), Y[:, :-1]], axis=1)
            lengths[ok] = self.nav.path_lengths(prev.reshape(-1, 2), Y.reshape(-1, 2)) \
                .reshape(len(Y), self.n)
        drivable = np.isfinite(lengths).all(axis=1)
        if robot:
            goto_cost = np.where(np.isfinite(lengths), goto_time, 0.0)
        else:
            goto_cost = np.where(np.isfinite(lengths), lengths, 0.0) / p.speed + costs.gamma
        dishes = [dish for _, dish in self.picks]
        where = np.stack([np.broadcast_to(self.start, (m, 2)) if g < 0 else X[:, g]
                          for g, _ in self.picks], axis=1) if dishes else np.zeros((m, 0, 2))
        F = np.zeros((m, len(dishes)))
        for j, dish in enumerate(dishes):
            F[:, j] = self.feasibility.values(dish, where[:, j])
        stops = [g for g, _ in self.picks]
        gotos = goto_time if timed else None
        delta = costs.pickup_costs(dishes, where, stops, gotos)
        pickup_time = np.zeros((m, len(dishes)))
        if timed:
            pickup_time = delta if robot else costs.pickup_times(dishes, where, stops, gotos)
        start_cost = start_turns if robot else 0.0
        utility = (-goto_cost.sum(axis=1) - start_cost
                   + (-delta + p.reward * self.shares * F).sum(axis=1))
        bad = ~(ok & drivable)
        unreachable = (~np.isfinite(lengths) & ok[:, None]).sum(axis=1)
        utility[bad] = -PENALTY - outside[bad].sum(axis=1) - UNREACHABLE_STEP * unreachable[bad]
        times = np.full(m, np.nan)
        if timed:
            times[~bad] = costs.predicted_time(goto_time[~bad], start_turns[~bad],
                                               pickup_time[~bad])
        return utility, lengths, F, times

    def result(self, method: str, x: np.ndarray, samples: int, elapsed: float,
               history: list[np.ndarray], history_utility: list[np.ndarray]) -> MotionResult:
        """The MotionResult of the sample x (n, 2), re-evaluated so that every number in it
        comes from the same evaluation."""
        x = np.asarray(x, dtype=float).reshape(self.n, 2)
        u, lengths, F, times = self.evaluate(x[None], timed=True)
        legs = lengths[0]
        valid = bool(u[0] > -PENALTY + 1e-9) if self.n else True
        if not valid:
            time_s = math.inf
        elif self.costs.timed:
            time_s = float(times[0])
        else:  # no dishes or start known: the paper's own estimate
            time_s = float(legs.sum() / self.planner.speed
                           + self.pickup_duration * len(self.picks))
        feas = {dish: float(F[0, j]) for j, (_, dish) in enumerate(self.picks)}
        return MotionResult(method=method, actions=self.actions, locations=self.locations,
                            positions=x, utility=float(u[0]), valid=valid,
                            predicted_time=time_s, leg_lengths=legs, feasibility=feas,
                            samples=samples, elapsed=elapsed, history=history,
                            history_utility=history_utility)


class _Tally:
    """What a search has seen: every generation (for Fig. 4) and the best sample so far."""

    def __init__(self) -> None:
        self.history: list[np.ndarray] = []
        self.history_u: list[np.ndarray] = []
        self.samples = 0
        self.best_u = -math.inf
        self.best_x: np.ndarray | None = None

    def add(self, X: np.ndarray, u: np.ndarray) -> None:
        self.history.append(X)
        self.history_u.append(u)
        self.samples += len(X)
        k = int(np.argmax(u))
        if u[k] > self.best_u:
            self.best_u, self.best_x = float(u[k]), X[k].copy()

    def result(self, problem: SequenceProblem, method: str, t0: float) -> MotionResult:
        return problem.result(method, self.best_x, self.samples, time.monotonic() - t0,
                              self.history, self.history_u)


def _ask_inside(es: cma.CMAEvolutionStrategy, problem: SequenceProblem, population: int) -> list:
    """`population` solutions from `es` whose positions all lie in their regions, drawn
    until found or MAX_RESAMPLING x `population` draws are spent: cma's own constraint
    handling (`ask_and_eval` resamples infeasible solutions), here vectorised and without
    evaluating anything. Each batch asks for as many as the share inside so far says the
    rest needs: where few draws land inside (small or thin regions) this takes a few asks
    where one of `population` at a time took up to a hundred. Solutions still outside at
    the end fill the rest and get the penalty."""
    inside: list = []
    outside: list = []
    left = MAX_RESAMPLING * population
    batch = population
    while left > 0:
        asked = es.ask(min(batch, left))
        left -= len(asked)
        ok = problem.inside(np.array(asked).reshape(len(asked), problem.n, 2))
        inside += [x for x, good in zip(asked, ok, strict=True) if good]
        if len(inside) >= population:
            return inside[:population]
        outside += [x for x, good in zip(asked, ok, strict=True) if not good]
        drawn = len(inside) + len(outside)
        need = population - len(inside)
        # No draw inside yet: four times as many as asked so far.
        batch = math.ceil(1.25 * need * drawn / len(inside)) if inside else 4 * drawn
    return inside + outside[:population - len(inside)]


def _seed_of(seed: int | None, rng: np.random.Generator | None) -> int:
    """A seed in [1, 2^31): cma treats 0 (and None) as "seed from the clock"."""
    if rng is not None:
        return int(rng.integers(1, 2**31 - 1))
    return int(seed if seed is not None else 0) % (2**31 - 2) + 1


def grop_star(sequence: Sequence[Action], regions: Mapping[str, BaseGeometry],
              feasibility: MotionFeasibility, nav: NavigationMap, start_xy: Sequence[float],
              planner: PlanningSettings, *, seed: int | None = None,
              rng: np.random.Generator | None = None, generations: int | None = None,
              population: int | None = None, pickup_duration: float | None = None,
              deadline: Deadline | None = None, costs: CostModel | None = None,
              grid: LocationGrid | None = None,
              groups: Mapping[str, Sequence[str]] | None = None) -> MotionResult:
    """GROP*: CMA-ES over one base position per goto of `sequence`.

    `regions` maps each location name to its region (shapely, e.g. the union of its dishes'
    Voronoi cells). Budget: `generations` (default planner.cma_generations) x `population`
    (default planner.cma_population) samples, each generation costed with one path query
    batch; `costs` is the cost profile (None: the paper's, from `planner`). `deadline` ends
    the search before a generation that would, at the pace of the previous one, end past
    it. `seed` or `rng` (rng wins) makes it deterministic.
    The starting guess and generation 0's draws come from the plan's location grid `grid`,
    where `groups` names the dishes whose cells make each location (None: each region is
    rasterised on its own). Returns the best sample seen.
    """
    t0 = time.monotonic()
    problem = SequenceProblem(sequence, regions, feasibility, nav, start_xy, planner,
                              pickup_duration, costs, grid=grid, groups=groups)
    generations = planner.cma_generations if generations is None else generations
    population = planner.cma_population if population is None else population
    if problem.n == 0:  # nothing to place: the sequence's utility is fixed
        return problem.result("GROP*", np.zeros((0, 2)), 1, time.monotonic() - t0, [], [])
    # Generation 0: the greedy initial point and population - 1 draws from the Fea^m
    # heatmaps (GROP's proposal); CMA-ES then starts at the best of them. A local search
    # started at one point cannot leave a good but far spot for an equally good near one
    # separated by zero feasibility; these draws let it start in the right basin.
    rng0 = np.random.default_rng(_seed_of(seed, rng))
    x0, previous = [], problem.start
    for g, share in zip(problem.grids, problem.stop_shares, strict=True):
        previous = initial_point(g, previous, planner.reward * share, planner.speed)
        x0.append(previous)
    X = np.stack([np.stack(x0)] * population)
    if population > 1:
        X[1:] = np.stack([draw(g, rng0, population - 1) for g in problem.grids], axis=1)
    tally = _Tally()
    tally.add(X, problem.evaluate(X)[0])
    sigma = max(MIN_SIGMA, SIGMA_FRACTION * problem.extent)
    rest = generations - 1
    options = {
        "popsize": population, "seed": _seed_of(seed, rng) + 1, "verbose": -9,
        "verb_log": 0, "verb_disp": 0, "maxiter": max(rest, 1),
        # Spend the whole budget: flat (all-penalty) generations must not stop it early.
        "tolflatfitness": math.inf, "tolfun": 0, "tolfunhist": 0, "tolx": 0,
        "tolstagnation": generations + 1,
    }
    with _BLAS.limit(limits=1, user_api="blas"):
        es = cma.CMAEvolutionStrategy(tally.best_x.ravel(), sigma, options)
        _evolve(es, problem, tally, population, rest, deadline)
    return tally.result(problem, "GROP*", t0)


def _evolve(es: cma.CMAEvolutionStrategy, problem: SequenceProblem, tally: _Tally,
            population: int, generations: int, deadline: Deadline | None) -> None:
    """Up to `generations` generations of `es`, each told its utilities and added to
    `tally`, ending before a generation that would end past `deadline`."""
    clock = time.monotonic if deadline is None else deadline.now
    last = 0.0  # duration of the latest generation
    for _ in range(generations):
        # Stop when the next generation would end past the deadline, not only once it has
        # passed: a generation of a long sequence takes tens of milliseconds.
        if deadline is not None and deadline.remaining() <= last:
            break
        t_generation = clock()
        asked = _ask_inside(es, problem, population)
        X = np.array(asked).reshape(len(asked), problem.n, 2)
        u = problem.evaluate(X)[0]
        tally.add(X, u)
        es.tell(asked, list(-u))  # cma minimises
        last = clock() - t_generation


def grop(sequence: Sequence[Action], regions: Mapping[str, BaseGeometry],
         feasibility: MotionFeasibility, nav: NavigationMap, start_xy: Sequence[float],
         planner: PlanningSettings, *, seed: int | None = None,
         rng: np.random.Generator | None = None,
         generations: int | None = None, population: int | None = None,
         pickup_duration: float | None = None, deadline: Deadline | None = None,
         costs: CostModel | None = None, grid: LocationGrid | None = None,
         groups: Mapping[str, Sequence[str]] | None = None) -> MotionResult:
    """GROP (the baseline): the same budget as `grop_star`, each sample drawing every
    goto's position from its location's Fea^m grid (∝ Fea^m, only where Fea^m > 0 unless
    it is 0 everywhere), no adaptation; the best utility is kept. Batches of `population`
    are costed together (one `path_lengths` call each) so `deadline` is checked as often
    as in GROP*. `grid` and `groups` as in `grop_star`."""
    t0 = time.monotonic()
    problem = SequenceProblem(sequence, regions, feasibility, nav, start_xy, planner,
                              pickup_duration, costs, grid=grid, groups=groups)
    generations = planner.cma_generations if generations is None else generations
    population = planner.cma_population if population is None else population
    if problem.n == 0:
        return problem.result("GROP", np.zeros((0, 2)), 1, time.monotonic() - t0, [], [])
    rng = rng if rng is not None else np.random.default_rng(seed)
    clock = time.monotonic if deadline is None else deadline.now
    tally = _Tally()
    for _ in range(generations):
        t_batch = clock()
        X = np.stack([draw(g, rng, population) for g in problem.grids], axis=1)
        tally.add(X, problem.evaluate(X)[0])
        # As in GROP*: no batch that would end past the deadline.
        if deadline is not None and deadline.remaining() <= clock() - t_batch:
            break
    return tally.result(problem, "GROP", t0)


def location_regions(groups: Sequence[Sequence[str]], cells: Mapping[str, BaseGeometry],
                     names: Sequence[str] | None = None) -> dict[str, BaseGeometry]:
    """Regions per location name ("l{k}" by default, as `plan_problem`) from the cells of
    each dish (e.g. `dict(zip(partition.dishes, partition.cells))`)."""
    names = list(names) if names is not None else [f"l{k}" for k in range(len(groups))]
    return {name: unary_union([cells[d] for d in group])
            for name, group in zip(names, groups, strict=True)}
