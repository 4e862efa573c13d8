"""Score and rank candidate state spaces; the top-K distribution the planner samples from.

`build_abstraction` is the one entry point (S3O's steps 2-4): Voronoi cells of the
free space, candidate partitions, task-level feasibility of every group, Score, rank.

Ranking value. The paper ranks by Score = Σ_o Fea^t(l(o), o) alone. That Score barely
moves when two close dishes merge (both stay about as feasible), and Fea^m and Fea^t
are Monte-Carlo estimates, so plain Voronoi and a sensible merge differ by noise. The
planner's own utility settles it: every location costs at least one `goto`, γ = 20,
against λ = 150 per unit of pickup feasibility (GROP*'s utility). Candidates are therefore
ranked by Score - c·|L| with the location cost c = γ / λ (0.133 by default; pass
`location_cost=0` for the paper's ranking): a merge wins unless it loses more than c of
summed Fea^t. A merged group's summed Fea^t counts at the share of Fea^m that executed
pickups at a stop of its size achieved (`shared_stop.py`), as in the motion search's
utility. Remaining ties (within 1e-9) go to fewer locations, then the canonical form, so
the ranking never depends on generation order or on the machine. The top-K distribution
normalises the ranking values of the K best (clipped at 0), so that it
follows the ranking; with `location_cost=0` it is the paper's normalised Score.
"""

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from shapely.geometry.base import BaseGeometry
from shapely.ops import unary_union

from s3o_drake.abstraction.candidates import (
    DEFAULT_BEAM_WIDTH,
    EXHAUSTIVE_MAX_DISHES,
    Partition,
    best_sums,
    canonical,
    connected_components,
    generate_candidates,
)
from s3o_drake.abstraction.location_grid import GRID_CELL, LocationGrid
from s3o_drake.abstraction.shared_stop import NONE as NO_SHARES
from s3o_drake.abstraction.shared_stop import StopShares, stop_shares
from s3o_drake.abstraction.task_feasibility import TaskFeasibility
from s3o_drake.abstraction.voronoi import Drivable, VoronoiPartition, voronoi_partition
from s3o_drake.belief.known_world import KnownWorld
from s3o_drake.world.deadline import Deadline

KEEP = 1000
"""How many of the best candidates are kept, scored and ranked in full."""


@dataclass(frozen=True)
class StateSpace:
    """A candidate symbolic state space: locations (groups of dishes) and their Fea^t."""

    groups: tuple[tuple[str, ...], ...]
    """One tuple of dish names per location."""
    indices: Partition
    score: float
    """Σ_o Fea^t(l(o), o): the paper's Score."""
    value: float
    """Score - location_cost * number of locations: what the ranking orders by."""
    task_feasibility: dict[str, float]
    """Fea^t(l(o), o) per dish."""

    def location_of(self, dish: str) -> int:
        """Index of the location (group) that holds the dish."""
        return next(k for k, g in enumerate(self.groups) if dish in g)


