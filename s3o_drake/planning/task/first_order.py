"""Good first visiting orders, given to clingo as its search heuristic and bound (order.lp,
visit_order.py).

clingo's branch and bound starts from the order its domain heuristic suggests. The cheap
drive first (order.lp's own heuristic) is a nearest-neighbour tour, and from 15 locations
on clingo improves little on it within seconds: on random problems of 20-40 locations its
order after 10 s was 7-12 % above what a local search finds in a fraction of a second.
So the planner first searches locally and has clingo try the best order found first, and
then look only for better ones; the next-best distinct orders of the search are the hints
of the next sequences.

The search is an iterated local search: the nearest-neighbour order, improved by 2-opt
(segment reversals) and or-opt moves (1-3 consecutive locations moved, either way round)
to a local optimum, then, a fixed number of times, kicked by a double bridge (the path
cut in four, the middle two pieces swapped) and improved again; it walks on from there
unless that is more than WORSE above where it stood, keeps every local optimum met, and
stops after KICKS kicks, or PATIENCE in a row that found nothing better. A move is
priced in constant time from prefix sums of the path's arcs both ways round, so that the
costs may be asymmetric. The kicks draw from a fixed seed and their count is fixed: the
same costs give the same orders, unless the time cap cuts the search.

Written here: networkx's TSP heuristics (threshold accepting on the open-path graph with a
dummy node) gave orders 2-3 times as long in seconds, and OR-tools would add some 150 MB
of dependencies for this one step.
"""

from __future__ import annotations

import time

import numpy as np

KICKS = 200
"""Double-bridge kicks after the first local optimum, at most..."""
PATIENCE = 50
"""...and no more once this many in a row found no better order. On 24 random ordering
problems of 13-18 locations, against the exact optimum: 100 took 4.2 s and found all 24
optima, 50 took 1.9 s and found all 24, 25 took 1.0 s and ended 1.05 % above one."""
WORSE = 0.03
"""The search walks on from a kicked local optimum up to this share worse than where it
stood (the best is kept apart): from the best alone it stalled 1-4 % above the optimum."""
SEED = 0
BIG = 1e9  # a drive that does not exist, in the local search (finite: no inf - inf)


def first_order(costs: np.ndarray, time_limit: float = 0.2) -> list[int]:
    """An open path from node 0 through every other node of the cost matrix `costs`
    (n, n; inf where no drive exists), as node indices without 0: the best that
    `good_orders` finds within `time_limit` s."""
    return good_orders(costs, 1, time_limit)[0]


def good_orders(costs: np.ndarray, count: int, time_limit: float = 0.2) -> list[list[int]]:
    """Up to `count` distinct open paths from node 0 (as `first_order`), the cheapest
    first: the local optima that the iterated local search met."""
    costs = np.asarray(costs, float)
    order = _nearest_neighbour(costs)
    if len(costs) <= 3:  # at most two orders: both
        pool = {tuple(o): path_cost(costs, o) for o in (order, order[::-1])}
    else:
        pool = _search(np.where(np.isfinite(costs), costs, BIG), order, count,
                       time.perf_counter() + time_limit)
    return [list(o) for o in sorted(pool, key=lambda o: (pool[o], o))][:count]


def _search(c: np.ndarray, order: list[int], count: int, deadline: float
            ) -> dict[tuple[int, ...], float]:
    """The iterated local search from `order` on costs `c` (BIG for no drive): every local
    optimum met, with its cost."""
    rng = np.random.default_rng(SEED)
    walk = _local_search(c, [0, *order], deadline)
    pool = {tuple(walk[1:]): path_cost(c, walk[1:])}
    best_cost, since = pool[tuple(walk[1:])], 0
    for _ in range(KICKS):
        if time.perf_counter() >= deadline or since >= PATIENCE:
            break
        path = _local_search(c, _double_bridge(walk, rng), deadline)
        cost = path_cost(c, path[1:])
        pool[tuple(path[1:])] = cost
        if cost < pool[tuple(walk[1:])] * (1 + WORSE):
            walk = path
        since = 0 if cost < best_cost - 1e-9 else since + 1
        best_cost = min(best_cost, cost)
    if len(pool) < count:
        # Every kick came back to few local optima: the next-best orders are then the
        # cheapest single moves away from the best.
        best = min(pool, key=lambda o: (pool[o], o))
        for other in _neighbours(c, [0, *best], count):
            pool.setdefault(tuple(other[1:]), path_cost(c, other[1:]))
    return pool


def path_cost(costs: np.ndarray, order: list[int]) -> float:
    """The cost of driving from node 0 through `order`."""
    nodes = [0, *order]
    return float(np.asarray(costs)[nodes[:-1], nodes[1:]].sum())


