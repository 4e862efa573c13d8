"""The robot's closest approach to the true world, measured in the simulation.

A run's plan keeps the base clear of what the robot knows; the simulation has the true
chairs and the robot's real motion, noise and all. The `ClearanceMonitor` reads the
simulation's SceneGraph every `period` and keeps the smallest signed distance between the
robot's collision geometry and that of the room's walls, the tables and the chairs (not
the dishes, which the gripper touches, nor the floor): the run's `closest_approach`.
Below zero, the robot was in collision with the world.
"""

from collections.abc import Iterable

from pydrake.common.value import AbstractValue
from pydrake.geometry import GeometryId, QueryObject, Role, SceneGraph
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import ModelInstanceIndex
from pydrake.systems.framework import Context, DiscreteValues, EventStatus, LeafSystem

from s3o_drake.world.system_lifetime import weak_callback

REACH = 0.3
"""Pairs further apart than this (m) are not measured: the closest approach of a run is
never that large (a stop keeps a few centimetres from its table)."""


def proximity_geometries(plant: MultibodyPlant, scene_graph: SceneGraph,
                         instances: Iterable[ModelInstanceIndex], *,
                         world_names: Iterable[str] = ()) -> frozenset[GeometryId]:
    """The collision (proximity) geometries of the bodies of `instances`, and those of the
    world body whose names start with one of `world_names` (the walls)."""
    inspector = scene_graph.model_inspector()
    ids: set[GeometryId] = set()
    for instance in instances:
        for body in plant.GetBodyIndices(instance):
            ids.update(inspector.GetGeometries(plant.GetBodyFrameIdOrThrow(body),
                                               Role.kProximity))
    prefixes = tuple(world_names)
    if prefixes:
        frame = plant.GetBodyFrameIdOrThrow(plant.world_body().index())
        ids.update(g for g in inspector.GetGeometries(frame, Role.kProximity)
                   if inspector.GetName(g).split("::")[-1].startswith(prefixes))
    return frozenset(ids)


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
        self._robot, self._world = frozenset(robot), frozenset(world)
        self._query_port = self.DeclareAbstractInputPort(
            "query_object", AbstractValue.Make(QueryObject()))
        self._closest = self.DeclareDiscreteState([REACH])
        self.DeclareStateOutputPort("closest_approach", self._closest)
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, weak_callback(self._measure))
        self.DeclareForcedDiscreteUpdateEvent(weak_callback(self._measure))

    def _measure(self, context: Context, state: DiscreteValues) -> EventStatus:
        query: QueryObject = self._query_port.Eval(context)
        closest = float(context.get_discrete_state(self._closest).GetAtIndex(0))
        for pair in query.ComputeSignedDistancePairwiseClosestPoints(REACH):
            a, b = pair.id_A, pair.id_B
            if (a in self._robot and b in self._world) or (b in self._robot and a in self._world):
                closest = min(closest, float(pair.distance))
        state.get_mutable_vector(self._closest).SetAtIndex(0, closest)
        return EventStatus.Succeeded()

