"""The motion search's positions, checked exactly against the free-stop test.

The free-stop rule (`feasibility/stops.py`) keeps a heatmap cell when its centre and four
corners are free stops, and the motion search reads Fea^m per cell. A position inside a
kept cell can still collide where an obstacle's corner reaches in between the tested
points: on the soak's scene 33 (`random_scene(0, 33)`) a chair's corner cut the top edge
of a kept cell, and S3O-GROP*, S3O-GROP and V-GROP commanded dish_2's stop 1 cm inside it.
Testing every sample exactly would cost the search about a third of its time, while a
final position only rarely falls there. So the best search results are tested (all their
stops in one query, `FreeStops.free_facing`, each facing the first dish picked there, as
the plan's goto pose faces), and a stop that is not free moves to the position that the
search's own utility rates best among the free ones near it in its region: a lattice of
`STEP` within `RADIUS` of it first, then the region's location-grid lattice. A stop with
no free position in its region stays, and the plan checker reports it.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
import shapely

from s3o_drake.abstraction.voronoi import lattice_in
from s3o_drake.planning.motion.grop import MotionResult, SequenceProblem

FreeTest = Callable[[np.ndarray, Sequence[str]], np.ndarray]
"""(positions (m, 2), dishes (m,)) -> bool (m,): the base at each position, facing its
dish, is free (`FreeStops.free_facing`: one collision query for all)."""
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
    # A stop with no pickup faces along its path: there is no dish to face, nothing to test.
    tested = [k for k, dishes in enumerate(problem.stop_dishes) if dishes]
    first = [problem.stop_dishes[k][0] for k in tested]
    ok = free(x[tested], first) if tested else np.zeros(0, dtype=bool)
    moved = False
    for k, dish in ((k, d) for k, d, good in zip(tested, first, ok, strict=True) if not good):
        for candidates in (_near(problem.regions[k], x[k]), lattice_in(problem.regions[k])):
            if len(candidates):
                candidates = candidates[free(candidates, [dish] * len(candidates))]
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
