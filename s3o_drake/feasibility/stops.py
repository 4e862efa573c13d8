"""Stops the planner may command: base poses that are free in the world the robot knows.

Fea^m(y, o) models a base *sent to* y facing o: where that pose collides, the landing
model (`landing.stop_short`) has the base step back along its heading, towards free space.
The execution does not drive that way: the BaseNavigator stops at the last free pose along
the path it drives, which comes in from wherever the previous stop was. At a planned stop
that collides the two disagree, and the calibration study measured it: on 152 executed
pickups (26 generated tasks, S3O-GROP* and V-PETLON, seed 0), the 28 planned at stops
that collide in the true world succeeded 0.86 of the time at ECE 0.14, every `no_ik`
among them, against 0.98 and ECE 0.02 at free stops (docs/calibration.md).

So the planner commands only stops that are free as planned: the robot, arm stowed, at the
stop and facing the dish, passes the known world's collision check (`FeasibilityChecker.
base_free`: its map, the perceived chairs, the remaining dishes; the same check and
padding as the execution's). Only the landing noise can then push the base into a
collision, by a few centimetres, where stepping back along the heading and along the path
end close together.

- `FreeStops.restrict(heatmap)` sets Fea^m to 0 in the cells where a stop is not free:
  the cell's centre and its four corners must be free, so that a continuous position of
  the motion search inside a kept cell is free too (the heatmap is read per cell).
- `FreeStops.any_free_cell(heatmap)` says whether `restrict` would keep any cell, asking
  only until it finds one (the task generator's question, once per chair it draws).
- `FreeStops.free(points, dish)` tests exact positions; `goal_test` adds to it that the
  position lies in no cell the rule dropped (V-PETLON's random goals: a free position in a
  dropped cell would be planned with Fea^m 0, though the model rates it higher).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping, Sequence

import numpy as np

from s3o_drake.feasibility.check import FeasibilityChecker
from s3o_drake.feasibility.oracle import Heatmap
from s3o_drake.feasibility.scene import FeasibilityScene
from s3o_drake.world.angles import facing_yaw

#: A cell's centre and corners, in cells from its lower-left corner.
_CORNERS = ((0, 0), (0, 1), (1, 0), (1, 1))


class FreeStops:
    """The known world's free-stop test (see the module docstring), on the plan's one scene
    of it (`planning_scene.PlanningScene.free_stops`)."""

    def __init__(self, scene: FeasibilityScene, dishes: Sequence[str]):
        # Only base_free is asked: no reachability map is needed ("ik" loads none).
        self._checker = FeasibilityChecker(scene, method="ik")
        self._p_WD = {d: scene.dish_p_WD(d)[0][:2] for d in dishes}
        # The free cells of a heatmap depend only on its grid and which cells are asked: a
        # second plan on the same heatmaps (the FCN's re-plan) reuses them.
        self._cells: dict[tuple, np.ndarray] = {}

    def free(self, points: np.ndarray, dish: str) -> np.ndarray:
        """Whether the base at each position of `points` (n, 2), facing `dish`, is
        collision-free in the known world: bool (n,)."""
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        return self.free_facing(points, [dish] * len(points))

    def free_facing(self, points: np.ndarray, dishes: Sequence[str]) -> np.ndarray:
        """`free`, each position of `points` (n, 2) facing its own dish of `dishes` (n),
        in one collision query."""
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        if len(points) == 0:
            return np.zeros(0, dtype=bool)
        targets = np.array([self._p_WD[d] for d in dishes], dtype=float).reshape(-1, 2)
        return self._checker.base_free(np.column_stack([points, facing_yaw(points, targets)]))

    def free_cells(self, heatmap: Heatmap) -> np.ndarray:
        """Cells (rows, cols) of `heatmap` with Fea^m > 0 whose centre and four corners are
        free stops for its dish; cells with Fea^m 0 are not tested (False)."""
        values = heatmap.values
        rows, cols = values.shape
        need = values > 0
        key = (heatmap.dish, heatmap.x0, heatmap.y0, heatmap.cell, need.shape,
               np.packbits(need).tobytes())
        if key in self._cells:
            return self._cells[key]
        corner_need = np.zeros((rows + 1, cols + 1), dtype=bool)
        for di, dj in _CORNERS:
            corner_need[di:di + rows, dj:dj + cols] |= need
        corner_free = self._lattice_free(heatmap, corner_need, 0.0)
        ok = need.copy()
        for di, dj in _CORNERS:
            ok &= corner_free[di:di + rows, dj:dj + cols]
        # Only cells whose four corners are free need their centre asked: on a 30-dish
        # task Drake then checks 12,359 poses instead of 14,658.
        ok &= self._lattice_free(heatmap, ok, 0.5)
        ok.setflags(write=False)  # shared by every caller that asks again
        self._cells[key] = ok
        return ok

    def any_free_cell(self, heatmap: Heatmap, batch: int = 32) -> bool:
        """Whether `free_cells(heatmap)` has any cell, asking Drake `batch` cells at a
        time and stopping at the first free one: the task generator asks it once per
        chair drawn, and most dishes have many free cells."""
        need = heatmap.values > 0
        rows, cols = need.shape
        asked = np.zeros((rows + 1, cols + 1), dtype=bool)
        corner_free = np.zeros((rows + 1, cols + 1), dtype=bool)
        cells = np.argwhere(need)
        for start in range(0, len(cells), batch):
            i, j = cells[start:start + batch].T
            corners = np.zeros_like(asked)
            for di, dj in _CORNERS:
                corners[i + di, j + dj] = True
            corners &= ~asked
            corner_free |= self._lattice_free(heatmap, corners, 0.0)
            asked |= corners
            ok = np.ones(len(i), dtype=bool)
            for di, dj in _CORNERS:
                ok &= corner_free[i + di, j + dj]
            if not ok.any():
                continue
            centres = np.zeros_like(need)
            centres[i[ok], j[ok]] = True
            if self._lattice_free(heatmap, centres, 0.5).any():
                return True
        return False

    def restrict(self, heatmap: Heatmap) -> Heatmap:
        """`heatmap` with Fea^m 0 wherever a stop is not free (`free_cells`)."""
        return dataclasses.replace(heatmap, values=np.where(self.free_cells(heatmap),
                                                            heatmap.values, 0.0))

    def restrict_all(self, heatmaps: Sequence[Heatmap],
                     check: Callable[[], object] | None = None) -> tuple[Heatmap, ...]:
        """`restrict` of each heatmap whose dish the known world holds (others as given).
        `check` is called before each dish: the planner's deadline, which raises when it
        has passed (30 dishes take about a second, more than a small budget)."""
        out = []
        for h in heatmaps:
            if check is not None:
                check()
            out.append(self.restrict(h) if h.dish in self._p_WD else h)
        return tuple(out)

    def restrict_source(self, heatmaps, check: Callable[[], object] | None = None):
        """`restrict_all` of a list, tuple or mapping (dish -> Heatmap) of heatmaps, in a
        container of the same kind; any other Fea^m source is returned as given."""
        if isinstance(heatmaps, Mapping):
            return dict(zip(heatmaps, self.restrict_all(list(heatmaps.values()), check),
                            strict=True))
        if isinstance(heatmaps, (list, tuple)):
            return self.restrict_all(heatmaps, check)
        return heatmaps

    def goal_test(self, model: Sequence[Heatmap], plan: Sequence[Heatmap]
                  ) -> Callable[[np.ndarray, str], np.ndarray]:
        """(points (n, 2), dish) -> bool (n,): free stops (`free`) that lie in no cell that
        `restrict` dropped, i.e. where `plan` (the restricted `model`) reads 0 and `model`
        does not. Dishes without heatmaps: `free` alone."""
        model_of = {h.dish: h for h in model}
        plan_of = {h.dish: h for h in plan}

        def test(points: np.ndarray, dish: str) -> np.ndarray:
            ok = self.free(points, dish)
            if dish in model_of and dish in plan_of:
                ok &= ~((model_of[dish].values_at(points) > 0)
                        & (plan_of[dish].values_at(points) == 0))
            return ok

        return test

    def _lattice_free(self, heatmap: Heatmap, where: np.ndarray, offset: float) -> np.ndarray:
        """Free-stop test at the lattice points (x0 + (j + offset) cell, y0 + (i + offset)
        cell) where `where` (i, j) holds; False elsewhere."""
        out = np.zeros(where.shape, dtype=bool)
        i, j = np.nonzero(where)
        points = np.column_stack([heatmap.x0 + (j + offset) * heatmap.cell,
                                  heatmap.y0 + (i + offset) * heatmap.cell])
        out[i, j] = self.free(points, heatmap.dish)
        return out
