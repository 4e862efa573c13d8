"""The Voronoi partition of the free base-position space: one cell per dish.

Free space. A base position y is a candidate if the base standing there can be free of
the room's walls, the tables and the chairs the planner knows (the mapped chairs and the
ones it perceived: the KnownWorld's obstacles), and if some dish lies within `reach` of it.
Obstacles and walls are inflated by `clearance`, by default the base's *inscribed*
radius BASE_WIDTH / 2 = 0.28 m, not its circumscribed radius BASE_RADIUS = 0.418 m:

- closer than the inscribed radius, every yaw of the rectangular footprint collides, so
  nothing Fea^m could count is lost;
- the base faces the dish, so at a table its front (BASE_LENGTH / 2 = 0.31 m ahead)
  points at the edge; positions 0.31-0.42 m from the table are free and are among the
  best ones for reaching (the oracle tests stand 0.5 m from the edge with 0.1 m to
  spare). Inflating by BASE_RADIUS would cut that band away from every cell.

Fea^m itself checks the real, rotated footprint, so positions in the 0.28-0.42 m band
that do collide get probability 0 there and weigh nothing in Fea^t. Pass
`clearance=BASE_RADIUS` for the conservative, yaw-independent reading of "inflated by
the base radius".

Cells. Dish o's cell is the free positions within `reach` of o that are closer to o than
to any other dish. (A position closer to o than to a dish d within reach of it is also
within reach of o, so "within reach of some dish" and "within reach of o" agree inside
o's Voronoi region.) The planner's `reach` (the paper's 1 m) is shorter than the arm's
(about 1.35 m with a side grasp): a dish whose region has no free position within `reach`
gets the free positions of its region within `ARM_REACH` instead, where Fea^m decides.
Cells are built with `shapely.voronoi_polygons` and clipped. Two
dishes with cells are adjacent when their Voronoi regions, within the radius their cells
were cut with, share a boundary longer than `ADJACENCY_MIN_LENGTH`: an obstacle between the
free cells does not keep them apart, since a stop in either may serve both. (On
task_002 a chair splits the floor in front of a cup and a plate on the bar: the cup's own
cell has Fea^m 0 everywhere, the plate's holds the only stops that pick the cup, and
adjacency by the free cells' borders never let S3O merge them.) A dish whose cell is still
empty is kept, with an empty cell, and listed in `unreachable`.
"""

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import shapely
from shapely.geometry import MultiPoint, Point, Polygon
from shapely.geometry.base import BaseGeometry
from shapely.ops import unary_union

from s3o_drake.feasibility.oracle import REACH_LIMIT
from s3o_drake.known_world import KnownWorld
from s3o_drake.robot import INSCRIBED_RADIUS

ARM_REACH = REACH_LIMIT
"""How far (m) from a dish a base can stand and still pick it: the arm's full reach with a
side grasp, and a margin (the oracle's limit). A dish whose cell is empty within the
planner's `reach` gets its cell within this."""
ADJACENCY_MIN_LENGTH = 0.01
"""Cells touching along less than this (m) are not adjacent (a corner is not a border)."""
_EMPTY_AREA = 1e-9  # m^2; cells smaller than this are empty


def free_space(known: KnownWorld, *, clearance: float = INSCRIBED_RADIUS) -> BaseGeometry:
    """Base positions clear of the walls, the tables and the chairs the robot knows
    (mapped and perceived; never the true unmapped ones) by `clearance`."""
    return known.obstacles.free_space(clearance)


