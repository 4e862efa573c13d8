"""A sound shortcut for the base collision check: far from everything means free.

Most base poses a heatmap asks about stand in the open, and for those the Drake collision
query (robot with its arm stowed against the whole scene) only confirms what plan-view
geometry already proves: if no obstacle comes within the robot's horizontal radius (plus the
checker's padding) of the base's centre, nothing can touch it. `BaseClearance` answers
"certainly free" from a distance field of the scene's footprints and walls, and for the
poses near furniture from the robot's plan extent turned to the pose's yaw
(`certainly_free_posed`: on a 40-dish task it leaves Drake 7,579 poses of 17,378);
everything else still goes to the `SceneGraphCollisionChecker`, so the answers are Drake's
own, only cheaper (tests compare them on random poses, and on poses next to furniture).

Soundness rests on two bounds, both computed rather than assumed:
- the robot's extent: the plan-view box of all its collision shapes' bounding boxes in the
  base's frame, with the arm stowed and the fingers open (from the plant), and its radius,
  the farthest corner of that box from the base's vertical axis;
- the field: the footprints of `s3o_drake.world.furniture` (the same numbers the plant is built
  from; a dish lies within its table's top) rasterised with every cell touching an obstacle
  marked, and the distance read at a point reduced by one cell diagonal.
"""

import math
from dataclasses import dataclass

import numpy as np
import shapely
from pydrake.geometry import Box, Capsule, Convex, Cylinder, Mesh, Role, Sphere

from s3o_drake.world.furniture import DistanceField
from s3o_drake.world.obstacles import Obstacles
from s3o_drake.world.robot import RobotInstances

#: Raster cell (m): fine enough that the one-cell-diagonal allowance costs little.
FIELD_RESOLUTION = 0.02
#: Extra distance (m) on top of radius and padding, for rounding in the shapes' poses.
SAFETY_MARGIN = 0.01
#: The signs (8, 3) of a box's corners about its centre.
BOX_SIGNS = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])


def _shape_half_extents(shape) -> np.ndarray:
    """Half extents of a shape's bounding box in its own frame."""
    if isinstance(shape, Box):
        return np.array([shape.width(), shape.depth(), shape.height()]) / 2
    if isinstance(shape, Cylinder):
        return np.array([shape.radius(), shape.radius(), shape.length() / 2])
    if isinstance(shape, Sphere):
        return np.full(3, shape.radius())
    if isinstance(shape, Capsule):
        return np.array([shape.radius(), shape.radius(), shape.length() / 2 + shape.radius()])
    raise TypeError(f"no bounding box for a {type(shape).__name__} collision shape")


def shape_corners(shape) -> np.ndarray:
    """Points (k, 3) in a shape's frame whose hull holds it: its bounding box's corners,
    or a mesh's convex hull's vertices (a maker's arm is meshes)."""
    if isinstance(shape, Mesh | Convex):
        hull = shape.GetConvexHull()
        return np.array([hull.vertex(i) for i in range(hull.num_vertices())])
    return BOX_SIGNS * _shape_half_extents(shape)


def robot_plan_extent(plant, scene_graph_inspector, placed: RobotInstances,
                      context) -> np.ndarray:
    """[x_lo, x_hi, y_lo, y_hi] (m) of the collision geometry of the robot `placed` in
    `plant` (all its model instances) in base_link's frame, with the arm stowed:
    bounding-box corners of every proximity shape."""
    robot = placed.robot
    placed.set_positions(context, robot.positions(
        0.0, 0.0, 0.0, arm=robot.arm_stow, gripper=robot.gripper_open))
    corners = []
    for body_index in placed.body_indices():
        body = plant.get_body(body_index)
        X_WB = plant.EvalBodyPoseInWorld(context, body)
        frame_id = plant.GetBodyFrameIdOrThrow(body_index)
        for geometry in scene_graph_inspector.GetGeometries(frame_id, Role.kProximity):
            X_BG = scene_graph_inspector.GetPoseInFrame(geometry)
            corners_G = shape_corners(scene_graph_inspector.GetShape(geometry))
            corners.append((X_WB @ X_BG).multiply(corners_G.T).T[:, :2])
    xy = np.vstack(corners)
    return np.array([xy[:, 0].min(), xy[:, 0].max(), xy[:, 1].min(), xy[:, 1].max()])


