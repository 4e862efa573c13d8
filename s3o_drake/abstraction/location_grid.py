"""The location grid: the base positions a location stands for, and Fea^m at each of them.

A location is the union of some Voronoi cells (`voronoi.py`). Fea^t (`task_feasibility.py`),
the planner's representative points and the motion search's starting points and draws
(`planning/methods.py`, `planning/motion/grop.py`) all read a location through this grid:

- Lattice. The centres of a regular grid of `GRID_CELL` (5 cm), anchored at multiples of
  the cell so that the grids of different scenes and regions line up, over the bounding box
  of the dishes' reach discs. A point belongs to the cell that Sym maps it to
  (`VoronoiPartition.sym_many`: the nearest dish, within reach, in free space).
- Fea^m of every dish at every point is evaluated once, when the grid is built (once per
  plan, before the planner forks its search workers, which inherit it). Built with
  `drivable` (the planner's "a drive from the start reaches it"), Fea^m is 0 at points
  the base cannot reach: a dish picked there is not picked. Without it, a location whose
  best points lie mostly beyond a chair started every motion search there, and every
  search of every state space ended on an undrivable leg (dense task_015).
- `location(group, dishes)` gives the points of the group's cells, in the grid's fixed
  order, with the Fea^m of `dishes` there; cached per (group, dishes).

One joint-feasibility rule (`joint_feasible`): a point counts for a location when every
dish picked there has Fea^m > `threshold` at it (0 by default: some chance of each pickup),
as the paper's code scores a pixel of a merged cell only if all its objects are feasible
there. For a single dish it is plain "Fea^m > threshold". Its fallbacks (`GridFallback`)
are named because the readers differ on them:

- NOT_JOINT: the location has grid points but none is joint. Fea^t is 0 (no position serves
  the whole group); a motion search still needs positions, so its weight is the summed
  Fea^m over all the points.
- NO_POINT: the location holds no grid point (a sliver thinner than a cell). Fea^t is 0;
  the region's representative point stands in as its one point (none if the region is
  empty), so that a search can still start somewhere inside it.

A lone region (a motion search called without a plan's grid) gets the same lattice, rule
and fallbacks through `region_location`, with membership by containment in the region.
"""

from __future__ import annotations

import enum
from collections.abc import Callable, Sequence
from functools import cached_property, partial

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry
from shapely.ops import unary_union

from s3o_drake.abstraction.motion_feasibility import MotionFeasibility, as_motion_feasibility
from s3o_drake.abstraction.voronoi import GRID_CELL, Drivable, VoronoiPartition


def joint_feasible(fea: np.ndarray, threshold: float = 0.0) -> np.ndarray:
    """The joint-feasibility rule: which positions count for a location whose dishes have
    Fea^m `fea` (dishes, positions) there: those where every dish's Fea^m > `threshold`."""
    return np.all(np.asarray(fea) > threshold, axis=0)


class GridFallback(enum.Enum):
    """Which case of the joint-feasibility rule a location is in (module docstring)."""

    NONE = "none"
    """Some grid point is joint: the rule applies as stated."""
    NOT_JOINT = "not joint"
    """Grid points but no joint one: Fea^t 0; the motion search weighs all points."""
    NO_POINT = "no point"
    """No grid point (a sliver): Fea^t 0; the region's representative point stands in."""


def _lattice(low: np.ndarray, high: np.ndarray, cell: float) -> np.ndarray:
    """Cell centres (m, 2) covering [low, high), row by row (y outer, x inner)."""
    # Anchored at multiples of `cell`, so that grids over different boxes line up.
    start = np.floor(low / cell) * cell + cell / 2
    xs = np.arange(start[0], high[0], cell)
    ys = np.arange(start[1], high[1], cell)
    return np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)


class GridLocation:
    """One location's grid points and the Fea^m there of the dishes picked from it."""

    def __init__(self, points: np.ndarray, fea: np.ndarray, dishes: Sequence[str],
                 threshold: float, fallback_region: Callable[[], BaseGeometry],
                 sliver: bool):
        self.points = points
        """Positions (m, 2) in the grid's fixed order (NO_POINT: the representative point)."""
        self.fea = fea
        """Fea^m (len(dishes), m) of each dish at each point."""
        self.dishes = tuple(dishes)
        self.joint = joint_feasible(fea, threshold)
        """Whether each point counts: the joint-feasibility rule."""
        if sliver:
            self.fallback = GridFallback.NO_POINT
        elif self.joint.any():
            self.fallback = GridFallback.NONE
        else:
            self.fallback = GridFallback.NOT_JOINT
        # The motion search weighs a point by the summed Fea^m of the dishes picked there,
        # on the joint points, or on all of them when none is joint (NOT_JOINT).
        total = fea.sum(axis=0)
        self.weight = np.where(self.joint, total, 0.0) if self.joint.any() else total
        """The motion search's weight of each point (module docstring)."""
        self._fallback_region = fallback_region

    @cached_property
    def region(self) -> BaseGeometry:
        """The location's region: the union of its cells (built when first asked for)."""
        return self._fallback_region()

    def representative_point(self) -> np.ndarray:
        """A point inside the region (shapely's representative point)."""
        rp = self.region.representative_point()
        return np.array([rp.x, rp.y])


