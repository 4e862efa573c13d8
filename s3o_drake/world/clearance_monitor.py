"""The robot's closest approach to the true world, measured in the simulation.

A run's plan keeps the base clear of what the robot knows; the simulation has the true
chairs and the robot's real motion, noise and all. The `ClearanceMonitor` reads the
simulation's SceneGraph every `period` and keeps the smallest signed distance between the
robot's collision geometry and that of the room's walls, the tables and the chairs (not
the dishes, which the gripper touches, nor the floor): the run's `closest_approach`.
Below zero, the robot was in collision with the world.
"""

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.geometry import (
    Box,
    Capsule,
    Convex,
    Cylinder,
    Ellipsoid,
    FrameId,
    GeometryId,
    Mesh,
    QueryObject,
    Role,
    SceneGraph,
    SceneGraphInspector,
    Sphere,
)
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import ModelInstanceIndex, RigidBody
from pydrake.systems.framework import (
    Context,
    Diagram,
    DiagramBuilder,
    DiscreteValues,
    EventStatus,
    LeafSystem,
    OutputPort,
)

from s3o_drake.world.robot import Robot
from s3o_drake.world.system_lifetime import weak_callback

REACH = 0.3
"""Pairs further apart than this (m) are not measured: the closest approach of a run is
never that large (a stop keeps a few centimetres from its table)."""
BOUND_MARGIN = 1e-3
"""A pair is measured unless a lower bound of its distance exceeds REACH by this much (m):
far more than the narrow phase's error, so that a pair left out would have measured more
than REACH."""


def proximity_geometries(plant: MultibodyPlant, scene_graph: SceneGraph,
                         instances: Iterable[ModelInstanceIndex], *,
                         world_names: Iterable[str] = (),
                         bodies: Iterable[RigidBody] = ()) -> frozenset[GeometryId]:
    """The collision (proximity) geometries of the bodies of `instances` and of `bodies`,
    and those of the world body whose names start with one of `world_names` (the walls)."""
    inspector = scene_graph.model_inspector()
    ids: set[GeometryId] = set()
    indices = [b for instance in instances for b in plant.GetBodyIndices(instance)]
    for body in [*indices, *(b.index() for b in bodies)]:
        ids.update(inspector.GetGeometries(plant.GetBodyFrameIdOrThrow(body), Role.kProximity))
    prefixes = tuple(world_names)
    if prefixes:
        frame = plant.GetBodyFrameIdOrThrow(plant.world_body().index())
        ids.update(g for g in inspector.GetGeometries(frame, Role.kProximity)
                   if inspector.GetName(g).split("::")[-1].startswith(prefixes))
    return frozenset(ids)


def room_geometries(plant: MultibodyPlant, scene_graph: SceneGraph,
                    furniture: Iterable[str]) -> frozenset[GeometryId]:
    """The collision geometries of the room's walls and of the `furniture` (model instance
    names: the tables and the chairs), which are fixed in the world (`NearPairs` reads their
    poses once). ValueError naming a piece of furniture that could move."""
    instances = [plant.GetModelInstanceByName(name) for name in furniture]
    for instance in instances:
        for index in plant.GetBodyIndices(instance):
            if not plant.IsAnchored(plant.get_body(index)):
                raise ValueError(f"{plant.GetModelInstanceName(instance)}: furniture must be "
                                 f"welded to the world")
    return proximity_geometries(plant, scene_graph, instances, world_names=("wall",))


class ClearanceMonitor(LeafSystem):
    """Keeps the smallest signed distance (m) between two sets of geometries.

    Input ports:
        query_object (abstract QueryObject): the simulation's SceneGraph.
    Output ports:
        closest_approach (vector 1): the smallest distance measured so far (m; REACH
            before any pair came that close).

    Every `period` s (and on a forced discrete update) it measures the pairs of `robot`
    and `world` geometries within REACH of each other.
    """

    def __init__(self, *, robot: frozenset[GeometryId], world: frozenset[GeometryId],
                 period: float) -> None:
        super().__init__()
        if period <= 0:
            raise ValueError(f"period: expected a positive period, got {period}")
        self._near = NearPairs(robot=robot, world=world, reach=REACH)
        self._query_port = self.DeclareAbstractInputPort(
            "query_object", AbstractValue.Make(QueryObject()))
        self._closest = self.DeclareDiscreteState([REACH])
        self.DeclareStateOutputPort("closest_approach", self._closest)
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, weak_callback(self._measure))
        self.DeclareForcedDiscreteUpdateEvent(weak_callback(self._measure))

    def _measure(self, context: Context, state: DiscreteValues) -> EventStatus:
        query: QueryObject = self._query_port.Eval(context)
        closest = float(context.get_discrete_state(self._closest).GetAtIndex(0))
        # Drake's pairwise query measures every pair within REACH, the robot's links
        # against each other too (most of its pairs, and of its time), to drop all but
        # the robot's against the world's. Those pairs are measured alone instead, by the
        # same narrow phase: the same distances. A pair it leaves out (a filtered one) is
        # left out here too, and a pair whose distance is bounded above REACH would
        # measure more than REACH, which never lowers `closest` (at most REACH).
        for a, b in self._near.pairs(query):
            closest = min(closest, float(
                query.ComputeSignedDistancePairClosestPoints(a, b).distance))
        state.get_mutable_vector(self._closest).SetAtIndex(0, closest)
        return EventStatus.Succeeded()


