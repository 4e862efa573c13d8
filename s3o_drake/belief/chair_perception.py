"""Finding the chairs the robot's map lacks in the overhead camera's depth image.

The honest rule: what the map explains is known; what rises above the floor and the map
does not explain is an unmapped obstacle. The map is the room's walls, the tables (with
the dishes on them), the mapped chairs and the robot at its start pose. The render labels
are not used to tell chairs from other things: the robot does not know which label is a
chair, and the depth image alone suffices.

Method, and why:

1. Every pixel is back-projected to the world point it sees (`camera.back_project`) and
   the points are binned into a top-view height grid over the room (cells of one camera
   pixel on the floor, 2 cm by default; the highest point wins). Working in the world
   rather than in the image undoes the perspective: a 0.9 m backrest seen 5 m off the
   optical axis appears 0.45 m displaced in the image but lands in its true cell here.
   (`RENDER_PIXEL_OFFSET` corrects a half-pixel shift between the renderer and
   `camera.back_project`.)
2. Cells the map explains (footprints grown by a small margin) are set aside; what is
   left above `OBSTACLE_HEIGHT` forms blobs (OpenCV connected components). Blobs close
   together are joined when the union still fits in one chair (`blobs`): seen from the
   side, the floor under a seat's edge is visible and can cut a chair's backrest off its
   seat. Tiny blobs are noise. A blob too large for one chair (touching chairs) is split
   into as many as its area holds (`blobs.split`).
3. Each blob's pose is fitted to the chair's known shape rather than read off its outline,
   because the outline is often incomplete: the backrest hides up to a quarter of the seat
   when the chair faces away from the image centre, and a table top hides the part of a
   chair near its edge. The cost has two sides. Every seen point of the blob must lie on
   the model's top view (seat, or backrest for the points above the seat). And no part of
   the model's top surface may stand in front of what the camera saw: a model point whose
   pixel shows something lower (farther along the ray) would have hidden it, and pays its
   distance to the blob. The test runs along the camera's rays, not straight down,
   because the camera does see the floor under a seat's edge from the side. Hidden parts
   thus cost nothing, and the visible ones pin the pose. The fit starts from the four axis
   directions of the blob's minimum-area rectangle (`cv2.minAreaRect`) and keeps the best
   (scipy's Powell minimiser); the backrest's points break the square seat's symmetry.

The yaw reported is the direction the seat faces (the scenario's Chair.pose convention):
away from the backrest.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import cv2
import numpy as np
from scipy.optimize import minimize

from s3o_drake.belief.blobs import blobs, split
from s3o_drake.belief.known_world import Briefing, KnownWorld, OverheadImages
from s3o_drake.world import furniture as fu
from s3o_drake.world.angles import wrap
from s3o_drake.world.camera import OverheadCamera, back_project, overhead_camera
from s3o_drake.world.map import Map
from s3o_drake.world.robot import Robot
from s3o_drake.world.settings import Camera

if TYPE_CHECKING:  # the truth, read only by perfect perception (tests, benchmarks)
    from s3o_drake.world.scenario import Scenario

OBSTACLE_HEIGHT = 0.10
"""Anything higher above the floor (m) that the map does not explain is an obstacle."""
FREE_TOLERANCE = 0.05
"""A model point conflicts with a pixel that sees more than this (m) below it."""
MAP_MARGIN = 0.03
"""Growth of the map's footprints (m) when explaining cells: absorbs edge cells."""
ROBOT_MARGIN = 0.08
"""Growth of the robot's footprint (m): the stowed arm and the lidar stay inside it."""
MIN_BLOB_AREA = 0.02
"""Blobs smaller than this (m^2) are noise; a chair's seat alone is 0.18 m^2."""
SEAT_LEVEL = 0.55
"""Points below this height (m) may be seat or the backrest's foot; above, backrest only."""
RENDER_PIXEL_OFFSET = 0.5
"""Pixels: RenderEngineVtk's pixel (u, v) shows the ray that `camera.back_project` assigns
to (u + 0.5, v + 0.5). Measured by matching the rendered table tops to their footprints
(the mismatch is least at exactly half a pixel, in both axes); uncorrected, every world
point is off by half a pixel, about 1 cm, towards the image's top-left (north-west)."""
EXPLAINED = 0.001
"""A fit whose cost (m², squared distances summed over the blob's points and the model's
points that the camera saw through) is below this explains what the camera saw: the other
directions' fits are not tried. Fits ended at 0 to 0.0022 (the chair, to the camera's
noise) or at 4.4 to 11.7 (a wrong direction) on 18 chairs of three tasks. On the perception
benchmark's 20 tasks (120 chairs) this keeps the accuracy of trying all four directions
(centre error p95 0.0085 m, yaw p95 0.0081 rad against 0.0077) at 0.54 s a scene instead of
1.44 s; at 0.01 the worst yaw grew to 0.05 rad."""


