"""ObjectTracker: the dishes as geometry that follows the gripper and the tray.

The dishes are not bodies of the plant (the contact solver would have to hold a plate in a
parallel gripper, which the execution does not need); `AddObjectTracker` registers their
geometry with the SceneGraph and adds the system that moves it by the rules of `GripEvent`.
The values on its ports are in world/dish_messages.py.
"""

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.geometry import (
    CollisionFilterDeclaration,
    Cylinder,
    FrameId,
    FramePoseVector,
    GeometryFrame,
    GeometryInstance,
    GeometrySet,
    IllustrationProperties,
    PerceptionProperties,
    ProximityProperties,
    RenderLabel,
    Rgba,
    SceneGraph,
    SourceId,
)
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import (
    Context,
    DiagramBuilder,
    EventStatus,
    LeafSystem,
    State,
    ValueProducer,
)

from s3o_drake.world.dish_messages import DishPoses, DishState, DishStates
from s3o_drake.world.furniture import DISH_SHAPES
from s3o_drake.world.goals import surface_below
from s3o_drake.world.gripper import caught, holds_whole
from s3o_drake.world.objects import surface_height
from s3o_drake.world.robot import RobotInstances
from s3o_drake.world.robot_messages import GripEvent, GripperStatus
from s3o_drake.world.robot_ports import robot_state_output
from s3o_drake.world.scenario import Scenario
from s3o_drake.world.system_lifetime import weak_callback
from s3o_drake.world.target_sensor import SensingError


@dataclass(frozen=True)
class _Track:
    """Where one dish is: its `state` and its pose X_RD relative to the frame R that the
    state implies (W on a table or the floor, the grasp frame G in the gripper, the tray T).
    """

    dish: str
    state: DishState
    X_RD: RigidTransform

    def __deepcopy__(self, memo: dict) -> "_Track":
        # Shared, not copied: the fields are frozen, and X_RD, the one mutable object, is
        # the tracker's alone (its outputs get copies or products of it) and is never
        # changed in place (an update makes new _Tracks). Drake deep-copies the state around
        # every update event; real copies of the transforms cost a simulation of the
        # restaurant's world at rest about 7% of its time.
        return self


#: The tracker's abstract state: a _Track per dish, in the scenario's order. Immutable: an
#: update makes a new tuple.
_Tracks = tuple[_Track, ...]


#: An object let go at its place tilted less than this (rad) from upright comes to stand
#: upright on the surface below; tilted more, it is left as it was let go (it would topple),
#: and the run's report says it is not upright.
STANDING_TILT = 0.17


def tilt(R: RotationMatrix) -> float:
    """The angle (rad) between the frame's z axis and the world's."""
    return math.acos(min(1.0, max(-1.0, float(R.matrix()[2, 2]))))


def _upright(x: float, y: float, z: float, R: RotationMatrix) -> RigidTransform:
    """A pose at (x, y, z) that keeps only R's turn about z: a set-down dish stands up."""
    m = R.matrix()
    return RigidTransform(RotationMatrix.MakeZRotation(math.atan2(m[1, 0], m[0, 0])), [x, y, z])


