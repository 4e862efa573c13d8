"""Task-level feasibility Fea^t(l, o) of a (possibly merged) location.

The motion-level source. Anything with `values(dish, points) -> Fea^m` per point
satisfies `MotionFeasibility`; `HeatmapFeasibility` serves it from `Heatmap` grids (the
Drake oracle's now, the FCN's later: both produce Heatmaps), with vectorised lookups.

How "N positions drawn from l weighted by Fea^m" is read here:

1. l is rasterised: the positions of l are the centres of a regular grid (cell
   `PositionGrid.cell`, 5 cm by default) that `Sym` maps into one of l's cells.
2. For dish o the weight of a position y is Fea^m(y, o) (the paper's Smp: "positions
   weighted by Fea^m(y_r, y_o)"), and 0 unless Fea^m(y, o') > `joint_threshold` for
   every dish o' of l's group: joint feasibility, as the paper's code scores a pixel of
   a merged cell only if all its objects are feasible there. With the default threshold
   0, a position counts if every dish of the group has some chance from it. For a
   single dish this is plain Fea^m weighting over its cell.
3. N positions are drawn from the normalised weights by *systematic* resampling: one
   uniform offset u ~ U[0, 1) from a generator seeded by (seed, the group's dish
   indices), then the positions at cumulative weights (u + k) / N, k = 0..N-1, in the
   grid's fixed order; the dishes of a group share u. It is an unbiased draw with far
   less variance than N independent draws, so candidates are not reordered by sampling
   noise, and it is deterministic given the seed and independent of which other
   candidates were scored before.
4. Fea^t(l, o) = the mean of Fea^m(y_k, o) over the N drawn positions; 0 if no position
   of l has positive weight.
"""

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

from s3o_drake.abstraction.voronoi import VoronoiPartition
from s3o_drake.feasibility.oracle import Heatmap

DEFAULT_GRID_CELL = 0.05  # m


@runtime_checkable
class MotionFeasibility(Protocol):
    """A source of Fea^m(y, o): the Drake oracle's heatmaps or the learned model."""

    def values(self, dish: str, points: np.ndarray) -> np.ndarray:
        """Fea^m at each base position of `points` (m, 2) for `dish`, in [0, 1]."""
        ...


class HeatmapFeasibility:
    """Fea^m read from one Heatmap per dish (0 outside a heatmap's grid)."""

    def __init__(self, heatmaps: Mapping[str, Heatmap] | Sequence[Heatmap]):
        if isinstance(heatmaps, Mapping):
            self.heatmaps = dict(heatmaps)
        else:
            self.heatmaps = {h.dish: h for h in heatmaps}

    def values(self, dish: str, points: np.ndarray) -> np.ndarray:
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        heatmap = self.heatmaps.get(dish)
        if heatmap is None:
            return np.zeros(len(points))
        j = np.floor((points[:, 0] - heatmap.x0) / heatmap.cell).astype(int)
        i = np.floor((points[:, 1] - heatmap.y0) / heatmap.cell).astype(int)
        rows, cols = heatmap.values.shape
        inside = (i >= 0) & (i < rows) & (j >= 0) & (j < cols)
        out = np.zeros(len(points))
        out[inside] = heatmap.values[i[inside], j[inside]]
        return out


def as_motion_feasibility(source) -> MotionFeasibility:
    """Accepts a MotionFeasibility, a mapping dish -> Heatmap, or a list of Heatmaps."""
    # A dict has a `values` attribute too: check for heatmap containers first.
    if isinstance(source, (Mapping, list, tuple)):
        return HeatmapFeasibility(source)
    if isinstance(source, MotionFeasibility):
        return source
    raise TypeError(f"not a Fea^m source: {type(source).__name__}")


@dataclass
class PositionGrid:
    """The rasterised cells: grid positions and the dish cell each one belongs to."""

    points: np.ndarray
    """Positions (m, 2) that lie in some cell, in row-major grid order."""
    owner: np.ndarray
    """Cell (dish index) of each position."""
    cell: float

    @classmethod
    def of(cls, partition: VoronoiPartition, cell: float = DEFAULT_GRID_CELL) -> "PositionGrid":
        """Grid centres over the reach discs' bounding box, kept where Sym is defined."""
        if not partition.dishes:
            return cls(np.zeros((0, 2)), np.zeros(0, dtype=int), cell)
        low = partition.p_WO.min(axis=0) - partition.reach
        high = partition.p_WO.max(axis=0) + partition.reach
        # Anchored at multiples of `cell`, so that grids of different scenes line up.
        start = np.floor(low / cell) * cell + cell / 2
        xs = np.arange(start[0], high[0], cell)
        ys = np.arange(start[1], high[1], cell)
        points = np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)
        owner = partition.sym_many(points)
        keep = owner >= 0
        return cls(points[keep], owner[keep], cell)


class TaskFeasibility:
    """Fea^t of groups of dishes (a merged location = the union of the group's cells).

    Results are cached per group, so scoring many candidate partitions costs one
    evaluation per distinct group.
    """

    def __init__(self, partition: VoronoiPartition, source, *, samples: int, seed: int,
                 joint_threshold: float = 0.0, grid_cell: float = DEFAULT_GRID_CELL):
        if joint_threshold < 0.0:
            raise ValueError(f"joint_threshold must be at least 0, got {joint_threshold:g}")
        self.partition = partition
        self.source = as_motion_feasibility(source)
        self.samples = samples
        self.seed = seed
        self.joint_threshold = joint_threshold
        self.grid = PositionGrid.of(partition, grid_cell)
        # Fea^m of every dish at every grid position of its possible groups: computed
        # once; a dish can only be grouped with cells reachable from the grid anyway.
        self._fea_m = np.stack([self.source.values(d, self.grid.points)
                                for d in partition.dishes]) if partition.dishes else \
            np.zeros((0, 0))
        self._members = [np.flatnonzero(self.grid.owner == i)
                         for i in range(len(partition.dishes))]
        self._cache: dict[tuple[int, ...], np.ndarray] = {}

    def of_group(self, group: Sequence[int]) -> np.ndarray:
        """Fea^t(l, o) for each dish o of the group (in sorted index order), l = its union."""
        key = tuple(sorted(group))
        cached = self._cache.get(key)
        if cached is not None:
            return cached
        index = np.concatenate([self._members[i] for i in key])
        result = np.zeros(len(key))
        if len(index):
            index.sort()  # the grid's fixed order, whatever the group's
            fea = self._fea_m[np.array(key)][:, index]  # (|group|, positions)
            joint = np.all(fea > self.joint_threshold, axis=0)
            if joint.any():
                rng = np.random.default_rng([self.seed, len(key), *key])
                u = (rng.random() + np.arange(self.samples)) / self.samples
                for k in range(len(key)):
                    weights = np.where(joint, fea[k], 0.0)
                    cdf = np.cumsum(weights) / weights.sum()
                    drawn = np.minimum(np.searchsorted(cdf, u, side="right"), len(cdf) - 1)
                    result[k] = fea[k, drawn].mean()
        self._cache[key] = result
        return result

    def group_score(self, group: Sequence[int]) -> float:
        """Sum of Fea^t over the group's dishes: the group's share of the Score."""
        return float(self.of_group(group).sum())

    def score(self, groups: Sequence[Sequence[int]]) -> float:
        """Score = sum over dishes of Fea^t(l(o), o) for a partition into groups."""
        return float(sum(self.group_score(g) for g in groups))