@dataclass(frozen=True)
class ChairModel:
    """The chair's top view in its own frame (x from the back to the front of the seat).

    `seat` and `back` are [x_min, x_max, y_min, y_max] rectangles (m) of what a camera
    straight above sees: the seat, and the tilted backrest's front face and top.
    """

    seat: tuple[float, float, float, float]
    back: tuple[float, float, float, float]
    back_profile: tuple[tuple[float, ...], tuple[float, ...]]
    """Height (m) of the backrest's top view along the chair's x: (x values, heights)."""

    @classmethod
    def from_furniture(cls) -> ChairModel:
        """The rectangles from the furniture dimensions the world builder uses."""
        half_d, half_w = fu.CHAIR_SEAT_DEPTH / 2, fu.CHAIR_SEAT_WIDTH / 2
        back_x, back_z = fu.chair_back_offset()
        c, s = math.cos(fu.CHAIR_BACK_TILT), math.sin(fu.CHAIR_BACK_TILT)
        half_t, half_h = fu.CHAIR_BACK_THICKNESS / 2, fu.CHAIR_BACK_HEIGHT / 2
        # The backrest box's corners in the x-z plane; the top view spans their x range.
        base = fu.CHAIR_SEAT_HEIGHT
        corners = [(back_x + a * half_t * c - b * half_h * s,
                    base + back_z + a * half_t * s + b * half_h * c)
                   for a in (-1, 1) for b in (-1, 1)]
        xs = [x for x, _ in corners]
        # Seen from above: the front face rises from its bottom edge to its top edge, then
        # the top face reaches back to the rear top edge.
        rear_top, front_top, front_bottom = corners[1], corners[3], corners[2]
        profile = tuple(zip(rear_top, front_top, front_bottom, strict=True))
        half_bw = fu.CHAIR_BACK_WIDTH / 2
        return cls(seat=(-half_d, half_d, -half_w, half_w),
                   back=(min(xs), max(xs), -half_bw, half_bw), back_profile=profile)

    def heights(self, p_C: np.ndarray) -> np.ndarray:
        """Height (m) of the top surface over points (n, 2) of the top view (chair frame)."""
        back = (_rect_distance(p_C, self.back) == 0.0) & (p_C[:, 0] < self.back[1])
        z = np.full(len(p_C), fu.CHAIR_SEAT_HEIGHT)
        z[back] = np.maximum(np.interp(p_C[back, 0], *self.back_profile),
                             fu.CHAIR_SEAT_HEIGHT)
        return z

    def corners(self) -> np.ndarray:
        """The corners (8, 2) of the seat's and the backrest's rectangles (chair frame): the
        top view's extreme points."""
        return np.array([(x, y) for x0, x1, y0, y1 in (self.seat, self.back)
                         for x in (x0, x1) for y in (y0, y1)])

    def samples(self, spacing: float) -> np.ndarray:
        """Points (n, 2) on a lattice covering the top view, in the chair frame."""
        points = []
        for x0, x1, y0, y1 in (self.seat, self.back):
            xs = np.arange(x0 + spacing / 2, x1, spacing)
            ys = np.arange(y0 + spacing / 2, y1, spacing)
            gx, gy = np.meshgrid(xs, ys)
            points.append(np.stack([gx.ravel(), gy.ravel()], axis=1))
        return np.concatenate(points)