def AddObjectTracker(builder: DiagramBuilder, *, scenario: Scenario, plant: MultibodyPlant,
                     robot: RobotInstances, scene_graph: SceneGraph, period: float = 0.01,
                     name: str = "object_tracker") -> "ObjectTracker":
    """Registers the scenario's dishes with `scene_graph` and adds their ObjectTracker to
    `builder`, named `name`, connected to the robot's state (robot_state, `robot_ports`) and
    to the scene graph (geometry_pose); grip and the dish outputs are the caller's to
    connect. `robot` is the scenario's robot (`scenario.robot_value`) in the plant.

    Each dish D becomes a frame of a geometry source `name`, named after the dish, with one
    cylinder (its bottom face's centre at D's origin) that has illustration, perception
    (colour, depth and a render label of its own, after the plant's) and proximity roles.

    Call it after the plant is finalized and every other geometry is registered: the
    dishes are filtered out of all collision pairs that exist then, because the plant
    rejects contact results involving geometry it does not own.
    """
    if not plant.is_finalized():
        raise ValueError("AddObjectTracker needs a finalized plant")
    source_id = scene_graph.RegisterSource(name)
    # Labels after every body of the plant: the plant labels its geometry by body index.
    first_label = plant.num_bodies()
    frame_ids: dict[str, FrameId] = {}
    labels: dict[str, int] = {}
    for i, dish in enumerate(scenario.dishes):
        shape = DISH_SHAPES[dish.kind]
        frame_id = scene_graph.RegisterFrame(source_id, GeometryFrame(dish.name))
        geometry = GeometryInstance(RigidTransform([0.0, 0.0, shape.height / 2]),
                                    Cylinder(shape.radius, shape.height), f"{dish.name}_body")
        rgba = Rgba(*shape.rgba)
        illustration = IllustrationProperties()
        illustration.AddProperty("phong", "diffuse", rgba)
        geometry.set_illustration_properties(illustration)
        label = RenderLabel(first_label + i)
        perception = PerceptionProperties()
        perception.AddProperty("phong", "diffuse", rgba)
        perception.AddProperty("label", "id", label)
        geometry.set_perception_properties(perception)
        geometry.set_proximity_properties(ProximityProperties())
        scene_graph.RegisterGeometry(source_id, frame_id, geometry)
        frame_ids[dish.name] = frame_id
        labels[dish.name] = int(label)
    # The plant rejects contact results that involve geometry it does not own, so the
    # dishes' proximity geometry is kept out of all collision pairs (it still answers
    # queries that ignore the filters, e.g. signed distance to a point or a named pair).
    inspector = scene_graph.model_inspector()
    dish_geometries = GeometrySet(list(frame_ids.values()))
    scene_graph.collision_filter_manager().Apply(
        CollisionFilterDeclaration()
        .ExcludeWithin(dish_geometries)
        .ExcludeBetween(dish_geometries, GeometrySet(inspector.GetAllGeometryIds())))

    tracker = builder.AddNamedSystem(name, ObjectTracker(
        scenario=scenario, plant=plant, robot=robot, source_id=source_id,
        frame_ids=frame_ids, labels=labels, period=period))
    builder.Connect(robot_state_output(builder, robot), tracker.GetInputPort("robot_state"))
    builder.Connect(tracker.GetOutputPort("geometry_pose"),
                    scene_graph.get_source_pose_port(source_id))
    return tracker