@dataclass
class Abstraction:
    """The Voronoi partition, the ranked candidates and the top-K distribution."""

    partition: VoronoiPartition
    ranked: list[StateSpace]
    """The best candidates (all of them when there are at most `keep`), best first."""
    top_k: list[StateSpace]
    probabilities: np.ndarray
    """Normalised ranking values of `top_k` (uniform if all are 0); sums to 1."""
    plain_voronoi: StateSpace
    """The "V" state space: every dish alone."""
    complete: bool
    """True if candidate generation ran to its end (exhaustive: all candidates)."""
    exhaustive: bool
    """True if candidates were enumerated, not searched by the beam."""
    count: int
    """Candidates generated: the product of the components' counts."""
    components: list[list[tuple[Partition, float]]]
    """Each adjacency component's generated partitions and ranking values, best first."""
    elapsed: float
    """Wall time of candidate generation and scoring (s)."""
    grid: LocationGrid
    """The location grid Fea^t was computed on: the planner's representative points and
    motion search read the same one."""
    infeasible: list[str] = field(default_factory=list)
    """Dishes whose Fea^t is 0 even alone (unreachable ones included)."""
    _make: Callable[[Partition, float], StateSpace] | None = field(default=None, repr=False)

    @property
    def unreachable(self) -> list[str]:
        """Dishes whose cell is empty: no free base position within reach."""
        return self.partition.unreachable

    @property
    def best(self) -> StateSpace:
        return self.ranked[0]

    def sample(self, rng: np.random.Generator) -> StateSpace:
        """A state space drawn from the top-K distribution (S3O's selection)."""
        return self.top_k[int(rng.choice(len(self.top_k), p=self.probabilities))]

    def random_candidate(self, rng: np.random.Generator) -> StateSpace:
        """A state space drawn uniformly among all generated candidates (S3O-Random).

        Candidates are the products of the components' partitions, so one uniform draw
        per component is a uniform draw among all `count` of them.
        """
        picks = [found[int(rng.integers(len(found)))] for found in self.components]
        indices = canonical([g for p, _ in picks for g in p])
        return self._make(indices, sum(v for _, v in picks))

    def location(self, state_space: StateSpace, k: int) -> BaseGeometry:
        """The region of location k: the union of its dishes' cells."""
        return unary_union([self.partition.cells[i] for i in state_space.indices[k]])

    def sym(self, state_space: StateSpace, p: Sequence[float]) -> int | None:
        """Sym(y): the location of `state_space` that holds position p, or None."""
        cell = self.partition.sym(p)
        if cell is None:
            return None
        return next(k for k, g in enumerate(state_space.indices) if cell in g)


def top_k_distribution(scores: Sequence[float]) -> np.ndarray:
    """Scores normalised to probabilities; uniform when they are all zero."""
    scores = np.asarray(scores, dtype=float)
    if len(scores) == 0:
        return scores
    total = scores.sum()
    return scores / total if total > 0 else np.full(len(scores), 1.0 / len(scores))


def _sort_key(item: tuple[Partition, float]):
    partition, score = item
    return (-round(score, 9), len(partition), partition)


def rank(partition: VoronoiPartition, task: TaskFeasibility, *, top_k: int,
         location_cost: float = 0.0, max_count: int = 100_000, time_limit: float = 5.0,
         keep: int = KEEP, exhaustive_max_dishes: int = EXHAUSTIVE_MAX_DISHES,
         beam_width: int = DEFAULT_BEAM_WIDTH, shares: StopShares = NO_SHARES) -> Abstraction:
    """Generates, scores and ranks candidate state spaces of a partition.

    Each connected component of the adjacency graph is partitioned on its own
    (enumerated up to `exhaustive_max_dishes` dishes, beam search above; `max_count`
    and the remaining time bound each), then the components' best partitions are
    combined best-first into the `keep` best candidates overall. With every component
    enumerated, those are exactly the `keep` best of all candidates. A group's summed Fea^t
    counts at the share of its stop size (`shares`, `shared_stop.py`), as the motion search
    rates its pickups.
    """
    start = time.perf_counter()
    deadline = start + time_limit
    n = len(partition.dishes)
    names = partition.dishes
    per_component: list[list[tuple[Partition, float]]] = []
    complete, exhaustive, count = True, True, 1
    for component in connected_components(n, partition.adjacency):
        local = {v: k for k, v in enumerate(component)}
        local_adjacency = [{local[w] for w in partition.adjacency[v]} for v in component]

        # The enumeration meets each group in many partitions (17,167 partitions of a
        # 40-dish task's components asked 82,130 group values): each is computed once.
        values: dict[tuple[int, ...], float] = {}

        def value(group: tuple[int, ...], component=component, values=values) -> float:
            known = values.get(group)
            if known is None:
                known = values[group] = (shares.of(len(group))
                                         * task.group_score([component[k] for k in group])
                                         - location_cost)
            return known

        found, done = generate_candidates(
            len(component), local_adjacency, value, max_count=max_count,
            time_limit=max(deadline - time.perf_counter(), 0.0),
            exhaustive_max_dishes=exhaustive_max_dishes, beam_width=beam_width)
        complete &= done
        exhaustive &= len(component) <= exhaustive_max_dishes
        count *= len(found)
        mapped = [(canonical([[component[k] for k in g] for g in p]), v) for p, v in found]
        per_component.append(sorted(mapped, key=_sort_key))

    combined: list[tuple[Partition, float]] = [((), 0.0)]
    keep = max(keep, top_k)
    for found in per_component:
        combined = best_sums(combined, found, keep)
    plain = canonical([(i,) for i in range(n)])
    if not any(p == plain for p, _ in combined):  # always a candidate
        combined.append((plain, task.score(plain) - location_cost * n))
    combined.sort(key=_sort_key)

    def state_space(indices: Partition, value: float) -> StateSpace:
        fea: dict[str, float] = {}
        for group in indices:
            for i, fea_t in zip(group, task.of_group(group), strict=True):
                fea[names[i]] = float(fea_t)
        return StateSpace(groups=tuple(tuple(names[i] for i in g) for g in indices),
                          indices=indices, score=task.score(indices), value=float(value),
                          task_feasibility=fea)

    ranked = [state_space(p, v) for p, v in combined]
    best = ranked[:top_k]
    plain_space = next(s for s in ranked if s.indices == plain)
    infeasible = [d for d, v in plain_space.task_feasibility.items() if v <= 0.0]
    return Abstraction(partition=partition, ranked=ranked, top_k=best,
                       probabilities=top_k_distribution([max(s.value, 0.0) for s in best]),
                       plain_voronoi=plain_space, complete=complete, exhaustive=exhaustive,
                       count=count, components=per_component,
                       elapsed=time.perf_counter() - start, grid=task.grid,
                       infeasible=infeasible,
                       _make=state_space)