def _nearest_neighbour(costs: np.ndarray) -> list[int]:
    order: list[int] = []
    here, left = 0, set(range(1, len(costs)))
    while left:
        here = min(left, key=lambda j, h=here: (costs[h, j], j))
        order.append(here)
        left.remove(here)
    return order


def _double_bridge(path: list[int], rng: np.random.Generator) -> list[int]:
    """The path (node 0 first) cut at three random places, the middle two pieces
    swapped: a kick that 2-opt and or-opt cannot undo in one move. A path is open, so a
    cut may fall at its end: then its last piece moves forward whole."""
    i, j, k = sorted(rng.choice(np.arange(1, len(path) + 1), size=3, replace=False).tolist())
    return path[:i] + path[j:k] + path[i:j] + path[k:]


def _local_search(costs: np.ndarray, path: list[int], deadline: float) -> list[int]:
    """2-opt and or-opt moves, the best of all taken each time, until none lowers the cost
    (or the deadline). `costs` has BIG for no drive."""
    while time.perf_counter() < deadline:
        gains, moves = _priced_moves(costs, path)
        k = int(np.argmin(gains)) if gains.size else -1
        if k < 0 or gains[k] >= -1e-9:
            break
        path = _apply(path, moves[k])
    return path


def _neighbours(costs: np.ndarray, path: list[int], count: int) -> list[list[int]]:
    """The `count` cheapest distinct paths one 2-opt or or-opt move away from `path`."""
    gains, moves = _priced_moves(costs, path)
    found: dict[tuple[int, ...], None] = {}
    for k in np.argsort(gains, kind="stable"):
        if len(found) >= count:
            break
        other = tuple(_apply(path, moves[k]))
        if other != tuple(path):
            found.setdefault(other)
    return [list(o) for o in found]


def _priced_moves(costs: np.ndarray, path: list[int]) -> tuple[np.ndarray, np.ndarray]:
    """Every 2-opt and or-opt move of `path` and how much each changes its cost, all priced
    at once: (gains, moves), a move being (kind, a, b or q, size) as `_apply` reads it.
    `e` is the costs in path order with a node after the end that every node enters free;
    F[k] and R[k] are the costs of the path's first k arcs, driven forwards and backwards."""
    m = len(path)
    e = np.zeros((m + 1, m + 1))
    e[:m, :m] = costs[np.ix_(path, path)]
    F = np.concatenate([[0.0], np.cumsum(np.diagonal(e, 1)[:m - 1])])
    R = np.concatenate([[0.0], np.cumsum(np.diagonal(e, -1)[:m - 1])])
    gains, moves = [], []
    # 2-opt: positions i..j reversed.
    i, j = np.triu_indices(m, 1)
    i, j = i[i >= 1], j[i >= 1]
    gains.append(e[i - 1, j] + R[j] - R[i] + e[i, j + 1]
                 - e[i - 1, i] - (F[j] - F[i]) - e[j, j + 1])
    moves.append(np.stack([np.zeros_like(i), i, j, np.zeros_like(i)], axis=1))
    # or-opt: positions a..a+size-1 moved behind position q, either way round (size < 0).
    q = np.arange(m)
    for size in (1, 2, 3):
        a = np.arange(1, m - size + 1)
        if not a.size:
            break
        b = a + size - 1
        removed = e[a - 1, a] + e[b, b + 1] - e[a - 1, b + 1]
        flipped = R[b] - R[a] - (F[b] - F[a])
        A, Q = np.meshgrid(a, q, indexing="ij")
        B = A + size - 1
        outside = (Q < A - 1) | (Q > B)
        for way in (0,) if size == 1 else (0, 1):
            first, last = (A, B) if way == 0 else (B, A)
            gain = e[Q, first] + e[last, Q + 1] - e[Q, Q + 1] - removed[:, None]
            if way:
                gain = gain + flipped[:, None]
            gains.append(gain[outside])
            n = int(outside.sum())
            moves.append(np.stack([np.ones(n, int), A[outside], Q[outside],
                                   np.full(n, -size if way else size)], axis=1))
    return np.concatenate(gains), np.concatenate(moves)


def _apply(path: list[int], move: np.ndarray) -> list[int]:
    kind, a, b, size = (int(x) for x in move)
    if kind == 0:
        return path[:a] + path[a:b + 1][::-1] + path[b + 1:]
    n = abs(size)
    segment = path[a:a + n] if size > 0 else path[a:a + n][::-1]
    rest = path[:a] + path[a + n:]
    at = b + 1 if b < a else b + 1 - n
    return rest[:at] + segment + rest[at:]