def add_clearance_monitor(builder: DiagramBuilder, world: Diagram, *, robot: Robot,
                          furniture: Iterable[str], period: float) -> OutputPort:
    """A ClearanceMonitor ("clearance_monitor") of `robot` against the walls and the
    `furniture` (model instance names: the tables and the chairs) of `world` (a world
    diagram, in `builder`); its closest_approach port."""
    plant = world.GetSubsystemByName("plant")
    scene_graph = world.GetSubsystemByName("scene_graph")
    monitor = builder.AddNamedSystem("clearance_monitor", ClearanceMonitor(
        robot=proximity_geometries(plant, scene_graph,
                                   list(robot.instances_in(plant).instances)),
        world=room_geometries(plant, scene_graph, furniture),
        period=period))
    builder.Connect(world.GetOutputPort("query_object"), monitor.GetInputPort("query_object"))
    return monitor.GetOutputPort("closest_approach")


class NearPairs:
    """The pairs of a `robot` geometry and a `world` one that may come within `reach` (m)
    of each other, found without Drake's pairwise query (which measures the robot's links
    against each other too). The `world` geometries are fixed (`room_geometries`): their
    poses, and which pairs are filtered, are read at the first call."""

    def __init__(self, *, robot: frozenset[GeometryId], world: frozenset[GeometryId],
                 reach: float) -> None:
        self._ordered = (sorted(robot, key=GeometryId.get_value),
                         sorted(world, key=GeometryId.get_value))
        self._reach = reach
        self._bound: _Shapes | None = None
        self._room: _Room | None = None
        # Per (robot, world) geometry, the distance from the robot geometry's origin to the
        # world geometry's box beyond which the pair cannot come within `reach`: the reach,
        # the margin and both bounds' slack (the robot's radius, the world's extra).
        self._far = np.empty((0, 0))

    def pairs(self, query: QueryObject) -> list[tuple[GeometryId, GeometryId]]:
        """The unfiltered (robot, world) pairs that may come within `reach`, each in the
        order of their ids (that of the pairwise query's narrow phase). A lower bound of a
        pair's distance: the distance from the robot geometry's bounding sphere to the
        world geometry's box (the walls, tables and chairs are boxes), else to its
        bounding sphere."""
        robot, world = self._ordered
        if not robot or not world:
            return []
        shapes = self._shapes(query.inspector())
        room = self._room_in(query)
        # One pose per frame (a link holds several geometries).
        X_WF = [query.GetPoseInWorld(frame) for frame in shapes.frames]
        R_WF = np.array([X.rotation().matrix() for X in X_WF])
        p_WF = np.array([X.translation() for X in X_WF])
        f = shapes.frame_of
        p_WG = np.matmul(R_WF[f], shapes.p_FG[:, :, None])[:, :, 0] + p_WF[f]
        # Each robot geometry's origin in each world geometry's frame, by one product:
        # (p_WG - p_Ww) R_Ww = p_WG R_Ww - p_Ww R_Ww.
        p_wG = (p_WG @ room.R_W_all).reshape(len(p_WG), *room.p_w_W.shape) - room.p_w_W
        outside = np.abs(p_wG)
        outside -= shapes.half
        np.maximum(outside, 0.0, out=outside)
        box_gap = np.sqrt(np.einsum("rwk,rwk->rw", outside, outside))
        near = ~(box_gap > self._far) & room.measured
        return [room.pairs[i][j] for i, j in zip(*np.nonzero(near), strict=True)]

    def _shapes(self, inspector: SceneGraphInspector) -> "_Shapes":
        """What `pairs` needs of the geometries' shapes, and the distances beyond which a
        pair is far, made once: shapes and their poses in their frames do not change during
        a simulation."""
        if self._bound is None:
            self._bound = _Shapes.of(inspector, *self._ordered)
            self._far = self._bound.radius[:, None] + (
                self._reach + BOUND_MARGIN + self._bound.extra)
        return self._bound

    def _room_in(self, query: QueryObject) -> "_Room":
        """The world geometries' poses and the pairs' order and filtering, read once: the
        room does not move and its filters do not change."""
        if self._room is None:
            robot, world = self._ordered
            inspector = query.inspector()
            X_WG = [query.GetPoseInWorld(g) for g in world]
            pairs = [[(a, b) if a.get_value() < b.get_value() else (b, a) for b in world]
                     for a in robot]
            p_WG = np.array([X.translation() for X in X_WG])
            R_WG = np.array([X.rotation().matrix() for X in X_WG])
            self._room = _Room(
                R_W_all=R_WG.transpose(1, 0, 2).reshape(3, 3 * len(R_WG)),
                p_w_W=np.einsum("wk,wkl->wl", p_WG, R_WG),
                pairs=pairs,
                measured=np.array([[not inspector.CollisionFiltered(a, b) for a, b in row]
                                   for row in pairs], dtype=bool))
        return self._room