class LocationGrid:
    """The grid points of a set of cells, their cell, and Fea^m of the dishes at each
    (module docstring). Build it with `of` (a Voronoi partition) or through
    `region_location` (one region)."""

    def __init__(self, points: np.ndarray, owner: np.ndarray, cells: Sequence[BaseGeometry],
                 names: Sequence[str], source, dishes: Sequence[str], *,
                 threshold: float = 0.0, cell: float = GRID_CELL,
                 drivable: Drivable | None = None):
        if threshold < 0.0:
            raise ValueError(f"joint_threshold must be at least 0, got {threshold:g}")
        self.points = points
        """Positions (m, 2) that lie in some cell, in row-major grid order."""
        self.owner = owner
        """Cell index of each position."""
        self.cells = list(cells)
        self.names = list(names)
        """Each cell's name (a partition's cells are named by their dishes)."""
        self.source: MotionFeasibility = as_motion_feasibility(source)
        self.dishes = list(dishes)
        self.threshold = threshold
        self.cell = cell
        self._cell_index = {n: i for i, n in enumerate(self.names)}
        self._row = {d: i for i, d in enumerate(self.dishes)}
        self.fea = (np.stack([self.source.values(d, points) for d in self.dishes])
                    if self.dishes else np.zeros((0, len(points))))
        """Fea^m (dishes, m) at every point: evaluated once, here; 0 where `drivable`
        says the base cannot go (asked only where some dish has Fea^m > 0)."""
        if drivable is not None and self.fea.size:
            ask = np.flatnonzero((self.fea > 0).any(axis=0))
            if ask.size:
                self.fea[:, ask[~np.asarray(drivable(points[ask]), dtype=bool)]] = 0.0
        self._members = [np.flatnonzero(owner == i) for i in range(len(self.cells))]
        self._cache: dict[tuple, GridLocation] = {}
        self._regions: dict[tuple[int, ...], BaseGeometry] = {}

    @classmethod
    def of(cls, partition: VoronoiPartition, source, *, threshold: float = 0.0,
           cell: float = GRID_CELL, drivable: Drivable | None = None) -> LocationGrid:
        """The grid over a partition's cells, with Fea^m of all its dishes from `source`
        (a MotionFeasibility, a mapping dish -> Heatmap or a list of Heatmaps), 0 where
        `drivable` (points (m, 2) -> bool (m,); None: everywhere) says no."""
        if not partition.dishes:
            return cls(np.zeros((0, 2)), np.zeros(0, dtype=int), [], [], source, [],
                       threshold=threshold, cell=cell)
        low = partition.p_WO.min(axis=0) - partition.reach
        high = partition.p_WO.max(axis=0) + partition.reach
        if partition.claims:  # claimed positions may lie beyond `reach` of every dish
            x0, y0, x1, y1 = partition.bounds()
            low, high = np.minimum(low, [x0, y0]), np.maximum(high, [x1, y1])
        points = _lattice(low, high, cell)
        owner = partition.sym_many(points)
        keep = owner >= 0
        return cls(points[keep], owner[keep], partition.cells, partition.dishes, source,
                   partition.dishes, threshold=threshold, cell=cell, drivable=drivable)

    def region(self, group: Sequence[str]) -> BaseGeometry:
        """The union of the named cells."""
        key = tuple(sorted(self._cell_index[n] for n in group))
        if key not in self._regions:
            self._regions[key] = unary_union([self.cells[i] for i in key])
        return self._regions[key]

    def location(self, group: Sequence[str], dishes: Sequence[str] | None = None
                 ) -> GridLocation:
        """The location made of the named cells, with Fea^m of `dishes` (default: the
        cells' names, for a partition the group's own dishes) in that order."""
        dishes = tuple(group if dishes is None else dishes)
        cells = tuple(sorted(self._cell_index[n] for n in group))
        key = (cells, dishes)
        found = self._cache.get(key)
        if found is not None:
            return found
        rows = [self._row[d] for d in dishes]
        index = (np.sort(np.concatenate([self._members[i] for i in cells]))
                 if cells else np.zeros(0, dtype=int))
        names = [self.names[i] for i in cells]
        if len(index):
            points = self.points[index]
            fea = self.fea[np.ix_(rows, index)]
        else:
            region = self.region(names)
            points = np.zeros((0, 2)) if region.is_empty else \
                np.array(region.representative_point().coords[:1], dtype=float)
            fea = np.array([self.source.values(d, points) for d in dishes]) \
                .reshape(len(dishes), len(points))
        # A partial, not a lambda: a planning result that carries the grid stays picklable.
        found = GridLocation(points, fea, dishes, self.threshold,
                             partial(self.region, names), sliver=not len(index))
        self._cache[key] = found
        return found


def region_location(region: BaseGeometry, source, dishes: Sequence[str], *,
                    threshold: float = 0.0, cell: float = GRID_CELL) -> GridLocation:
    """One region's grid location for `dishes`: the plan's lattice over the region's
    bounding box, membership by containment (a motion search without a plan's grid)."""
    if region.is_empty:
        points = np.zeros((0, 2))
    else:
        x0, y0, x1, y1 = region.bounds
        points = _lattice(np.array([x0, y0]), np.array([x1, y1]), cell)
        points = points[shapely.contains_xy(region, points[:, 0], points[:, 1])]
    grid = LocationGrid(points, np.zeros(len(points), dtype=int), [region], ["region"],
                        source, dishes, threshold=threshold, cell=cell)
    return grid.location(["region"], dishes)
