"""The task generator's check on the true world: which dishes no stop can serve.

The generator (`world.task_generation`) draws chairs and keeps a task only when every dish
keeps a candidate stop; `python -m s3o_drake.commands.generate` gives it this test. It reads
the truth (every chair where the scenario puts it), as a generator may, and never plans.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import shapely

from s3o_drake.belief.known_world import KnownWorld
from s3o_drake.feasibility.oracle import Heatmap
from s3o_drake.feasibility.planning_scene import PlanningScene
from s3o_drake.feasibility.stops import FreeStops
from s3o_drake.planning.navigation.map import NavigationMap
from s3o_drake.world.scenario import Scenario

STOP_CELL = 0.05
"""Grid spacing (m) of the candidate stops `dishes_without_stops` tries."""


def dishes_without_stops(scenario: Scenario, chair_margin: float = 0.0, *,
                         first: bool = False) -> list[str]:
    """The dishes (and place targets) of `scenario` that have no candidate stop: no base
    position within the planner's reach (`planner.reach`) of them that is free as planned
    (`FreeStops`, on a grid of STOP_CELL) and that a drive from the robot's start reaches,
    in the true world (every chair where the scenario puts it). No method can pick such a
    dish; the benchmark's tasks have none (`task_generation.generate_task`, `stops`).

    `chair_margin` (m): the drives are asked on a map whose unmapped chairs are grown by
    it, where perception may put them. A dish whose only way passes a chair within that
    of the drives' clearance is then named too: on the chairs perception finds, millimetres
    off, the planner may find no way there (dense task_030 and task_045, docs/results_history.md).

    `best_stops` with Fea^m 1 within reach, but cheaper (the generator asks once per chair
    drawn): the collision check, the costly part, is asked only at positions that keep
    the base's inscribed radius from every obstacle (nearer, every yaw collides) and that a
    drive reaches, and only until one free stop is found (`FreeStops.any_free_cell`); the
    drives too are asked only until they settle the question (`_Candidates`).

    `first`: return at the first dish found without a stop (a list of one), for a caller
    that asks only whether there is one. The generator's rejected chairs mostly close a
    dish's last drivable way, which the navigation map alone shows: they then cost no
    collision checker."""
    known = KnownWorld.perfect(scenario)
    reach = known.planner.reach_for(known.robot)
    nav = NavigationMap(known.obstacles_grown(chair_margin), robot=known.robot)
    start = nav.way_out(known.pose[:2])
    clear = known.obstacles.free_space(known.robot.inscribed_radius)
    cells = int(np.ceil(2 * reach / STOP_CELL))
    missing, asked = [], []
    for dish in known.dishes:
        p = np.asarray(dish.position[:2], float)
        grid = Heatmap(dish.name, np.zeros((cells, cells)), p[0] - reach, p[1] - reach,
                       STOP_CELL)
        centres = grid.centers()
        ask = (np.linalg.norm(centres - p, axis=-1) <= reach) & shapely.contains_xy(
            clear, centres[..., 0], centres[..., 1])
        stops = _Candidates(grid, ask, nav, start)
        if not stops.any_reachable():
            if first:
                return [dish.name]
            missing.append(dish.name)
        else:
            asked.append(stops)
    free = PlanningScene(known).free_stops if asked else None
    for stops in asked:
        if not stops.any_free(free):
            if first:
                return [stops.grid.dish]
            missing.append(stops.grid.dish)
    return sorted(missing)


class _Candidates:
    """One dish's candidate stops (`ask`: in reach and clear of obstacles, on `grid`),
    asked of the navigation map only as far as the question needs.

    Whether a cell is reachable, and whether it is a free stop, depends on that cell
    alone, so "is any cell reachable and free" has the same answer whatever the order and
    the batches the cells are asked in. A dish has hundreds of candidate cells and a few
    mostly settle it, while the generator asks once per chair drawn. Reachability is asked
    in growing batches from the cells of most clearance (in open floor: likely reachable,
    cheap for the map and likely free), and the free-stop test first on the cells found
    reachable so far; all cells are asked only of a dish that a chair cut off."""

    FIRST_BATCH = 8

    def __init__(self, grid: Heatmap, ask: np.ndarray, nav: NavigationMap,
                 start: np.ndarray) -> None:
        self.grid = grid
        self._nav, self._start = nav, start
        centres = grid.centers()
        idx = np.flatnonzero(ask)
        # Stable: ties keep the grid's order, so the work done is the same every time.
        order = np.argsort(-nav.clearance(centres.reshape(-1, 2)[idx]), kind="stable")
        self._todo = idx[order]
        self._centres = centres.reshape(-1, 2)
        self._reachable = np.zeros(ask.shape, dtype=bool)
        self._tested = np.zeros(ask.shape, dtype=bool)
        self._batch = self.FIRST_BATCH

    def _ask_next(self, size: int | None = None) -> bool:
        """Asks the map about the next `size` cells (default: the next batch, each
        twice the last); whether any of them is reachable."""
        size = self._batch if size is None else size
        batch, self._todo = self._todo[:size], self._todo[size:]
        self._batch *= 2
        if not len(batch):
            return False
        ok = self._nav.reachable(self._start, self._centres[batch])
        self._reachable.flat[batch[ok]] = True
        return bool(ok.any())

    def any_reachable(self) -> bool:
        """Whether a drive from the start reaches any candidate cell."""
        while len(self._todo):
            if self._ask_next():
                return True
        return bool(self._reachable.any())

    def any_free(self, stops: FreeStops) -> bool:
        """Whether any reachable candidate cell is a free stop (`FreeStops.any_free_cell`
        on the reachable cells, asked first of those found so far)."""
        while True:
            fresh = self._reachable & ~self._tested
            if fresh.any():
                self._tested |= fresh
                if stops.any_free_cell(dataclasses.replace(self.grid,
                                                           values=fresh.astype(float))):
                    return True
            if not len(self._todo):
                return False
            self._ask_next(len(self._todo))
