"""Fea^m(y_r, y_o) under uncertainty: Monte-Carlo over the navigation and reaching noise.

The robot is sent to base position y_r with its yaw facing the dish (the arm is mounted on
the base's x axis, so facing the dish puts the dish straight ahead of the arm). It lands
at y_r + ε, yaw + η with ε ~ N(0, nav_xy_std² I), η ~ N(0, nav_yaw_std²) (T^n), and the
gripper aims at the dish's grasp point shifted horizontally by ξ ~ N(0, reach_std² I) (T^m:
the overhead camera errs in the floor plane; the table's height is known). Fea^m is
the fraction of `samples` such landings from which `FeasibilityChecker` finds a feasible
pick. The noise is drawn from one generator seeded by the caller, all at once and before
any work is split, so the result does not depend on how many workers compute it.

Heatmaps evaluate Fea^m on a grid of base positions: a 4 m x 4 m crop at 64 x 64 cells
around a dish (as the paper's code did), or the whole room.
"""

import math
from dataclasses import dataclass

import numpy as np

from s3o_drake.feasibility.check import FeasibilityChecker, facing_yaw
from s3o_drake.scenario import Uncertainty

CROP_SIZE = 4.0
CROP_CELLS = 64


@dataclass(frozen=True)
class Heatmap:
    """Fea^m of one dish on a grid of base positions.

    values[i, j] is the probability at the cell centre
    (x0 + (j + 0.5) * cell, y0 + (i + 0.5) * cell): rows go north (+y), columns east (+x).
    """

    dish: str
    values: np.ndarray
    x0: float
    y0: float
    cell: float

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """(x_min, x_max, y_min, y_max) of the grid, for plotting."""
        rows, cols = self.values.shape
        return (self.x0, self.x0 + cols * self.cell, self.y0, self.y0 + rows * self.cell)

    def centers(self) -> np.ndarray:
        """Cell centres, shape (rows, cols, 2)."""
        rows, cols = self.values.shape
        xs = self.x0 + (np.arange(cols) + 0.5) * self.cell
        ys = self.y0 + (np.arange(rows) + 0.5) * self.cell
        return np.stack(np.meshgrid(xs, ys), axis=-1)

    def value_at(self, p: np.ndarray) -> float:
        """The probability of the cell holding the point p (0 outside the grid)."""
        j = math.floor((p[0] - self.x0) / self.cell)
        i = math.floor((p[1] - self.y0) / self.cell)
        rows, cols = self.values.shape
        return float(self.values[i, j]) if 0 <= i < rows and 0 <= j < cols else 0.0


class FeasibilityOracle:
    """Fea^m from the Drake check, with the scenario's noise model."""

    def __init__(self, checker: FeasibilityChecker, noise: Uncertainty):
        self.checker = checker
        self.noise = noise

    def _landings(self, nominal: np.ndarray, dish: str, samples: int,
                  rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        """Noisy landing poses (n * samples, 3) and reach offsets for nominal positions."""
        p_dish, _ = self.checker.scene.dish_p_WD(dish)
        n = len(nominal)
        yaw = facing_yaw(nominal, p_dish)
        bases = np.empty((n, samples, 3))
        bases[..., :2] = nominal[:, None, :] + rng.normal(0.0, self.noise.nav_xy_std,
                                                         (n, samples, 2))
        bases[..., 2] = yaw[:, None] + rng.normal(0.0, self.noise.nav_yaw_std, (n, samples))
        # The dish is seen from above: its position errs in the floor plane; its height is
        # that of the mapped table top.
        offsets = np.zeros((n, samples, 3))
        offsets[..., :2] = rng.normal(0.0, self.noise.reach_std, (n, samples, 2))
        return bases.reshape(-1, 3), offsets.reshape(-1, 3)

    def probabilities(self, positions: np.ndarray, dish: str, *, rng: np.random.Generator,
                      samples: int | None = None) -> np.ndarray:
        """Fea^m for each base position (n, 2) and the dish."""
        positions = np.asarray(positions, dtype=float).reshape(-1, 2)
        samples = samples or self.noise.samples
        bases, offsets = self._landings(positions, dish, samples, rng)
        feasible = self.checker.check_many(bases, dish, offsets)
        return feasible.reshape(len(positions), samples).mean(axis=1)

    def probability(self, position: np.ndarray, dish: str, *, rng: np.random.Generator,
                    samples: int | None = None) -> float:
        """Fea^m(y_r, y_o) for one base position."""
        return float(self.probabilities(position, dish, rng=rng, samples=samples)[0])

    def heatmap(self, dish: str, *, rng: np.random.Generator, size: float = CROP_SIZE,
                cells: int = CROP_CELLS, center: np.ndarray | None = None,
                samples: int | None = None) -> Heatmap:
        """Fea^m on a cells x cells grid of side `size` (m), centred on the dish by default."""
        if center is None:
            center, _ = self.checker.scene.dish_p_WD(dish)
        cell = size / cells
        grid = Heatmap(dish, np.zeros((cells, cells)), float(center[0] - size / 2),
                       float(center[1] - size / 2), cell)
        values = self.probabilities(grid.centers().reshape(-1, 2), dish, rng=rng,
                                    samples=samples)
        return Heatmap(dish, values.reshape(cells, cells), grid.x0, grid.y0, cell)

    def room_heatmap(self, dish: str, *, rng: np.random.Generator, cell: float = 0.05,
                     samples: int | None = None) -> Heatmap:
        """Fea^m over the whole room at `cell` resolution (m)."""
        x_min, y_min, x_max, y_max = self.checker.scene.scenario.room.bounds
        cols = math.ceil((x_max - x_min) / cell)
        rows = math.ceil((y_max - y_min) / cell)
        grid = Heatmap(dish, np.zeros((rows, cols)), x_min, y_min, cell)
        values = self.probabilities(grid.centers().reshape(-1, 2), dish, rng=rng,
                                    samples=samples)
        return Heatmap(dish, values.reshape(rows, cols), x_min, y_min, cell)