def build_abstraction(known: KnownWorld, feasibility, *,
                      dishes: Sequence[str] | None = None, seed: int | None = None,
                      clearance: float | None = None, joint_threshold: float = 0.0,
                      grid_cell: float = GRID_CELL,
                      location_cost: float | None = None, max_count: int = 100_000,
                      time_limit: float = 5.0,
                      exhaustive_max_dishes: int = EXHAUSTIVE_MAX_DISHES,
                      beam_width: int = DEFAULT_BEAM_WIDTH,
                      drivable: Drivable | None = None) -> Abstraction:
    """S3O's state-space computation for what the robot knows, ranked, with the top-K
    distribution.

    `feasibility` is Fea^m: a `MotionFeasibility`, a mapping dish -> Heatmap or a list of
    Heatmaps, evaluated once on the location grid (`location_grid.py`; cell `grid_cell`,
    joint rule at `joint_threshold`), which the result carries. The clearance defaults to the
    robot's inscribed radius (`voronoi.py`); reach, N, K and the seed
    default to the planner's settings and the scenario's seed; `location_cost` to the
    planner's γ / λ (the planner passes the motion search's own with
    `planner.location_price: search`); Fea^t draws as `planner.group_positions` says.
    `drivable` (points -> bool; None: all) says where the robot can drive to, for the
    partition's claims (`voronoi.py`) and the grid's Fea^m (0 where it cannot).
    """
    planner = known.planner
    if location_cost is None:
        location_cost = planner.gamma / planner.reward if planner.reward > 0 else 0.0
    partition = voronoi_partition(known, dishes=dishes, clearance=clearance,
                                  feasibility=feasibility, drivable=drivable,
                                  deadline=Deadline.after(time_limit))
    grid = LocationGrid.of(partition, feasibility, threshold=joint_threshold, cell=grid_cell,
                           drivable=drivable)
    task = TaskFeasibility(grid, samples=planner.location_samples,
                           seed=known.settings.seed if seed is None else seed,
                           positions=planner.group_positions)
    return rank(partition, task, top_k=planner.top_k, location_cost=location_cost,
                max_count=max_count,
                time_limit=time_limit, exhaustive_max_dishes=exhaustive_max_dishes,
                beam_width=beam_width, shares=stop_shares(planner, robot=known.robot))