def robot_horizontal_radius(extent: np.ndarray) -> float:
    """Largest horizontal distance (m) of the robot's collision geometry from base_link's
    vertical axis: the farthest corner of its plan extent (`robot_plan_extent`)."""
    x_lo, x_hi, y_lo, y_hi = extent
    return float(math.hypot(max(-x_lo, x_hi), max(-y_lo, y_hi)))


class BaseClearance:
    """Which base positions are certainly collision-free (see the module docstring)."""

    def __init__(self, obstacles: Obstacles, *, robot_extent: np.ndarray, padding: float,
                 resolution: float = FIELD_RESOLUTION):
        """`robot_extent`: `robot_plan_extent`; `padding`: the collision checker's."""
        self.bounds = obstacles.room.bounds
        self._extent = np.asarray(robot_extent, dtype=float)
        robot_radius = robot_horizontal_radius(self._extent)
        # Where the posed test measures: the footprints, and the room shrunk by the gap
        # (the walls stand outside it).
        self._gap = padding + SAFETY_MARGIN
        self._obstacles = obstacles.union
        shapely.prepare(self._obstacles)
        self._inside = obstacles.room.buffer(-self._gap, join_style="mitre")
        shapely.prepare(self._inside)
        # A cell counts as occupied when any of it touches an obstacle.
        self._field = DistanceField.of(obstacles.union, self.bounds, resolution,
                                       grow=resolution / math.sqrt(2))
        self.required = robot_radius + padding + SAFETY_MARGIN + resolution * math.sqrt(2)
        """Field distance (m) beyond which a base position is certainly free."""

    def in_room(self, xy: np.ndarray) -> np.ndarray:
        """bool (n,): base positions inside the room's walls. Beyond them the walls' thin
        boxes leave free space that is not part of the world; the checks treat a base
        there as colliding."""
        xy = np.asarray(xy, dtype=float).reshape(-1, 2)
        x0, y0, x1, y1 = self.bounds
        return (xy[:, 0] > x0) & (xy[:, 0] < x1) & (xy[:, 1] > y0) & (xy[:, 1] < y1)

    def certainly_free(self, xy: np.ndarray) -> np.ndarray:
        """bool (n,) for base positions (n, 2): True only where no collision is possible."""
        return self._field.at(xy) > self.required

    def footprint(self, base: np.ndarray) -> shapely.Polygon:
        """The robot's plan extent (a rectangle, arm stowed) at base pose (x, y, yaw)."""
        return self._footprints(np.asarray(base, dtype=float).reshape(1, 3))[0]

    def contact(self, base: np.ndarray) -> tuple[float, float]:
        """Where a base at pose (x, y, yaw) that collides touches what it collides with, in
        plan view (a bumper's reading): the middle of its footprint's overlap with the
        furniture, else the nearest point of the furniture or the walls (a collision within
        the checker's padding overlaps nothing)."""
        footprint = self.footprint(base)
        overlap = footprint.intersection(self._obstacles)
        if not overlap.is_empty:
            return float(overlap.centroid.x), float(overlap.centroid.y)
        walls = shapely.box(*self.bounds).exterior
        things = walls if self._obstacles.is_empty else self._obstacles.union(walls)
        x, y = shapely.shortest_line(footprint, things).coords[1]
        return float(x), float(y)

    def _footprints(self, bases: np.ndarray) -> np.ndarray:
        x_lo, x_hi, y_lo, y_hi = self._extent
        local = np.array([[x_lo, y_lo], [x_hi, y_lo], [x_hi, y_hi], [x_lo, y_hi]])
        c, s = np.cos(bases[:, 2])[:, None], np.sin(bases[:, 2])[:, None]
        corners = np.stack([bases[:, :1] + c * local[:, 0] - s * local[:, 1],
                            bases[:, 1:2] + s * local[:, 0] + c * local[:, 1]], axis=-1)
        return shapely.polygons(corners)

    def certainly_free_posed(self, bases: np.ndarray) -> np.ndarray:
        """bool (n,) for base poses (n, 3): True only where no collision is possible at that
        yaw: the robot's plan extent, turned and placed, keeps more than the checker's
        padding (and SAFETY_MARGIN) from every footprint and inside the room. Plan-view
        distances bound the 3-D ones from below, so this is sound as `certainly_free` is,
        and it settles the poses near furniture that the radius cannot (a stop facing a
        table stands closer to it than the robot's corners reach)."""
        bases = np.asarray(bases, dtype=float).reshape(-1, 3)
        if not len(bases):
            return np.zeros(0, dtype=bool)
        footprints = self._footprints(bases)
        free = shapely.contains(self._inside, footprints)
        if not self._obstacles.is_empty:
            ask = np.flatnonzero(free)
            free[ask] = shapely.distance(footprints[ask], self._obstacles) > self._gap
        return free


