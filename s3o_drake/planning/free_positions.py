"""The motion search's positions, checked exactly against the free-stop test.

The free-stop rule (`feasibility/stops.py`) keeps a heatmap cell when its centre and four
corners are free stops, and the motion search reads Fea^m per cell. A position inside a
kept cell can still collide where an obstacle's corner reaches in between the tested
points: on the soak's scene 33 (`random_scene(0, 33)`) a chair's corner cut the top edge
of a kept cell, and S3O-GROP*, S3O-GROP and V-GROP commanded dish_2's stop 1 cm inside it.
Testing every sample exactly would cost the search about a third of its time, while a
final position only rarely falls there. So each search's result is tested (`FreeStops.free`,
facing the first dish picked at the stop, as the plan's goto pose faces), and a stop that
is not free moves to the position that the search's own utility rates best among the free
ones near it in its region: a lattice of `STEP` within `RADIUS` of it first, then the
region's location-grid lattice. A stop with no free position in its region stays, and the
plan checker reports it.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import shapely

from s3o_drake.abstraction.voronoi import lattice_in
from s3o_drake.planning.motion_search import MotionResult, SequenceProblem

FreeTest = Callable[[np.ndarray, str], np.ndarray]
"""(positions (m, 2), dish) -> bool (m,): the base there, facing the dish, is free."""
STEP = 0.02
"""Spacing (m) of the positions tried near a stop that is not free."""
RADIUS = 0.15
"""How far (m) from a stop that is not free its nearby positions are tried first."""


def _near(region, p: np.ndarray) -> np.ndarray:
    """The lattice points of spacing STEP within RADIUS of `p` inside `region` (m, 2)."""
    n = int(RADIUS / STEP)
    offsets = np.stack(np.meshgrid(np.arange(-n, n + 1), np.arange(-n, n + 1)), -1)
    offsets = offsets.reshape(-1, 2) * STEP
    offsets = offsets[np.hypot(offsets[:, 0], offsets[:, 1]) <= RADIUS]
    points = p + offsets
    return points[shapely.intersects_xy(region, points[:, 0], points[:, 1])]


def with_free_stops(result: MotionResult, problem: SequenceProblem,
                    free: FreeTest) -> MotionResult:
    """`result` (a search's over `problem`) with every stop free by `free` where its region
    has a free position (module docstring); `result` itself when its stops are free."""
    if not result.valid or problem.n == 0:
        return result
    x = np.array(result.positions, dtype=float).reshape(problem.n, 2)
    moved = False
    for k, dishes in enumerate(problem.stop_dishes):
        if not dishes or free(x[k:k + 1], dishes[0])[0]:
            continue  # a stop with no pickup faces along its path: no dish to face
        for candidates in (_near(problem.regions[k], x[k]), lattice_in(problem.regions[k])):
            candidates = candidates[free(candidates, dishes[0])] if len(candidates) else candidates
            if len(candidates):
                X = np.repeat(x[None], len(candidates), axis=0)
                X[:, k] = candidates
                x[k] = candidates[int(np.argmax(problem.evaluate(X)[0]))]
                moved = True
                break
    if not moved:
        return result
    return problem.result(result.method, x, result.samples, result.elapsed,
                          list(result.history), list(result.history_utility))