@dataclass(frozen=True)
class _Room:
    """The world geometries' rotations in W side by side (3 x 3 per geometry: a point's
    row vector times them is the point in each geometry's axes), and their positions so
    rotated; and per (robot, world) geometry the pair in the order of their ids (that of
    the pairwise query's narrow phase) and whether it is measured (not filtered)."""

    R_W_all: np.ndarray
    p_w_W: np.ndarray  # noqa: N815 (monogram notation)
    pairs: list[list[tuple[GeometryId, GeometryId]]]
    measured: np.ndarray


@dataclass(frozen=True)
class _Shapes:
    """The robot's geometries' frames and poses in them, and their bounding radii about
    their origins (m); the world geometries' half sizes (a box's, else 0) and what their
    distance falls short of their surface's (0 for a box, else the bounding radius). inf
    for a shape of no known bound: its pairs are always measured."""

    frames: list[FrameId]
    frame_of: np.ndarray
    R_FG: np.ndarray
    p_FG: np.ndarray  # noqa: N815 (monogram notation)
    radius: np.ndarray
    half: np.ndarray
    extra: np.ndarray

    @classmethod
    def of(cls, inspector: SceneGraphInspector, robot: list[GeometryId],
           world: list[GeometryId]) -> "_Shapes":
        frames: dict[FrameId, int] = {}
        frame_of = [frames.setdefault(inspector.GetFrameId(g), len(frames)) for g in robot]
        X_FG = [inspector.GetPoseInFrame(g) for g in robot]
        shapes = [inspector.GetShape(g) for g in world]
        return cls(
            frames=list(frames), frame_of=np.array(frame_of),
            R_FG=np.array([X.rotation().matrix() for X in X_FG]),
            p_FG=np.array([X.translation() for X in X_FG]),
            radius=np.array([_bounding_radius(inspector.GetShape(g)) for g in robot]),
            half=np.array([[s.width() / 2, s.depth() / 2, s.height() / 2]
                           if isinstance(s, Box) else [0.0, 0.0, 0.0] for s in shapes]),
            extra=np.array([0.0 if isinstance(s, Box) else _bounding_radius(s)
                            for s in shapes]))


def _bounding_radius(shape: object) -> float:
    """The radius (m) of a sphere about the shape's origin that holds it; inf if unknown."""
    if isinstance(shape, Box):
        return 0.5 * math.sqrt(shape.width() ** 2 + shape.depth() ** 2 + shape.height() ** 2)
    if isinstance(shape, Cylinder):
        return math.hypot(shape.radius(), shape.length() / 2)
    if isinstance(shape, Sphere):
        return shape.radius()
    if isinstance(shape, Capsule):
        return shape.radius() + shape.length() / 2
    if isinstance(shape, Ellipsoid):
        return max(shape.a(), shape.b(), shape.c())
    if isinstance(shape, (Mesh, Convex)):
        # The farthest vertex of its convex hull (scaled), which holds the mesh and is what
        # the distance queries measure for it.
        try:
            hull = shape.GetConvexHull()
        except RuntimeError:  # a file Drake cannot make a hull of
            return math.inf
        return max(math.sqrt(sum(c * c for c in hull.vertex(i)))
                   for i in range(hull.num_vertices()))
    return math.inf