def placement_error(true_pose: Sequence[float], found_pose: Sequence[float],
                    model: ChairModel | None = None) -> float:
    """The most (m) any point of a chair's top view lies from where it truly is, the chair
    perceived at `found_pose` (x, y, yaw) instead of `true_pose`: a planar motion moves
    the points of a polygon furthest at one of its corners."""
    corners = (model or ChairModel.from_furniture()).corners()
    return float(np.max(np.linalg.norm(
        _to_world(corners, np.asarray(found_pose, dtype=float))
        - _to_world(corners, np.asarray(true_pose, dtype=float)), axis=1)))


def _rect_distance(p: np.ndarray, rect: tuple[float, float, float, float]) -> np.ndarray:
    """Distance (m) of points (n, 2) to an axis-aligned rectangle; 0 inside."""
    x0, x1, y0, y1 = rect
    dx = np.maximum(np.maximum(x0 - p[:, 0], p[:, 0] - x1), 0.0)
    dy = np.maximum(np.maximum(y0 - p[:, 1], p[:, 1] - y1), 0.0)
    return np.hypot(dx, dy)


def _to_chair_frame(p_W: np.ndarray, pose: np.ndarray) -> np.ndarray:
    c, s = math.cos(pose[2]), math.sin(pose[2])
    d = p_W - pose[:2]
    return np.stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]], axis=1)


def _to_world(p_C: np.ndarray, pose: np.ndarray) -> np.ndarray:
    c, s = math.cos(pose[2]), math.sin(pose[2])
    return np.stack([c * p_C[:, 0] - s * p_C[:, 1] + pose[0],
                     s * p_C[:, 0] + c * p_C[:, 1] + pose[1]], axis=1)


