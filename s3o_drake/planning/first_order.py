"""A good first visiting order, given to clingo as its search heuristic (order.lp).

clingo's branch and bound starts from the order its domain heuristic suggests. The cheap
drive first (order.lp's own heuristic) is a nearest-neighbour tour, and from 15 locations
on clingo improves little on it within seconds: on random problems of 20-40 locations its
order after 10 s was 7-12 % above what a local search finds in a fraction of a second.
So the planner first improves the nearest-neighbour order by local search (2-opt segment
reversals and or-opt moves of 1-3 locations, to a local optimum or a time cap) and has
clingo try that order first; clingo then keeps improving on it and proves what it can.

Written here: networkx's TSP heuristics (threshold accepting on the open-path graph with a
dummy node) gave orders 2-3 times as long in seconds, and OR-tools would add some 150 MB
of dependencies for this one step.
"""

from __future__ import annotations

import time

import numpy as np


def first_order(costs: np.ndarray, time_limit: float = 0.2) -> list[int]:
    """An open path from node 0 through every other node of the cost matrix `costs`
    (n, n; inf where no drive exists), as node indices without 0: nearest neighbour, then
    2-opt and or-opt moves while they lower the cost, for at most `time_limit` s."""
    n = len(costs)
    order: list[int] = []
    here, left = 0, set(range(1, n))
    while left:
        here = min(left, key=lambda j, h=here: (costs[h, j], j))
        order.append(here)
        left.remove(here)
    deadline = time.perf_counter() + time_limit
    best = path_cost(costs, order)
    improved = True
    while improved and time.perf_counter() < deadline:
        improved = False
        for candidate in _moves(order):
            cost = path_cost(costs, candidate)
            if cost < best:
                order, best, improved = candidate, cost, True
                break
    return order


def path_cost(costs: np.ndarray, order: list[int]) -> float:
    """The cost of driving from node 0 through `order`."""
    nodes = [0, *order]
    return float(costs[nodes[:-1], nodes[1:]].sum())


def _moves(order: list[int]):
    """Every 2-opt reversal, then every or-opt move of 1-3 consecutive nodes (either way
    round) to another place of the path."""
    n = len(order)
    for i in range(n):
        for j in range(i + 1, n):
            yield order[:i] + order[i:j + 1][::-1] + order[j + 1:]
    for size in (1, 2, 3):
        for i in range(n - size + 1):
            segment, rest = order[i:i + size], order[:i] + order[i + size:]
            for j in range(len(rest) + 1):
                if j != i:
                    yield rest[:j] + segment + rest[j:]
                    if size > 1:
                        yield rest[:j] + segment[::-1] + rest[j:]