#: Overlap (m) two shapes must have before they count as certainly touching: far above
#: rounding, far below any clearance that matters.
OVERLAP_MARGIN = 0.001
_VERTICAL = 1.0 - 1e-9


@dataclass(frozen=True)
class _Prism:
    """A collision shape that is a vertical prism: a box turned about z only (rectangle) or
    a cylinder standing upright (disk), between heights z_lo and z_hi."""

    center: np.ndarray  # (2,) in its frame (world, or the base's for the robot)
    angle: float  # rectangle: its x axis' angle in that frame
    half: np.ndarray  # rectangle: half sizes (2,); disk: (radius, radius)
    disk: bool
    z_lo: float
    z_hi: float

    @property
    def reach(self) -> float:
        return float(np.hypot(*self.half))


def _prism(shape, X) -> "_Prism | None":
    R = X.rotation().matrix()
    if abs(R[2, 2]) < _VERTICAL:
        return None
    p = X.translation()
    if isinstance(shape, Box):
        half_z = shape.height() / 2
        return _Prism(p[:2].copy(), math.atan2(R[1, 0], R[0, 0]),
                      np.array([shape.width(), shape.depth()]) / 2, False,
                      p[2] - half_z, p[2] + half_z)
    if isinstance(shape, Cylinder):
        half_z = shape.length() / 2
        return _Prism(p[:2].copy(), 0.0, np.full(2, shape.radius()), True,
                      p[2] - half_z, p[2] + half_z)
    return None