@dataclass(frozen=True)
class HeightGrid:
    """A top-view grid over the room: row 0 at the north edge (y_max), column 0 at x_min."""

    x_min: float
    y_max: float
    cell: float
    height: np.ndarray
    """Highest point seen in each cell (m); NaN where no pixel lands (unknown)."""

    def cell_of(self, p_W: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(row, col) integer indices of points (n, 2); may fall outside the grid."""
        col = np.floor((p_W[:, 0] - self.x_min) / self.cell).astype(int)
        row = np.floor((self.y_max - p_W[:, 1]) / self.cell).astype(int)
        return row, col

    def polygon_cells(self, polygon) -> np.ndarray:
        """Integer (k, 1, 2) vertex array of a shapely polygon in (col, row) for cv2."""
        xy = np.asarray(polygon.exterior.coords)
        return np.stack([(xy[:, 0] - self.x_min) / self.cell,
                         (self.y_max - xy[:, 1]) / self.cell], axis=1).round().astype(
                             np.int32).reshape(-1, 1, 2)


def world_points(camera: OverheadCamera, depth: np.ndarray) -> np.ndarray:
    """The world points (n, 3) the depth image's pixels see; pixels without a return are
    dropped. Corrects `back_project` by `RENDER_PIXEL_OFFSET`."""
    depth = np.asarray(depth, dtype=float)
    p_W = back_project(camera, depth)
    # Half a pixel along the camera's x (world +x) and y (world -y) at each point's depth.
    half = RENDER_PIXEL_OFFSET * depth / camera.focal
    p_W[..., 0] += half
    p_W[..., 1] -= half
    p_W = p_W.reshape(-1, 3)
    return p_W[np.isfinite(p_W).all(axis=1)]


def height_grid(points: np.ndarray, bounds: list[float], cell: float) -> HeightGrid:
    """Bins world points (n, 3) into a top-view grid of highest points.

    When the cell is about a pixel's footprint the two lattices beat against each other
    and leave lines of empty cells one cell wide; such a cell, seen on both sides along a
    row or a column, takes the higher of those two neighbours (a shadow behind something
    tall is wider and stays unknown).
    """
    x_min, y_min, x_max, y_max = bounds
    cols = math.ceil((x_max - x_min) / cell)
    rows = math.ceil((y_max - y_min) / cell)
    grid = HeightGrid(x_min=x_min, y_max=y_max, cell=cell,
                      height=np.full((rows, cols), -np.inf))
    row, col = grid.cell_of(points[:, :2])
    inside = (row >= 0) & (row < rows) & (col >= 0) & (col < cols)
    np.maximum.at(grid.height, (row[inside], col[inside]), points[inside, 2])
    h = grid.height
    h[np.isneginf(h)] = np.nan
    padded = np.pad(h, 1, constant_values=np.nan)
    fill = np.full_like(h, np.nan)
    for before, after in ((padded[1:-1, :-2], padded[1:-1, 2:]),
                          (padded[:-2, 1:-1], padded[2:, 1:-1])):
        both = np.isfinite(before) & np.isfinite(after)
        fill = np.where(both, np.fmax(fill, np.fmax(before, after)), fill)
    gap = np.isnan(h) & np.isfinite(fill)
    h[gap] = fill[gap]
    return grid


#: A perception function: (colour RGBA, depth (m), label) images -> chair poses [x, y, yaw].
Perceive = Callable[[np.ndarray, np.ndarray, np.ndarray], list[list[float]]]

class ChairPerception:
    """Finds the unmapped chairs in the overhead images: `__call__(color, depth, label)`.

    Constructed with what the robot knows: its map (the room, the tables, the mapped
    chairs), the camera's settings, and where the robot stands. It is never given the true
    world's unmapped chairs. Returns the chairs' poses [x, y, yaw] (the seat's centre and
    the direction it faces), sorted by x then y so that the output does not depend on blob
    numbering.
    """

    def __init__(self, map: Map, camera: Camera, *, pose: Sequence[float], robot: Robot,
                 cell: float | None = None):
        """`pose`: where `robot` stands, (x, y, yaw); its own pixels are explained by it.
        `cell`: the top-view grid's cell (m); default one camera pixel on the floor."""
        self._camera = overhead_camera(map.room, camera)
        if cell is None:
            cell = camera.height / self._camera.focal
        self._bounds = list(map.room.bounds)
        self._cell = cell
        self._model = ChairModel.from_furniture()
        self._samples = self._model.samples(cell)
        self._sample_heights = self._model.heights(self._samples)
        # The map's footprints; the room's walls are outside the grid, plus a rim of cells.
        shapes = [fu.table_footprint(t.center, t.yaw, t.size).buffer(MAP_MARGIN)
                  for t in map.tables]
        shapes += [fu.chair_footprint(c.pose).buffer(MAP_MARGIN) for c in map.chairs]
        shapes.append(robot.footprint(*pose).buffer(ROBOT_MARGIN))
        self._map_shapes = shapes
        self._explained: np.ndarray | None = None

    def explained(self, grid: HeightGrid) -> np.ndarray:
        """Cells (bool, grid-shaped) that the map explains; computed once per grid shape."""
        if self._explained is not None and self._explained.shape == grid.height.shape:
            return self._explained
        mask = np.zeros(grid.height.shape, dtype=np.uint8)
        for shape in self._map_shapes:
            polygons = getattr(shape, "geoms", [shape])
            for polygon in polygons:
                cv2.fillPoly(mask, [grid.polygon_cells(polygon)], 1)
        rim = max(1, round(MAP_MARGIN / grid.cell))
        mask[:rim, :] = mask[-rim:, :] = 1
        mask[:, :rim] = mask[:, -rim:] = 1
        self._explained = mask.astype(bool)
        return self._explained

    def __call__(self, color: np.ndarray, depth: np.ndarray, label: np.ndarray
                 ) -> list[list[float]]:
        """Poses [x, y, yaw] of the chairs the map lacks. `color` and `label` are accepted
        for the planner's port layout; the depth image (H, W) or (H, W, 1) carries the
        information used."""
        del color, label  # see the module docstring: depth and the map suffice
        depth = np.asarray(depth, dtype=np.float32)
        if depth.ndim == 3:
            depth = depth[:, :, 0]
        if depth.shape != (self._camera.height, self._camera.width):
            raise ValueError(f"depth: expected shape {(self._camera.height, self._camera.width)}"
                             f", got {depth.shape}")
        points = world_points(self._camera, depth)
        grid = height_grid(points, self._bounds, self._cell)
        explained = self.explained(grid)
        seen = np.isfinite(grid.height)
        obstacle = seen & (np.nan_to_num(grid.height) > OBSTACLE_HEIGHT) & ~explained
        # Distance (m) from each cell to the nearest obstacle cell: what a model point
        # that hides something the camera saw pays.
        to_obstacle = cv2.distanceTransform((~obstacle).astype(np.uint8), cv2.DIST_L2,
                                            cv2.DIST_MASK_PRECISE) * grid.cell
        # Height of what each pixel sees (the optical axis is vertical).
        seen_z = self._camera.X_WC.translation()[2] - np.where(np.isfinite(depth), depth, 0.0)
        labels = blobs(obstacle, grid.cell)
        # The data term uses the raw points (exact positions, not cell centres): each
        # obstacle point belongs to the blob of its cell.
        row, col = grid.cell_of(points[:, :2])
        rows, cols = grid.height.shape
        inside = (row >= 0) & (row < rows) & (col >= 0) & (col < cols)
        inside[inside] &= obstacle[row[inside], col[inside]]
        inside &= points[:, 2] > OBSTACLE_HEIGHT
        blob_points = points[inside]
        point_labels = labels[row[inside], col[inside]]
        poses = []
        min_cells = MIN_BLOB_AREA / grid.cell**2
        for k in range(1, labels.max() + 1):
            cells = np.count_nonzero(labels == k)
            if cells < min_cells:
                continue
            # Touching chairs make one blob: split into the chairs its area holds.
            for part in split(blob_points[point_labels == k], cells * grid.cell**2):
                poses.append(self._fit(part, grid, seen_z, to_obstacle))
        return sorted(poses)

    def _cost(self, pose: np.ndarray, points: np.ndarray, high: np.ndarray, grid: HeightGrid,
              seen_z: np.ndarray, to_obstacle: np.ndarray) -> float:
        p_C = _to_chair_frame(points[:, :2], pose)
        d_back = _rect_distance(p_C, self._model.back)
        d_any = np.minimum(_rect_distance(p_C, self._model.seat), d_back)
        data = np.where(high, d_back, d_any)
        # Model points in front of what their pixel saw: each pays its distance to the blob.
        p_W = _to_world(self._samples, pose)
        u, v = self._pixels(p_W, self._sample_heights)
        rows, cols = seen_z.shape
        inside = (u >= 0) & (u < cols) & (v >= 0) & (v < rows)
        hides = np.zeros(len(p_W), dtype=bool)
        hides[inside] = seen_z[v[inside], u[inside]] < self._sample_heights[inside] - FREE_TOLERANCE
        row, col = grid.cell_of(p_W[hides])
        g_rows, g_cols = to_obstacle.shape
        ok = (row >= 0) & (row < g_rows) & (col >= 0) & (col < g_cols)
        free = to_obstacle[row[ok], col[ok]]
        return float(np.sum(data**2) + np.sum(free**2))

    def _pixels(self, p_W: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The rendered pixel (column u, row v) that sees world points (n, 2) at heights z."""
        cam = self._camera
        centre = cam.X_WC.translation()
        scale = cam.focal / (centre[2] - z)
        # Camera x is world x and camera y is world -y (camera.overhead_camera).
        u = cam.width / 2 - 0.5 + scale * (p_W[:, 0] - centre[0]) - RENDER_PIXEL_OFFSET
        v = cam.height / 2 - 0.5 - scale * (p_W[:, 1] - centre[1]) - RENDER_PIXEL_OFFSET
        return np.round(u).astype(int), np.round(v).astype(int)

    def _fit(self, points: np.ndarray, grid: HeightGrid, seen_z: np.ndarray,
             to_obstacle: np.ndarray) -> list[float]:
        """The chair pose that best explains one blob's points (see the module docstring)."""
        high = points[:, 2] > SEAT_LEVEL
        (cx, cy), _, angle = cv2.minAreaRect(points[:, :2].astype(np.float32))
        theta = math.radians(angle)
        # The top view's centre lies behind the seat's centre (the backrest sticks out at
        # the back only); start each direction's fit from where the seat would then be.
        shift = -(self._model.back[0] + self._model.seat[1]) / 2
        best = None
        for k in range(4):
            # All four directions of the rectangle: the backrest's points decide which
            # one fits, and a start per direction keeps Powell out of the wrong basin.
            yaw = float(wrap(theta + k * math.pi / 2))
            start = np.array([cx + shift * math.cos(yaw), cy + shift * math.sin(yaw), yaw])
            result = minimize(self._cost, start, args=(points, high, grid, seen_z, to_obstacle),
                              method="Powell",
                              options={"xtol": 1e-3, "ftol": 1e-7, "maxfev": 2000})
            if best is None or result.fun < best[0]:
                best = (result.fun, result.x)
            if best[0] < EXPLAINED:
                break
        x, y, yaw = best[1]
        return [float(x), float(y), float(wrap(float(yaw)))]


def perceived_chairs(given: Briefing, images: tuple[np.ndarray, np.ndarray, np.ndarray]
                     ) -> list[list[float]]:
    """The unmapped chairs found in (color, depth, label) overhead images, by a robot
    `given` its map and settings, standing at its start."""
    color, depth, label = images
    return ChairPerception(given.map, given.settings.camera, pose=given.start,
                           robot=given.robot)(color, depth,
                                                                               label)


def scenario_unmapped_chairs(scenario: Scenario) -> Perceive:
    """Perfect perception, for tests and comparisons: the scenario's unmapped chairs
    exactly, whatever the images show."""
    chairs = [list(map(float, c.pose)) for c in scenario.chairs if not c.mapped]
    return lambda color, depth, label: [list(c) for c in chairs]


def perceive_known_world(given: Briefing, images: tuple[np.ndarray, np.ndarray, np.ndarray],
                         *, pose: Sequence[float], dishes: Sequence[str],
                         perceive: Perceive | None = None,
                         robot_labels: frozenset[int] = frozenset(),
                         held: str = "") -> KnownWorld:
    """What the robot knows, standing at `pose` with `dishes` left (`held`, one of them,
    in the gripper), from the overhead (color, depth, label) images: what it was `given`
    (its map, the settings, the task's objects), the chairs perception finds (`perceive`,
    default ChairPerception from where the robot stands), and the images the learned Fea^m
    reads (`robot_labels`: the robot's own pixels)."""
    color, depth, label = images
    depth = np.asarray(depth)[..., 0] if np.ndim(depth) == 3 else np.asarray(depth)
    label = np.asarray(label)[..., 0] if np.ndim(label) == 3 else np.asarray(label)
    find = perceive or ChairPerception(given.map, given.settings.camera, pose=pose,
                                       robot=given.robot)
    chairs = find(color, depth, label)
    return KnownWorld.of(given, perceived_chairs=chairs, pose=pose, dishes=dishes,
                         held=held, overhead=OverheadImages(depth=depth, label=label,
                                                 robot_labels=robot_labels))
