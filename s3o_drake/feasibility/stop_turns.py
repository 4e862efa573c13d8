"""The turn in place between two pickups at one stop, and the chance that it gets there.

Fea^m(y, o) models a base sent to y facing o. A stop that serves several dishes is driven
to once, facing the first: the base lands where the noise puts it, picks, and then turns in
place to face each next dish (`landing.turn_until`). Where the turn sweeps a chair or a
table it stops short, and the arm reaches from a base turned away from its dish, which
Fea^m never rated. `s3o calibrate --by order` measures what that costs: the pickups made
after a turn at their stop against those made as the base arrived.

`StopTurns.chance(before, dish)` is a heatmap on `dish`'s Fea^m grid of the probability
that the turn from facing `before` to facing `dish` ends facing `dish` (within the landing
model's TURN_TOLERANCE), for a base sent to each cell: the turn's outcome T(x) for a base
that landed at x facing `before`, blurred by the landing noise's Gaussian over the free
landings only (a landing that is not free stops short nearby, at a free one). It is
computed where both dishes have Fea^m > 0 (elsewhere no stop serves them both) and kept
per pair. The motion search multiplies a later pickup's Fea^m by it when the planner's
`model_stop_turns` says so: a turn cut short is counted as a failed pickup, as Fea^m's
own assumption (the base faces its dish) has it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np
from scipy.ndimage import binary_dilation, gaussian_filter

from s3o_drake.feasibility.landing import TURN_TOLERANCE, FreeTest, turn_until
from s3o_drake.feasibility.oracle import TRUNCATE, Heatmap
from s3o_drake.world.angles import facing_yaw, wrap
from s3o_drake.world.goals import place_target_name

Pair = tuple[str, str]
"""(the dish picked before the turn, the dish picked after it)."""


class StopTurns:
    """The turn chances of one plan's belief: its free test (`FeasibilityChecker.base_free`
    of the known world), the dishes' positions, the landing noise and the Fea^m heatmaps
    the plan is made on (their grids and support)."""

    def __init__(self, free: FreeTest, dish_xy: Mapping[str, Sequence[float]],
                 nav_xy_std: float, heatmaps: Mapping[str, Heatmap]):
        self._free = free
        self._p = {d: np.asarray(p, dtype=float)[:2] for d, p in dish_xy.items()}
        self._sigma = float(nav_xy_std)
        self._heatmaps = dict(heatmaps)
        self._chances: dict[Pair, Heatmap] = {}

    def chance(self, before: str, dish: str) -> Heatmap:
        """The heatmap of the module docstring for the turn from `before` to `dish`."""
        if (before, dish) not in self._chances:
            self._chances[(before, dish)] = self._compute(before, dish)
        return self._chances[(before, dish)]

    def chances(self, pairs: Sequence[Pair]) -> dict[Pair, Heatmap]:
        """`chance` of each pair of `pairs` whose dishes both have a heatmap."""
        return {pair: self.chance(*pair) for pair in pairs
                if pair[0] in self._heatmaps and pair[1] in self._heatmaps}

    def _compute(self, before: str, dish: str) -> Heatmap:
        grid = self._heatmaps[dish]
        centres = grid.centers()
        shape = grid.values.shape
        support = (grid.values > 0) & (
            self._heatmaps[before].values_at(centres.reshape(-1, 2)).reshape(shape) > 0)
        values = np.zeros(shape)
        if support.any():
            sigma = self._sigma / grid.cell
            reach = max(1, math.ceil(TRUNCATE * sigma))
            area = binary_dilation(support, np.ones((2 * reach + 1, 2 * reach + 1), bool))
            points = centres[area]
            start = facing_yaw(points, self._p[before])
            target = facing_yaw(points, self._p[dish])
            free = self._free(np.column_stack([points, start]))
            reached = np.zeros(len(points), dtype=bool)
            if free.any():
                poses = np.column_stack([points[free], start[free]])
                yaw = turn_until(self._free, poses, target[free])
                reached[free] = np.abs(wrap(yaw - target[free])) <= TURN_TOLERANCE
            turned, landed = np.zeros(shape), np.zeros(shape)
            turned[area], landed[area] = reached, free
            if sigma > 0:
                turned = gaussian_filter(turned, sigma, mode="constant", truncate=TRUNCATE)
                landed = gaussian_filter(landed, sigma, mode="constant", truncate=TRUNCATE)
            ok = support & (landed > 1e-9)
            values[ok] = np.clip(turned[ok] / landed[ok], 0.0, 1.0)
        return Heatmap(dish, values, grid.x0, grid.y0, grid.cell)


def sequence_pairs(actions: Sequence[tuple[str, str]]) -> list[Pair]:
    """The turns at the stops of a task-level sequence (("goto", location), ("pickup",
    dish), ("place", object)): each dish picked after another at the same stop, with that
    one (a place is rated as a pick of its target, as the motion search rates it)."""
    pairs: list[Pair] = []
    before: str | None = None
    for name, arg in actions:
        if name == "goto":
            before = None
            continue
        dish = place_target_name(arg) if name == "place" else arg
        if before is not None:
            pairs.append((before, dish))
        before = dish
    return pairs
