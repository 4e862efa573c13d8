"""What the task planner reads of a state space: where each location is, and what driving
between them costs.

Costs for the task planner. Location-to-location costs are the collision-free path lengths
between the locations' representative points, divided by v, x10, as integers. A location's
representative point is its best standing spot: the point of its location grid with the
highest summed Fea^m under the joint-feasibility rule (the location GROP* starts from and
GROP draws from, `abstraction/location_grid.py`; ties to the point nearest the
Fea^m-weighted centroid), among the 20 best the first that can be driven to from the start;
when none of them can (the best spots enclosed by chairs), the first of the rest that can.
The motion search then moves the stops, so these costs only rank the visiting orders.

`dead_dishes` names the dishes that no point of their location can pick: left out
(unreachable) rather than driven to.
"""

from collections.abc import Mapping, Sequence

import numpy as np
from shapely.geometry.base import BaseGeometry

from s3o_drake.abstraction.location_grid import LocationGrid
from s3o_drake.planning.navigation.map import NavigationMap
from s3o_drake.planning.task.planner import START

COST_SCALE = 10.0
"""clingo's costs are integers: seconds of driving x COST_SCALE (a tenth of a second)."""
REPRESENTATIVE_CANDIDATES = 20
"""Best grid points tried (by joint Fea^m) for a location's representative point."""


def representative_points(regions: Mapping[str, BaseGeometry], groups: Sequence[Sequence[str]],
                          names: Sequence[str], grid: LocationGrid, nav: NavigationMap,
                          start: np.ndarray) -> dict[str, np.ndarray | None]:
    """Each location's best standing spot on the plan's location grid (see the module
    docstring); None for an empty region or one where no spot with Fea^m > 0 can be driven
    to."""
    out: dict[str, np.ndarray | None] = {}
    for name, group in zip(names, groups, strict=True):
        region = regions[name]
        if region.is_empty or region.area <= 0:
            out[name] = None
            continue
        location = grid.location(group)
        w, points = location.weight, location.points
        # Ties (a plateau of equal Fea^m) go to the point nearest the Fea^m-weighted
        # centroid, as for GROP*'s initial point: not to whichever the lattice lists first.
        centroid = (w[:, None] * points).sum(axis=0) / w.sum() if w.sum() > 0 else \
            points.mean(axis=0)
        near = np.linalg.norm(points - centroid, axis=1)
        ranked = np.lexsort((near, -w))
        # The best spots can all be enclosed (task_004: a corner boxed in by two chairs):
        # the location is not lost while a spot of it with Fea^m > 0 can be driven to.
        # The rest is asked only when none of the best can (rarely).
        ranked = np.concatenate([ranked[:REPRESENTATIVE_CANDIDATES],
                                 [k for k in ranked[REPRESENTATIVE_CANDIDATES:] if w[k] > 0]])
        P = points[ranked.astype(int)]
        first = first_reachable(nav, start, P, batch=REPRESENTATIVE_CANDIDATES)
        out[name] = None if first is None else P[first].copy()
    return out


def first_reachable(nav: NavigationMap, start: Sequence[float], P: np.ndarray,
                    batch: int = 256) -> int | None:
    """The index of the first of the points (m, 2), in their order, that a drive from
    `start` reaches on `nav`, or None; asked `batch` points at a time, so that a list in
    order of preference costs one query when its first points can be reached."""
    P = np.asarray(P, dtype=float).reshape(-1, 2)
    for k in range(0, len(P), batch):
        reached = np.flatnonzero(nav.reachable(start, P[k:k + batch]))
        if len(reached):
            return k + int(reached[0])
    return None


def dead_dishes(groups: Sequence[Sequence[str]], grid: LocationGrid) -> set[str]:
    """Dishes with Fea^m 0 at every point of their location: left out (unreachable), not
    driven to, since the search would stand anywhere there, even where the base collides
    (random scenes, issue 19). With the network's Fea^m the pipeline asks the oracle."""
    dead = set()
    for group in groups:
        location = grid.location(group)
        for row, dish in enumerate(location.dishes):
            if not (location.fea[row] > 0).any():
                dead.add(dish)
    return dead


def location_costs(points: Mapping[str, np.ndarray | None], nav: NavigationMap, start: np.ndarray,
                   speed: float) -> dict[tuple[str, str], float]:
    """Task-planner costs {(from, to): path length / v x COST_SCALE} between the
    representative points and the start; pairs with a missing point are left out (cannot
    drive there)."""
    keys = [k for k, p in points.items() if p is not None] + [START]
    P = np.array([points[k] for k in keys[:-1]] + [start]).reshape(-1, 2)
    A = np.repeat(P, len(P), axis=0)
    B = np.tile(P, (len(P), 1))
    L = nav.path_lengths(A, B).reshape(len(P), len(P))
    return {(a, b): float(L[i, j] / speed * COST_SCALE)
            for i, a in enumerate(keys) for j, b in enumerate(keys)
            if a != b and b != START and np.isfinite(L[i, j])}
