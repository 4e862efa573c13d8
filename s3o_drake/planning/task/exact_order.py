"""The visiting-order problem solved exactly, and a lower bound on it, for the task
planner's gap and the scale benchmark's reference (docs/planning.md).

The problem is order.lp's: an open path from node 0 (the start) through every other node
of a cost matrix, each once, at the least total cost; the costs need not be symmetric.
Closed by a dummy end node that every node enters free and that leads back to the start
free, it is an asymmetric travelling-salesman tour.

- `exact_order` solves it to optimality as an integer program on scipy's HiGHS
  (`scipy.optimize.milp`): one arc in and one out of every node, and a subtour
  elimination constraint added for each subtour that a solution still has, until none is
  left. Up to 40 locations it takes seconds; it is the benchmark's reference, not a
  planner (clingo plans, and proves what it can).
- `assignment_bound` is the assignment relaxation (every node one arc in and one out, no
  subtour constraint: `scipy.optimize.linear_sum_assignment`), in milliseconds: far
  tighter than the cheapest drive into each node, and what the task planner reports as the
  bound of an order it could not prove.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import Bounds, LinearConstraint, linear_sum_assignment, milp
from scipy.sparse import coo_array

_BIG = 1e9  # an arc that does not exist, in the assignment relaxation


def _closed(costs: np.ndarray) -> np.ndarray:
    """The tour form of the open path: a dummy last node, entered free from every node but
    the start (unless the start is the only node) and left free only to the start."""
    n = len(costs)
    tour = np.full((n + 1, n + 1), np.inf)
    tour[:n, :n] = costs
    np.fill_diagonal(tour, np.inf)
    tour[1:n, n] = 0.0
    if n == 1:
        tour[0, n] = 0.0
    tour[n, 0] = 0.0
    return tour


def assignment_bound(costs: np.ndarray) -> float:
    """A lower bound on every open path from node 0 through all nodes of `costs` (n, n;
    inf where no drive exists): the cheapest assignment of one successor to each node."""
    if len(costs) <= 1:
        return 0.0
    tour = _closed(np.asarray(costs, float))
    finite = np.where(np.isfinite(tour), tour, _BIG)
    rows, cols = linear_sum_assignment(finite)
    total = float(finite[rows, cols].sum())
    return total if total < _BIG else float("inf")


def exact_order(costs: np.ndarray, time_limit: float = 300.0) -> tuple[list[int], float]:
    """The cheapest open path from node 0 through every node of `costs` (n, n; inf where
    no drive exists), as (node indices without 0, its cost). Raises ValueError when no
    path exists, TimeoutError when HiGHS does not prove one within `time_limit` s."""
    costs = np.asarray(costs, float)
    n = len(costs)
    if n <= 1:
        return [], 0.0
    tour = _closed(costs)
    m = n + 1
    arcs = [(i, j) for i in range(m) for j in range(m) if np.isfinite(tour[i, j])]
    c = np.array([tour[i, j] for i, j in arcs])
    index = np.arange(len(arcs))
    tails = np.array([i for i, _ in arcs])
    heads = np.array([j for _, j in arcs])
    degree = coo_array((np.ones(2 * len(arcs)), (np.concatenate([tails, m + heads]),
                                                  np.concatenate([index, index]))),
                       shape=(2 * m, len(arcs))).tocsr()
    constraints = [LinearConstraint(degree, 1, 1)]
    while True:
        result = milp(c, constraints=constraints, integrality=np.ones(len(arcs)),
                      bounds=Bounds(0, 1), options={"time_limit": time_limit})
        if result.status == 2:
            raise ValueError("no open path visits every node")
        if result.status != 0 or result.x is None:
            raise TimeoutError(f"no proven optimum within {time_limit:g} s ({result.message})")
        successor = {i: j for (i, j), x in zip(arcs, result.x, strict=True) if x > 0.5}
        cycles = _cycles(successor)
        if len(cycles) == 1:
            break
        for cycle in cycles:  # no cycle of these nodes alone: fewer arcs inside than nodes
            inside = set(cycle)
            row = np.array([1.0 if i in inside and j in inside else 0.0 for i, j in arcs])
            constraints.append(LinearConstraint(row[None, :], -np.inf, len(cycle) - 1))
    order, here = [], successor[0]
    while here != n:
        order.append(here)
        here = successor[here]
    return order, float(costs[[0, *order[:-1]], order].sum())


def _cycles(successor: dict[int, int]) -> list[list[int]]:
    left, cycles = set(successor), []
    while left:
        here = min(left)
        cycle = []
        while here in left:
            left.remove(here)
            cycle.append(here)
            here = successor[here]
        cycles.append(cycle)
    return cycles
