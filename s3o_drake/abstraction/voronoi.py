"""The Voronoi partition of the free base-position space: one cell per dish.

Free space. A base position y is a candidate if the base standing there can be free of
the room's walls, the tables and the chairs the planner knows (the mapped chairs and the
ones it perceived: the KnownWorld's obstacles), and if some dish lies within `reach` of it.
Obstacles and walls are inflated by `clearance`, by default the base's *inscribed*
radius (`Robot.inscribed_radius`, half its width: the UR5e's 0.28 m), not its circumscribed
radius (`Robot.base_radius`, 0.418 m):

- closer than the inscribed radius, every yaw of the rectangular footprint collides, so
  nothing Fea^m could count is lost;
- the base faces the dish, so at a table its front (half its length: 0.31 m ahead)
  points at the edge; positions 0.31-0.42 m from the table are free and are among the
  best ones for reaching (the oracle tests stand 0.5 m from the edge with 0.1 m to
  spare). Inflating by the circumscribed radius would cut that band away from every cell.

Fea^m itself checks the real, rotated footprint, so positions in the 0.28-0.42 m band
that do collide get probability 0 there and weigh nothing in Fea^t. Pass
`clearance=robot.base_radius` for the conservative, yaw-independent reading of "inflated
by the base radius".

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
adjacency by the free cells' borders never let S3O merge them.)

Claims. Given Fea^m (`feasibility`), a dish that the positions of its own cell the robot
can drive to (`drivable`) pick at best with Fea^m below `CLAIM_BELOW` (or that has no cell)
claims the positions within the arm's reach that it can drive to and that pick it better,
and at least `CLAIM_SHARE` as well as the best of them: they leave their cells and become
its own, in place of the cell it had. Without claims every method left such a dish out as
unreachable, or picked it at long odds, though the robot could pick it from elsewhere:
task_032's bowl_1, whose own cell's free stops are boxed in by chairs, is picked at 0.87
from positions nearer a plate; task_055's plate_4 (0 in its own cell, 0.76 elsewhere). A
stop in another dish's cell need not serve both dishes, so merging does not help. A claim
takes nothing a cell needs: where a neighbour's only positions at or above `CLAIM_BELOW`
are among those claimed, they stay the neighbour's (S3O can still merge the two). A dish
whose cell is still empty is kept, with an empty cell, and listed in `unreachable`.
"""

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import shapely
from shapely.geometry import MultiPoint, Point, Polygon
from shapely.geometry.base import BaseGeometry
from shapely.ops import unary_union

from s3o_drake.abstraction.motion_feasibility import MotionFeasibility, as_motion_feasibility
from s3o_drake.belief.known_world import KnownWorld
from s3o_drake.feasibility.oracle import REACH_LIMIT
from s3o_drake.world.deadline import Deadline

ARM_REACH = REACH_LIMIT
"""How far (m) from a dish a base can stand and still pick it: the arm's full reach with a
side grasp, and a margin (the oracle's limit). A dish whose cell is empty within the
planner's `reach` gets its cell within this."""
ADJACENCY_MIN_LENGTH = 0.01
"""Cells touching along less than this (m) are not adjacent (a corner is not a border)."""
Drivable = Callable[[np.ndarray], np.ndarray]
"""Which base positions (m, 2) the robot can drive to: bool (m,)."""
CLAIM_BELOW = 0.5
"""A dish whose own cell picks it at best with Fea^m below this claims the positions that
pick it better (module docstring)."""
CLAIM_SHARE = 0.5
"""A claim takes the positions that pick its dish at least this share of the best Fea^m
of any it could claim."""
GRID_CELL = 0.05
"""Spacing (m) of the location grid (`location_grid.py`), on which claims read Fea^m too,
on the same anchors: a claimed square's centre is one of the location grid's points. The
heatmaps' resolution, finer than the base's landing noise (σ = 0.10 m), so nothing the
noise could tell apart is merged."""
_EMPTY_AREA = 1e-9  # m^2; cells smaller than this are empty


