"""Task-level feasibility Fea^t(l, o) of a (possibly merged) location.

How "N positions drawn from l weighted by Fea^m" is read here:

1. l is rasterised: its positions are the points of the plan's location grid
   (`location_grid.LocationGrid`, 5 cm) that `Sym` maps into one of l's cells.
2. For dish o the weight of a position y is Fea^m(y, o) (the paper's Smp: "positions
   weighted by Fea^m(y_r, y_o)"), and 0 unless y is jointly feasible for l's group (the
   grid's one rule, `location_grid.joint_feasible`: Fea^m(y, o') > the grid's threshold
   for every dish o' of the group), as the paper's code scores a pixel of a merged cell
   only if all its objects are feasible there. With the default threshold 0, a position
   counts if every dish of the group has some chance from it. For a single dish this is
   plain Fea^m weighting over its cell.
3. N positions are drawn from the normalised weights by *systematic* resampling: one
   uniform offset u ~ U[0, 1) from a generator seeded by (seed, the group's dish
   indices), then the positions at cumulative weights (u + k) / N, k = 0..N-1, in the
   grid's fixed order; the dishes of a group share u. It is an unbiased draw with far
   less variance than N independent draws, so candidates are not reordered by sampling
   noise, and it is deterministic given the seed and independent of which other
   candidates were scored before.
4. Fea^t(l, o) = the mean of Fea^m(y_k, o) over the N drawn positions; 0 if no position
   of l is jointly feasible (the rule's fallbacks, `GridFallback`, do not apply here: a
   location with no joint grid point serves no dish).

`positions` chooses whose weights draw the positions of a merged location:

- "per_dish" (the paper's code): each dish's own Fea^m, as in 2. Each dish is then scored
  at its own best spots of the union, though the robot stops once for the whole group;
- "shared": the group's joint value, the product of its dishes' Fea^m (the chance that a
  stop there picks every one of them), and every dish is evaluated at the same drawn
  positions: a merge is as good as the stops that serve all of its dishes.

For a single dish the two are the same.
"""

from collections.abc import Sequence

import numpy as np

from s3o_drake.abstraction.location_grid import GridFallback, LocationGrid
from s3o_drake.world.choices import GROUP_POSITIONS


def _draw(weights: np.ndarray, u: np.ndarray) -> np.ndarray:
    """The indices that systematic resampling with offsets `u` draws by `weights` (> 0
    somewhere)."""
    cdf = np.cumsum(weights) / weights.sum()
    return np.minimum(np.searchsorted(cdf, u, side="right"), len(cdf) - 1)


class TaskFeasibility:
    """Fea^t of groups of dishes (a merged location = the union of the group's cells).

    Results are cached per group, so scoring many candidate partitions costs one
    evaluation per distinct group.
    """

    def __init__(self, grid: LocationGrid, *, samples: int, seed: int,
                 positions: str = "per_dish"):
        if positions not in GROUP_POSITIONS:
            raise ValueError(f"positions: expected one of {', '.join(GROUP_POSITIONS)}, "
                             f"got {positions!r}")
        self.grid = grid
        self.samples = samples
        self.seed = seed
        self.positions = positions
        self._cache: dict[tuple[int, ...], np.ndarray] = {}

    def of_group(self, group: Sequence[int]) -> np.ndarray:
        """Fea^t(l, o) for each dish o of the group (in sorted index order), l = its union."""
        key = tuple(sorted(group))
        cached = self._cache.get(key)
        if cached is not None:
            return cached
        names = [self.grid.names[i] for i in key]
        location = self.grid.location(names, names)
        result = np.zeros(len(key))
        if location.fallback is GridFallback.NONE:
            rng = np.random.default_rng([self.seed, len(key), *key])
            u = (rng.random() + np.arange(self.samples)) / self.samples
            if self.positions == "shared":
                drawn = _draw(np.where(location.joint, location.fea.prod(axis=0), 0.0), u)
                result[:] = location.fea[:, drawn].mean(axis=1)
            else:
                for k in range(len(key)):
                    drawn = _draw(np.where(location.joint, location.fea[k], 0.0), u)
                    result[k] = location.fea[k, drawn].mean()
        self._cache[key] = result
        return result

    def group_score(self, group: Sequence[int]) -> float:
        """Sum of Fea^t over the group's dishes: the group's share of the Score."""
        return float(self.of_group(group).sum())

    def score(self, groups: Sequence[Sequence[int]]) -> float:
        """Score = sum over dishes of Fea^t(l(o), o) for a partition into groups."""
        return float(sum(self.group_score(g) for g in groups))