def _rect_axes(angle: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    c, s = np.cos(angle), np.sin(angle)
    return np.stack([c, s], -1), np.stack([-s, c], -1)


class CertainCollision:
    """Base poses at which the stowed robot certainly collides with the scene.

    Two solids certainly collide when their interiors overlap. For shapes that are vertical
    prisms (boxes turned about z only, upright cylinders; the robot's base body, pedestal and
    tray and the environment's walls, table tops and legs, chair seats and legs are), that
    is a positive overlap of their height intervals and of their plan-view rectangles or
    disks, tested exactly here (separating axes; disk against rectangle by distance).
    Other shapes are simply not used: the test only ever says "collides" when Drake would.
    """

    def __init__(self, robot: list[_Prism], environment: list[_Prism]):
        # Per environment rectangle, the robot's rectangles and disks whose heights overlap
        # it, as arrays: centre (k, 2) in the base frame, angle (k,), half sizes (k, 2).
        self.pairs: list[tuple[_Prism, dict[bool, tuple[np.ndarray, ...]]]] = []
        for e in environment:
            if e.disk:
                continue
            groups = {}
            for disk in (False, True):
                rs = [r for r in robot if r.disk == disk and
                      min(r.z_hi, e.z_hi) - max(r.z_lo, e.z_lo) > OVERLAP_MARGIN]
                if rs:
                    groups[disk] = (np.array([r.center for r in rs]),
                                    np.array([r.angle for r in rs]),
                                    np.array([r.half for r in rs]),
                                    np.array([r.reach for r in rs]))
            if groups:
                self.pairs.append((e, groups))
        self._reach = max((float(np.hypot(*r.center)) + r.reach for r in robot), default=0.0)

    @classmethod
    def of_scene(cls, plant, inspector, placed: RobotInstances,
                 context) -> "CertainCollision":
        """The vertical prisms of a plant's proximity geometry: those of the robot `placed`
        in it (all its model instances) with the arm stowed, in base_link's frame (the base
        at the origin), the rest in the world."""
        robot = placed.robot
        placed.set_positions(context, robot.positions(
            0.0, 0.0, 0.0, arm=robot.arm_stow, gripper=robot.gripper_open))
        mine = set(placed.instances)
        robot_prisms, env_prisms = [], []
        for geometry in inspector.GetAllGeometryIds(Role.kProximity):
            body = plant.GetBodyFromFrameId(inspector.GetFrameId(geometry))
            if body is None:
                continue
            X_WG = plant.EvalBodyPoseInWorld(context, body) @ inspector.GetPoseInFrame(geometry)
            prism = _prism(inspector.GetShape(geometry), X_WG)
            if prism is not None:
                ours = body.model_instance() in mine
                (robot_prisms if ours else env_prisms).append(prism)
        return cls(robot_prisms, env_prisms)

    def certainly_colliding(self, bases: np.ndarray) -> np.ndarray:
        """bool (n,) for base poses (n, 3): True only where the robot certainly collides."""
        bases = np.asarray(bases, dtype=float).reshape(-1, 3)
        out = np.zeros(len(bases), dtype=bool)
        for e, groups in self.pairs:
            rows = np.flatnonzero(~out & (np.hypot(*(bases[:, :2] - e.center).T)
                                          < self._reach + e.reach))
            if rows.size == 0:
                continue
            yaw = bases[rows, 2:3]
            c, s = np.cos(yaw), np.sin(yaw)  # (m, 1)
            hit = np.zeros(rows.size, dtype=bool)
            for disk, (p_BR, angle, half, reach) in groups.items():
                # The robot prisms' centres (m, k, 2) in the world at those base poses.
                center = bases[rows, None, :2] + np.stack(
                    [c * p_BR[:, 0] - s * p_BR[:, 1], s * p_BR[:, 0] + c * p_BR[:, 1]], -1)
                near = np.hypot(*np.moveaxis(center - e.center, -1, 0)) < reach + e.reach
                if not near.any():
                    continue
                m, k = np.nonzero(near)
                overlap = (_disk_in_rect(center[m, k], half[k, 0], e) if disk else
                           _rects_overlap(center[m, k], yaw[m, 0] + angle[k], half[k], e))
                hit[m[overlap]] = True
            out[rows[hit]] = True
        return out


def _disk_in_rect(center: np.ndarray, radius: np.ndarray, e: _Prism) -> np.ndarray:
    """Disks (n) of radii (n,) against one rectangle: interiors overlap by the margin."""
    u, v = _rect_axes(np.array(e.angle))
    d = center - e.center
    local = np.stack([d @ u, d @ v], -1)
    nearest = np.clip(local, -e.half, e.half)
    inside = np.all(np.abs(local) < e.half, axis=1)
    return inside | (np.hypot(*(local - nearest).T) < radius - OVERLAP_MARGIN)


def _rects_overlap(center: np.ndarray, angle: np.ndarray, half: np.ndarray,
                   e: _Prism) -> np.ndarray:
    """Separating-axis test of rectangles (n; half sizes (n, 2)) against one rectangle,
    with a margin. The four axes are the two rectangles' own; along each, the extents
    follow from the angle between them (|cos|, |sin|), written out per component: numpy's
    sums over pairs of coordinates cost more than the arithmetic."""
    delta = angle - e.angle
    c, s = np.abs(np.cos(delta)), np.abs(np.sin(delta))
    rc, rs = np.cos(angle), np.sin(angle)
    ec, es = math.cos(e.angle), math.sin(e.angle)
    dx, dy = e.center[0] - center[:, 0], e.center[1] - center[:, 1]
    h0, h1 = half[:, 0], half[:, 1]
    g0, g1 = float(e.half[0]), float(e.half[1])
    m = OVERLAP_MARGIN
    return ((np.abs(dx * rc + dy * rs) < h0 + g0 * c + g1 * s - m)  # robot's x axis
            & (np.abs(dy * rc - dx * rs) < h1 + g0 * s + g1 * c - m)  # robot's y axis
            & (np.abs(dx * ec + dy * es) < h0 * c + h1 * s + g0 - m)  # obstacle's x axis
            & (np.abs(dy * ec - dx * es) < h0 * s + h1 * c + g1 - m))  # obstacle's y axis