def free_space(known: KnownWorld, *, clearance: float | None = None) -> BaseGeometry:
    """Base positions clear of the walls, the tables and the chairs the robot knows
    (mapped and perceived; never the true unmapped ones) by `clearance` (default the
    robot's inscribed radius)."""
    return known.obstacles.free_space(known.robot.inscribed_radius if clearance is None
                                      else clearance)


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
    claims: list[tuple[int, BaseGeometry]] = field(default_factory=list)
    """(dish index, positions) claimed by a dish its own cell served poorly (module
    docstring), in the order they were made: a later claim wins where two meet. The claimed
    positions are the dish's cell; the rest of its Voronoi region belongs to no cell."""

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
        """Vectorised Sym by nearest dish, then the claims: cell index per point (m, 2), -1
        where none.

        Agrees with `sym` except on cell borders (measure zero).
        """
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        if not self.dishes:
            return np.full(len(points), -1)
        distances = np.linalg.norm(points[:, None, :] - self.p_WO[None, :, :], axis=-1)
        nearest = np.argmin(distances, axis=1)
        near = distances[np.arange(len(points)), nearest] <= self.reach
        free = shapely.contains_xy(self.free, points[:, 0], points[:, 1])
        owner = np.where(near & free, nearest, -1)
        for i, claimed in self.claims:
            owner[owner == i] = -1  # a claim replaces the cell that served its dish poorly
            owner[shapely.contains_xy(claimed, points[:, 0], points[:, 1])] = i
        return owner

    def bounds(self) -> tuple[float, float, float, float]:
        """The bounding box (m) of the non-empty cells: where Sym can answer."""
        return unary_union(self.cells).bounds


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
                      clearance: float | None = None, reach: float | None = None,
                      feasibility=None, drivable: Drivable | None = None,
                      deadline: Deadline | None = None) -> VoronoiPartition:
    """The Voronoi cells of the known world's dishes (default: all) over the free space.

    `clearance` defaults to the robot's inscribed radius (module docstring), `reach` to the
    planner's `reach`. With `feasibility` (Fea^m: a
    MotionFeasibility, a mapping dish -> Heatmap or a list of Heatmaps), a dish that its own
    cell serves poorly claims the positions that serve it better (module docstring); only
    positions where `drivable` (points (m, 2) -> bool (m,); None: all) holds count. No
    claim starts after `deadline` (None: none): a planner out of time plans on the cells
    as they are.
    """
    reach = known.planner.reach_for(known.robot) if reach is None else reach
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
    claims = [] if feasibility is None else \
        _claim(names, p_WO, cells, within, free, as_motion_feasibility(feasibility), drivable,
               deadline)
    return VoronoiPartition(dishes=names, p_WO=p_WO, cells=cells, free=free, reach=reach,
                            adjacency=_adjacency(within), claims=claims)


def lattice_in(geometry: BaseGeometry, step: float = GRID_CELL) -> np.ndarray:
    """The points (m, 2) inside `geometry` of the lattice of cell centres of spacing `step`
    anchored at multiples of it (the location grid's lattice)."""
    if geometry.is_empty:
        return np.zeros((0, 2))
    x0, y0, x1, y1 = geometry.bounds
    xs = np.arange(np.floor(x0 / step) * step + step / 2, x1, step)
    ys = np.arange(np.floor(y0 / step) * step + step / 2, y1, step)
    points = np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)
    return points[shapely.contains_xy(geometry, points[:, 0], points[:, 1])]


def _area(geometry: BaseGeometry) -> BaseGeometry:
    """The polygons of `geometry` (a difference or an intersection can leave lines and
    points beside them)."""
    if geometry.geom_type in ("Polygon", "MultiPolygon"):
        return geometry
    parts = [g for g in shapely.get_parts(geometry) if g.geom_type in ("Polygon", "MultiPolygon")]
    return unary_union(parts) if parts else Polygon()