@dataclass
class VoronoiPartition:
    """One cell per dish over the free, reachable base positions, and their adjacency."""

    dishes: list[str]
    p_WO: np.ndarray  # noqa: N815 (monogram notation)
    """Dish positions in the world, shape (n, 2)."""
    cells: list[BaseGeometry]
    """Cell of each dish (possibly empty), in the order of `dishes`."""
    free: BaseGeometry
    """The free base-position space (before the reach limit)."""
    reach: float
    adjacency: list[set[int]] = field(default_factory=list)
    """adjacency[i]: indices of the dishes whose cells share a border with cell i."""

    @property
    def unreachable(self) -> list[str]:
        """Dishes that no free base position within reach serves: empty cells."""
        return [d for d, c in zip(self.dishes, self.cells, strict=True) if c.area <= _EMPTY_AREA]

    def reachable_free(self) -> BaseGeometry:
        """Free positions within reach of some dish: the union of the cells."""
        return unary_union(self.cells)

    def edges(self) -> list[tuple[int, int]]:
        """Adjacent pairs (i < j), sorted."""
        return sorted((i, j) for i, js in enumerate(self.adjacency) for j in js if i < j)

    def sym(self, p: Sequence[float]) -> int | None:
        """Index of the dish whose cell holds position p, or None (not free or too far).

        On a shared border the lower index wins, so every position has one answer.
        """
        point = Point(float(p[0]), float(p[1]))
        for i, cell in enumerate(self.cells):
            if cell.area > _EMPTY_AREA and cell.covers(point):
                return i
        return None

    def sym_many(self, points: np.ndarray) -> np.ndarray:
        """Vectorised Sym by nearest dish: cell index per point (m, 2), -1 where none.

        Agrees with `sym` except on cell borders (measure zero).
        """
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        if not self.dishes:
            return np.full(len(points), -1)
        distances = np.linalg.norm(points[:, None, :] - self.p_WO[None, :, :], axis=-1)
        nearest = np.argmin(distances, axis=1)
        near = distances[np.arange(len(points)), nearest] <= self.reach
        free = shapely.contains_xy(self.free, points[:, 0], points[:, 1])
        return np.where(near & free, nearest, -1)


def _voronoi_regions(p_WO: np.ndarray, envelope: Polygon) -> list[BaseGeometry]:
    """The Voronoi region of each point, clipped to `envelope`, in the points' order."""
    if len(p_WO) == 1:
        return [envelope]
    regions = shapely.voronoi_polygons(MultiPoint([tuple(p) for p in p_WO]), extend_to=envelope)
    polygons = list(regions.geoms)
    result: list[BaseGeometry] = []
    for p in p_WO:
        point = Point(*p)
        owner = next(poly for poly in polygons if poly.covers(point))
        result.append(owner.intersection(envelope))
    return result


def _adjacency(cells: list[BaseGeometry]) -> list[set[int]]:
    """Which of `cells` (the dishes' regions within reach; empty for a dish without a free
    cell) share a border."""
    adjacency: list[set[int]] = [set() for _ in cells]
    nonempty = [i for i, c in enumerate(cells) if c.area > _EMPTY_AREA]
    for a_index, i in enumerate(nonempty):
        for j in nonempty[a_index + 1:]:
            if not cells[i].buffer(1e-6).intersects(cells[j]):
                continue
            shared = cells[i].boundary.intersection(cells[j].buffer(1e-6)).length
            if shared > ADJACENCY_MIN_LENGTH:
                adjacency[i].add(j)
                adjacency[j].add(i)
    return adjacency


def voronoi_partition(known: KnownWorld, *, dishes: Sequence[str] | None = None,
                      clearance: float = INSCRIBED_RADIUS,
                      reach: float | None = None) -> VoronoiPartition:
    """The Voronoi cells of the known world's dishes (default: all) over the free space.

    `reach` defaults to the planner's `reach`.
    """
    reach = known.planner.reach if reach is None else reach
    by_name = {d.name: d for d in known.dishes}
    names = list(dishes) if dishes is not None else list(by_name)
    p_WO = np.array([by_name[n].position for n in names], dtype=float).reshape(-1, 2)
    free = free_space(known, clearance=clearance)
    envelope = known.obstacles.room
    regions = _voronoi_regions(p_WO, envelope) if len(names) else []
    cells, within = [], []
    for p, region in zip(p_WO, regions, strict=True):
        cell = Polygon()
        # Within `reach` first; a dish with nothing free there gets its region's free
        # positions within the arm's full reach (Voronoi regions are disjoint, so the cells
        # still partition the space).
        for radius in (reach, max(reach, ARM_REACH)):
            near = region.intersection(Point(*p).buffer(radius, quad_segs=32))
            cell = near.intersection(free)
            if cell.area > _EMPTY_AREA:
                break
        cells.append(cell if cell.area > _EMPTY_AREA else Polygon())
        within.append(near if cell.area > _EMPTY_AREA else Polygon())
    return VoronoiPartition(dishes=names, p_WO=p_WO, cells=cells, free=free, reach=reach,
                            adjacency=_adjacency(within))