class ObjectTracker(LeafSystem):
    """Moves the dishes' geometry with the gripper, the tray, or not at all.

    `AddObjectTracker` registers the geometry and constructs it: `source_id` is the
    geometry source, `frame_ids` each dish's frame in it, `labels` each dish's render label;
    `robot` is the scenario's robot (`scenario.robot_value`) in the plant, whose grasp
    frame, tray and state it reads.

    A dish starts on its table. When `grip.dish` names it, the fingers close on it: they
    catch it unless the sighting the arm aimed with (`sensing_error`, for that dish) missed
    it by more than the gripper's tolerance (`gripper.caught`); a dish they miss stays
    where it is. A caught dish is in the gripper and keeps
    the pose relative to the grasp frame G that it had at that moment, except that one
    held whole (`gripper.holds_whole`: a cup, a can, an apple) is pushed by the closing
    fingers to the middle between them. When it is no longer
    named, it lands on the tray if it is in `grip.placed` (upright on the tray's floor,
    where it was released, kept inside the rim); if it is in `grip.put`, it was put down at
    its place: it stands on the highest surface below where it was let go
    (`goals.surface_below`: an object that stays, a table's top, the floor), upright unless
    it tilted more than STANDING_TILT; else it is dropped: upright on the floor below where
    it was. The states change at a periodic update (`period`) and at a forced
    unrestricted update; the poses of held dishes follow the robot's state continuously.

    Input ports:
        robot_state: vector (2 robot.num_positions, of `scenario.robot_value`): the robot's
            positions then its velocities.
        grip: abstract GripEvent; unconnected means the gripper holds nothing.
        sensing_error: abstract SensingError (world/target_sensor.py), the error of the
            arm's latest sighting; unconnected: exact sightings.
    Output ports:
        geometry_pose: FramePoseVector, for scene_graph.get_source_pose_port(source_id).
        dish_poses: abstract DishPoses, X_WD per dish.
        dish_states: abstract DishStates, the DishState of each dish (table, gripper,
            tray, placed or dropped).
        gripper_status: abstract GripperStatus, the gripper's report: an object is
            detected between the fingers while a dish is in the gripper.
    """

    def __init__(self, *, scenario: Scenario, plant: MultibodyPlant, robot: RobotInstances,
                 source_id: SourceId, frame_ids: Mapping[str, FrameId],
                 labels: Mapping[str, int], period: float = 0.01) -> None:
        super().__init__()
        if not plant.is_finalized():
            raise ValueError("ObjectTracker needs a finalized plant")
        names = tuple(d.name for d in scenario.dishes)
        for given, what in ((frame_ids, "frame_ids"), (labels, "labels")):
            if set(given) != set(names):
                raise ValueError(f"{what}: expected the dishes {names}, got {tuple(given)}")
        # The scenario names its robot, whose model the plant holds as `robot`: one source,
        # so the tracker cannot be given another robot than the world's.
        robot_value = scenario.robot_value
        self._plant = plant
        self._scenario = scenario
        self._G = robot.frame(robot_value.grasp_frame)
        self._robot = robot
        self._num_positions = robot_value.num_positions
        tray = robot_value.description.tray
        self._tray_inner = (tray.inner_length, tray.inner_width)
        # The tray is welded to the base link, which the planar joints place at (x, y, yaw):
        # the carried dishes follow from the first three positions without the plant's
        # kinematics at every step.
        default = plant.CreateDefaultContext()
        self._X_BT = robot.frame(robot_value.tray_link).CalcPose(
            default, robot.frame(robot_value.base_link))
        self._source_id = source_id
        self._names = names
        self._frame_ids = dict(frame_ids)
        self._labels = dict(labels)
        self._radii = {d.name: DISH_SHAPES[d.kind].radius for d in scenario.dishes}
        self._whole = {d.name: holds_whole(d.kind, robot=robot_value)
                       for d in scenario.dishes}
        self._kinds = {d.name: d.kind for d in scenario.dishes}
        self._robot_value = robot_value
        # As world.populate_plant welds the dishes: bottom centre on the surface.
        initial = tuple(
            _Track(d.name, DishState.TABLE,
                   RigidTransform([d.position[0], d.position[1],
                                   surface_height(scenario.tables, d)]))
            for d in scenario.dishes)

        self._robot_state_port = self.DeclareVectorInputPort("robot_state",
                                                              2 * self._num_positions)
        self._grip_port = self.DeclareAbstractInputPort("grip", AbstractValue.Make(GripEvent()))
        self._sensing_port = self.DeclareAbstractInputPort(
            "sensing_error", AbstractValue.Make(SensingError()))
        self._tracks_index = self.DeclareAbstractState(AbstractValue.Make(initial))
        # A plant context per system context, kept as a cache entry: kinematics of the
        # gripper and tray without a Python attribute that changes during simulation.
        # Its index, not the CacheEntry: the entry keeps its system alive where the gc cannot
        # see it (system_lifetime).
        self._plant_context_index = self.DeclareCacheEntry(
            "plant context at the robot's positions",
            ValueProducer(allocate=lambda: AbstractValue.Make(plant.CreateDefaultContext()),
                          calc=weak_callback(self._calc_plant_context)),
            {self._robot_state_port.ticket()}).cache_index()

        self.DeclareAbstractOutputPort(
            "geometry_pose", lambda: AbstractValue.Make(FramePoseVector()),
            weak_callback(self._calc_geometry_pose))
        self.DeclareAbstractOutputPort(
            "dish_poses", lambda: AbstractValue.Make(DishPoses()),
            weak_callback(self._calc_dish_poses))
        self.DeclareAbstractOutputPort(
            "dish_states", lambda: AbstractValue.Make(DishStates()),
            weak_callback(self._calc_dish_states))
        self.DeclareAbstractOutputPort(
            "gripper_status", lambda: AbstractValue.Make(GripperStatus()),
            weak_callback(self._calc_gripper_status),
            prerequisites_of_calc={self.abstract_state_ticket(self._tracks_index)})
        # Transitions only (the held dishes' poses are computed from the robot's live state),
        # so a 10 ms delay on grasp and release costs nothing visible and saves copying the
        # abstract state at every plant step.
        self.DeclarePeriodicUnrestrictedUpdateEvent(period, 0.0, weak_callback(self._update_tracks))
        self.DeclareForcedUnrestrictedUpdateEvent(weak_callback(self._update_tracks))

    @property
    def source_id(self) -> SourceId:
        """The SceneGraph source id of the dishes' geometry."""
        return self._source_id

    @property
    def dish_names(self) -> tuple[str, ...]:
        return self._names

    @property
    def labels(self) -> dict[str, int]:
        """The render label of each dish in the overhead label image."""
        return dict(self._labels)

    def _calc_plant_context(self, context: Context, value: AbstractValue) -> None:
        plant_context = value.get_mutable_value()
        q = self._robot_state_port.Eval(context)[:self._num_positions]
        self._robot.set_positions(plant_context, q)

    def _frames(self, context: Context) -> tuple[RigidTransform, RigidTransform]:
        """X_WG (grasp frame) and X_WT (tray) at the robot's current positions."""
        plant_context = self.get_cache_entry(self._plant_context_index).Eval(context)
        return self._G.CalcPoseInWorld(plant_context), self._tray_pose(context)

    def _grip(self, context: Context) -> GripEvent:
        if not self._grip_port.HasValue(context):
            return GripEvent()
        return self._grip_port.Eval(context)

    def _tray_pose(self, context: Context) -> RigidTransform:
        """X_WT from the base's planar joints alone."""
        x, y, yaw = self._robot_state_port.Eval(context)[:3]
        return RigidTransform(RotationMatrix.MakeZRotation(yaw), [x, y, 0.0]) @ self._X_BT

    def _tracks(self, context: Context) -> _Tracks:
        return context.get_abstract_state(self._tracks_index).get_value()

    def _world_poses(self, context: Context) -> list[tuple[str, RigidTransform]]:
        """(dish, X_WD) per dish; X_WD may be the state's own transform: read it only."""
        tracks = self._tracks(context)
        states = {t.state for t in tracks}
        reference = {}
        if DishState.GRIPPER in states:
            reference[DishState.GRIPPER] = self._G.CalcPoseInWorld(
                self.get_cache_entry(self._plant_context_index).Eval(context))
        if DishState.TRAY in states:
            reference[DishState.TRAY] = self._tray_pose(context)
        poses = []
        for track in tracks:
            X_WR = reference.get(track.state)
            poses.append((track.dish, track.X_RD if X_WR is None else X_WR @ track.X_RD))
        return poses

    def _calc_geometry_pose(self, context: Context, output: AbstractValue) -> None:
        poses = FramePoseVector()
        for name, X_WD in self._world_poses(context):
            poses.set_value(self._frame_ids[name], X_WD)
        output.set_value(poses)

    def _calc_dish_poses(self, context: Context, output: AbstractValue) -> None:
        # Copies: the output must not share the state's transforms.
        output.set_value(DishPoses((name, RigidTransform(X_WD))
                                   for name, X_WD in self._world_poses(context)))

    def _calc_dish_states(self, context: Context, output: AbstractValue) -> None:
        output.set_value(DishStates((t.dish, t.state) for t in self._tracks(context)))

    def _calc_gripper_status(self, context: Context, output: AbstractValue) -> None:
        output.set_value(GripperStatus(object_detected=any(
            t.state is DishState.GRIPPER for t in self._tracks(context))))

    def _misses(self, context: Context, dish: str) -> bool:
        """Whether the fingers closing on `dish` miss it: the sighting the arm aimed with
        was off by more than the gripper's tolerance."""
        if not self._sensing_port.HasValue(context):
            return False
        sensing: SensingError = self._sensing_port.Eval(context)
        return sensing.target == dish and not caught(np.array(sensing.error),
                                                      self._kinds[dish],
                                                      robot=self._robot_value)

    def _update_tracks(self, context: Context, state: State) -> EventStatus:
        tracks = self._tracks(context)
        grip = self._grip(context)
        changes = {t.dish for t in tracks
                   if (t.dish == grip.dish) != (t.state is DishState.GRIPPER)}
        if grip.dish in changes and self._misses(context, grip.dish):
            changes.discard(grip.dish)  # the fingers close beside it
        if not changes:
            return EventStatus.DidNothing()
        X_WG, X_WT = self._frames(context)
        X_WD_now = dict(self._world_poses(context))

        def moved(track: _Track) -> _Track:
            name = track.dish
            if name not in changes:
                return track
            X_WD = X_WD_now[name]
            if name == grip.dish:
                return _Track(name, DishState.GRIPPER, self._between_fingers(name,
                                                                             X_WG.inverse() @ X_WD))
            if name in grip.placed:
                return _Track(name, DishState.TRAY, self._on_tray(name, X_WT.inverse() @ X_WD))
            p = X_WD.translation()
            if name in grip.put:
                z = surface_below(self._scenario, p, ignore={name})
                R = X_WD.rotation()
                X_WD = (_upright(p[0], p[1], z, R) if tilt(R) <= STANDING_TILT
                        else RigidTransform(R, [p[0], p[1], z]))
                return _Track(name, DishState.PLACED, X_WD)
            return _Track(name, DishState.DROPPED, _upright(p[0], p[1], 0.0, X_WD.rotation()))

        state.get_mutable_abstract_state(self._tracks_index).set_value(
            tuple(moved(t) for t in tracks))
        return EventStatus.Succeeded()

    def _between_fingers(self, name: str, X_GD: RigidTransform) -> RigidTransform:
        """X_GD of a dish the fingers have closed on: one held whole is pushed to the middle
        between them (y = 0 in G, the fingers' closing axis); a pinched rim stays where
        it was caught."""
        if not self._whole[name]:
            return X_GD
        x, _, z = X_GD.translation()
        return RigidTransform(X_GD.rotation(), [x, 0.0, z])

    def _on_tray(self, name: str, X_TD: RigidTransform) -> RigidTransform:
        """X_TD set down on the tray's floor (z = 0 in T) and kept inside its rim."""
        radius = self._radii[name]
        inner_length, inner_width = self._tray_inner
        half_x = max(inner_length / 2 - radius, 0.0)
        half_y = max(inner_width / 2 - radius, 0.0)
        x, y, _ = X_TD.translation()
        return _upright(float(np.clip(x, -half_x, half_x)), float(np.clip(y, -half_y, half_y)),
                        0.0, X_TD.rotation())