def _claim(names: list[str], p_WO: np.ndarray, cells: list[BaseGeometry],
           within: list[BaseGeometry], free: BaseGeometry, fea: MotionFeasibility,
           drivable: Drivable | None, deadline: Deadline | None = None
           ) -> list[tuple[int, BaseGeometry]]:
    """Lets each dish that its cell serves poorly claim the positions that serve it better
    (module docstring); changes `cells` and `within` in place and returns the claims."""

    reached: dict[tuple[int, int], bool] = {}  # by lattice index: path queries are the cost

    def can_drive(points: np.ndarray) -> np.ndarray:
        """`drivable` on lattice points, each asked once."""
        if drivable is None:
            return np.ones(len(points), dtype=bool)
        keys = [tuple(k) for k in np.floor(points / GRID_CELL).astype(int)]
        ask = [n for n, k in enumerate(keys) if k not in reached]
        if ask:
            reached.update(zip([keys[n] for n in ask], drivable(points[ask]), strict=True))
        return np.array([reached[k] for k in keys], dtype=bool)

    def fea_at(dish: str, points: np.ndarray) -> np.ndarray:
        """Fea^m on lattice `points`, 0 where the base cannot drive to."""
        values = np.array(fea.values(dish, points), dtype=float)  # a copy: zeroed below
        positive = np.flatnonzero(values > 0)
        values[positive[~can_drive(points[positive])]] = 0.0
        return values

    def serves(dish: str, geometry: BaseGeometry) -> bool:
        """Whether a position of `geometry` that the robot can drive to picks `dish` at
        CLAIM_BELOW or better: the best first, a batch at a time (most cells answer in one)."""
        points = lattice_in(geometry)
        values = fea.values(dish, points)
        good = np.argsort(-values, kind="stable")[:int((values >= CLAIM_BELOW).sum())]
        return any(can_drive(points[good[k:k + 64]]).any() for k in range(0, len(good), 64))

    claims = []
    for i, name in enumerate(names):
        if deadline is not None and deadline.passed():
            break
        if serves(name, cells[i]):
            continue
        points = lattice_in(cells[i])
        own = float(fea_at(name, points).max()) if len(points) else 0.0
        points = lattice_in(Point(*p_WO[i]).buffer(ARM_REACH, quad_segs=32).intersection(free))
        values = fea_at(name, points)
        if not len(points) or values.max() <= own:
            continue  # nowhere better to pick it from
        # Where it is picked at odds like its best: a claim of every position with some
        # chance gave V-PETLON's random goals Fea^m 0.01 (task_032's bowl_1, best 0.87).
        points = points[(values > own) & (values >= CLAIM_SHARE * values.max())]
        half = GRID_CELL / 2
        squares = shapely.box(points[:, 0] - half, points[:, 1] - half,
                              points[:, 0] + half, points[:, 1] + half)
        claimed = _area(unary_union(squares).intersection(free))
        for j, cell in enumerate(cells):
            if j != i and cell.intersects(claimed) and serves(names[j], cell) \
                    and not serves(names[j], cell.difference(claimed)):
                claimed = _area(claimed.difference(cell))  # the neighbour's only good stops
        if claimed.area <= _EMPTY_AREA:
            continue
        for j in range(len(cells)):
            if j != i and within[j].intersects(claimed):  # a cell lies in its region
                cells[j] = _area(cells[j].difference(claimed))
                within[j] = _area(within[j].difference(claimed))
        # The claim replaces the cell (feasibility-blind draws, V-PETLON's, would land
        # there), and adds to the region that adjacency reads: S3O may still merge the dish
        # with the neighbours of its Voronoi region.
        cells[i] = claimed
        within[i] = _area(unary_union([within[i], claimed]))
        claims.append((i, claimed))
    return claims
