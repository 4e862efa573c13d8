"""ObjectTracker: dishes start on their tables, ride in the gripper, land on the tray or floor."""

import base64
import copy
import dataclasses
import json
import math
import re

import numpy as np
import pytest
from pydrake.math import RigidTransform
from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlantConfig
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource

from s3o_drake.world.builder import (
    ILLUSTRATION,
    build_world_diagram,
    populate_plant,
    robot_hold_state,
)
from s3o_drake.world.camera import overhead_camera
from s3o_drake.world.dish_messages import DishPoses, DishState, DishStates
from s3o_drake.world.furniture import DISH_SHAPES
from s3o_drake.world.goals import surface_below
from s3o_drake.world.gripper import grasp_tolerance
from s3o_drake.world.object_tracker import STANDING_TILT, AddObjectTracker
from s3o_drake.world.objects import PlaceSpot
from s3o_drake.world.robot import load_robot
from s3o_drake.world.robot_messages import GripEvent, GripperStatus
from s3o_drake.world.target_sensor import SensingError

UR5E = load_robot("ur5e")

ARM_REACHING = np.array([0.3, -0.6, 1.2, -2.2, -1.571, 0.4])


@pytest.fixture(scope="module")
def tracker_and_plant(scenario):
    diagram, tracker, plant, robot = _tracker_of(scenario)
    # The diagram owns the systems: held until the module's tests are done.
    yield tracker, plant, robot
    del diagram


def test_adding_a_tracker_needs_a_finalized_plant(scenario):
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlant(MultibodyPlantConfig(time_step=0.0), builder)
    models = populate_plant(plant, scene_graph, scenario.contents, dishes=False)
    sources = scene_graph.model_inspector().num_sources()
    with pytest.raises(ValueError, match="finalized"):
        AddObjectTracker(builder, scenario=scenario, plant=plant, robot=models.robot,
                         scene_graph=scene_graph)
    assert scene_graph.model_inspector().num_sources() == sources  # nothing registered


def test_dish_messages_are_read_only_and_print_as_words():
    states = DishStates({"plate_a": DishState.TRAY, "cup_b": DishState.TABLE})
    assert states.named(DishState.TRAY) == ("plate_a",) and states.named(DishState.DROPPED) == ()
    assert str(DishState.TRAY) == f"{DishState.TRAY}" == "tray"
    assert json.dumps(dict(states)) == '{"plate_a": "tray", "cup_b": "table"}'
    with pytest.raises(TypeError):
        states["cup_b"] = DishState.DROPPED
    with pytest.raises(AttributeError):
        states._values = {}
    poses = DishPoses({"plate_a": RigidTransform([1.0, 2.0, 0.75])})
    copied = copy.deepcopy(poses)  # as Drake copies port values
    assert isinstance(copied, DishPoses) and copied["plate_a"] is not poses["plate_a"]
    np.testing.assert_array_equal(copied["plate_a"].translation(), [1.0, 2.0, 0.75])
    assert copy.deepcopy(states) == states


def _frames(plant, robot, q) -> tuple[RigidTransform, RigidTransform]:
    """X_WG and X_WT at robot positions q, computed with the plant."""
    plant_context = plant.CreateDefaultContext()
    plant.SetPositions(plant_context, robot, q)
    return (plant.GetFrameByName(UR5E.grasp_frame, robot).CalcPoseInWorld(plant_context),
            plant.GetFrameByName(UR5E.tray_link, robot).CalcPoseInWorld(plant_context))


class _Driver:
    """The tracker alone: fixes its inputs and forces its update."""

    def __init__(self, tracker):
        self.tracker = tracker
        self.context = tracker.CreateDefaultContext()
        self.set(UR5E.positions(1.2, 2.0, 0.0), GripEvent())

    def set(self, q, grip):
        self.tracker.GetInputPort("robot_state").FixValue(self.context, UR5E.desired_state(q))
        self.tracker.GetInputPort("grip").FixValue(self.context, grip)

    def update(self):
        updated = self.context.Clone()
        self.tracker.CalcForcedUnrestrictedUpdate(self.context, updated.get_mutable_state())
        self.context.SetTimeStateAndParametersFrom(updated)

    def poses(self) -> DishPoses:
        return self.tracker.GetOutputPort("dish_poses").Eval(self.context)

    def states(self) -> DishStates:
        return self.tracker.GetOutputPort("dish_states").Eval(self.context)

    def gripper(self) -> GripperStatus:
        return self.tracker.GetOutputPort("gripper_status").Eval(self.context)


def _assert_same_pose(X_actual: RigidTransform, X_expected: RigidTransform):
    np.testing.assert_allclose(X_actual.GetAsMatrix4(), X_expected.GetAsMatrix4(), atol=1e-9)


def test_ports_and_names(tracker_and_plant, scenario):
    tracker, _, _ = tracker_and_plant
    assert tracker.dish_names == ("plate_a", "cup_b")
    assert tracker.GetInputPort("robot_state").size() == 22
    for name in ("grip", "robot_state", "sensing_error", "geometry_pose", "dish_poses",
                 "dish_states", "gripper_status"):
        assert tracker.HasInputPort(name) or tracker.HasOutputPort(name)
    assert len(set(tracker.labels.values())) == len(scenario.dishes)


def test_dishes_start_on_their_tables(tracker_and_plant, scenario):
    driver = _Driver(tracker_and_plant[0])
    heights = {t.name: t.height for t in scenario.tables}
    assert driver.states() == {"plate_a": DishState.TABLE, "cup_b": DishState.TABLE}
    for dish in scenario.dishes:
        X_WD = driver.poses()[dish.name]
        np.testing.assert_allclose(X_WD.translation(), [*dish.position, heights[dish.table]])
    # The geometry sits where the dish poses say.
    frame_poses = tracker_and_plant[0].GetOutputPort("geometry_pose").Eval(driver.context)
    assert len(frame_poses.ids()) == 2
    for frame_id in frame_poses.ids():
        assert frame_poses.value(frame_id).translation()[2] == pytest.approx(0.75)
    # The output holds copies: a reader that changes one does not move the dish.
    driver.poses()["plate_a"].set_translation([0.0, 0.0, 0.0])
    driver.set(UR5E.positions(1.2, 2.0, 0.0), GripEvent())  # a fresh Eval
    np.testing.assert_allclose(driver.poses()["plate_a"].translation(), [1.85, 2.3, 0.75])


def test_gripped_dish_follows_the_grasp_frame_then_lands_on_the_tray(tracker_and_plant):
    tracker, plant, robot = tracker_and_plant
    driver = _Driver(tracker)
    X_WD0 = driver.poses()["plate_a"]
    q1 = UR5E.positions(1.2, 2.0, 0.1, ARM_REACHING)
    driver.set(q1, GripEvent(dish="plate_a"))
    driver.update()
    assert driver.states() == {"plate_a": DishState.GRIPPER, "cup_b": DishState.TABLE}
    _assert_same_pose(driver.poses()["plate_a"], X_WD0)  # picked up where it stood

    # The arm and base move: the dish keeps its pose in the grasp frame.
    X_WG1, _ = _frames(plant, robot, q1)
    q2 = UR5E.positions(1.0, 1.7, -0.4, UR5E.arm_stow)
    driver.set(q2, GripEvent(dish="plate_a"))
    X_WG2, X_WT2 = _frames(plant, robot, q2)
    _assert_same_pose(driver.poses()["plate_a"], X_WG2 @ X_WG1.inverse() @ X_WD0)
    driver.update()  # no change of grip: nothing happens
    assert driver.states()["plate_a"] is DishState.GRIPPER

    # Released after being placed: on the tray's floor, inside the rim.
    driver.set(q2, GripEvent(dish="", placed=("plate_a",)))
    driver.update()
    assert driver.states() == {"plate_a": DishState.TRAY, "cup_b": DishState.TABLE}
    X_TD = X_WT2.inverse() @ driver.poses()["plate_a"]
    radius = DISH_SHAPES["plate"].radius
    x, y, z = X_TD.translation()
    assert z == pytest.approx(0.0, abs=1e-9)
    assert abs(x) <= UR5E.description.tray.inner_length / 2 - radius + 1e-9
    assert abs(y) <= UR5E.description.tray.inner_width / 2 - radius + 1e-9
    np.testing.assert_allclose(X_TD.rotation().col(2), [0, 0, 1], atol=1e-9)  # upright

    # The base drives on: the dish rides along on the tray.
    q3 = UR5E.positions(2.5, 1.0, 1.2, UR5E.arm_stow)
    driver.set(q3, GripEvent(dish="", placed=("plate_a",)))
    _, X_WT3 = _frames(plant, robot, q3)
    _assert_same_pose(driver.poses()["plate_a"], X_WT3 @ X_TD)
    driver.update()
    assert driver.states()["plate_a"] is DishState.TRAY


def test_the_fingers_miss_a_dish_the_sighting_put_beyond_the_tolerance(tracker_and_plant):
    """The grasp's rule is the world's: the fingers catch the dish they close on unless the
    sighting the arm aimed with was off by more than the gripper's tolerance; the
    gripper's report says whether they hold something."""
    tracker, _, _ = tracker_and_plant
    tolerance = grasp_tolerance("plate", robot=UR5E)
    q = UR5E.positions(1.2, 2.0, 0.1, ARM_REACHING)
    outcomes = {}
    for name, error, target in (("beyond", (0.0, tolerance + 0.001), "plate_a"),
                                ("within", (tolerance - 0.001, 0.0), "plate_a"),
                                ("another target's", (0.0, tolerance + 0.001), "cup_b")):
        driver = _Driver(tracker)
        assert driver.gripper() == GripperStatus(False)
        tracker.GetInputPort("sensing_error").FixValue(driver.context,
                                                       SensingError(1, target, error))
        driver.set(q, GripEvent(dish="plate_a"))
        driver.update()
        outcomes[name] = driver.states()["plate_a"], driver.gripper()
    assert outcomes["beyond"] == (DishState.TABLE, GripperStatus(False))
    assert outcomes["within"] == (DishState.GRIPPER, GripperStatus(True))
    assert outcomes["another target's"] == (DishState.GRIPPER, GripperStatus(True))


def test_a_cup_gripped_off_centre_is_pushed_between_the_fingers(tracker_and_plant):
    """The fingers close along G's y axis on a cup held whole: it moves to y = 0 in G and
    keeps its offset along the pads (x) and the approach (z); a plate, pinched at the rim,
    stays where it was caught."""
    tracker, plant, robot = tracker_and_plant
    q = UR5E.positions(1.5, 1.8, 0.5, ARM_REACHING)
    X_WG, _ = _frames(plant, robot, q)
    for dish in ("cup_b", "plate_a"):
        driver = _Driver(tracker)
        X_GD_before = X_WG.inverse() @ driver.poses()[dish]
        assert abs(X_GD_before.translation()[1]) > 0.05  # far off the fingers' middle
        driver.set(q, GripEvent(dish=dish))
        driver.update()
        p_GD = (X_WG.inverse() @ driver.poses()[dish]).translation()
        expected = X_GD_before.translation() * ([1, 0, 1] if dish == "cup_b" else 1)
        np.testing.assert_allclose(p_GD, expected, atol=1e-9)


def test_released_dish_not_placed_drops_to_the_floor(tracker_and_plant):
    tracker = tracker_and_plant[0]
    driver = _Driver(tracker)
    q = UR5E.positions(1.5, 1.8, 0.5, ARM_REACHING)
    driver.set(q, GripEvent(dish="cup_b"))
    driver.update()
    q_moved = UR5E.positions(1.4, 1.6, 0.2, ARM_REACHING)
    driver.set(q_moved, GripEvent(dish="cup_b"))
    p_held = driver.poses()["cup_b"].translation()
    assert np.hypot(p_held[0] - 2.15, p_held[1] - 2.3) > 0.1  # it moved with the gripper

    driver.set(q_moved, GripEvent())
    driver.update()
    assert driver.states() == {"plate_a": DishState.TABLE, "cup_b": DishState.DROPPED}
    X_WD = driver.poses()["cup_b"]
    np.testing.assert_allclose(X_WD.translation(), [p_held[0], p_held[1], 0.0], atol=1e-9)
    # It stays there whatever the robot does next.
    driver.set(UR5E.positions(0.5, 0.5, 0.0), GripEvent())
    driver.update()
    _assert_same_pose(driver.poses()["cup_b"], X_WD)


def _tracker_of(scenario):
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlant(MultibodyPlantConfig(time_step=0.0), builder)
    models = populate_plant(plant, scene_graph, scenario.contents, dishes=False)
    plant.Finalize()
    tracker = AddObjectTracker(builder, scenario=scenario, plant=plant, robot=models.robot,
                               scene_graph=scene_graph)
    return builder.Build(), tracker, plant, models.robot.instances[0]


def test_an_object_put_down_stands_on_the_surface_below_where_it_was_let_go(scenario):
    """The cup's goal is to go onto the plate, which stays: let go above the plate it stands
    on the plate's top; let go above the bare table, on the table's top, upright; tilted
    too far, it is left tilted (the report says it is not upright)."""
    plate, cup = scenario.dishes
    tidy = dataclasses.replace(scenario, dishes=[
        dataclasses.replace(plate, goal="stay"),
        dataclasses.replace(cup, goal="place", place=PlaceSpot(onto="plate_a"))])
    diagram, tracker, _, _ = _tracker_of(tidy)
    plate_top = 0.75 + DISH_SHAPES["plate"].height
    grasp = UR5E.positions(1.5, 1.8, 0.5, ARM_REACHING)
    bent = ARM_REACHING + np.array([0.0, 0.0, 0.0, 0.0, 0.5, 0.0])  # wrist 2 turned
    # The held cup moves with the base: a base shifted by d moves it by d.
    for target, arm, surface, upright in (((1.85, 2.3), ARM_REACHING, plate_top, True),
                                          ((2.3, 2.6), ARM_REACHING, 0.75, True),
                                          ((2.3, 2.6), bent, 0.75, False)):
        driver = _Driver(tracker)
        driver.set(grasp, GripEvent(dish="cup_b"))
        driver.update()
        q = UR5E.positions(1.5, 1.8, 0.5, arm)
        driver.set(q, GripEvent(dish="cup_b"))
        p = driver.poses()["cup_b"].translation()
        q[:2] += np.asarray(target) - p[:2]
        driver.set(q, GripEvent(dish="cup_b"))
        X_held = driver.poses()["cup_b"]
        np.testing.assert_allclose(X_held.translation()[:2], target, atol=1e-9)
        assert surface_below(tidy, target) == pytest.approx(surface)
        assert (X_held.rotation().matrix()[2, 2] >= math.cos(STANDING_TILT)) == upright
        driver.set(q, GripEvent(put=("cup_b",)))
        driver.update()
        assert driver.states() == {"plate_a": DishState.TABLE, "cup_b": DishState.PLACED}
        X_WD = driver.poses()["cup_b"]
        np.testing.assert_allclose(X_WD.translation(), [*target, surface], atol=1e-9)
        np.testing.assert_allclose(X_WD.rotation().col(2),
                                   [0, 0, 1] if upright else X_held.rotation().col(2),
                                   atol=1e-9)
    del diagram


def test_tracker_in_a_periodic_simulation_picks_up_when_gripped(tracker_and_plant):
    tracker = tracker_and_plant[0]
    simulator = Simulator(tracker)
    context = simulator.get_mutable_context()
    q = UR5E.positions(1.2, 2.0, 0.0, ARM_REACHING)
    tracker.GetInputPort("robot_state").FixValue(context, UR5E.desired_state(q))
    tracker.GetInputPort("grip").FixValue(context, GripEvent(dish="cup_b"))
    simulator.AdvanceTo(0.05)
    assert tracker.GetOutputPort("dish_states").Eval(context)["cup_b"] is DishState.GRIPPER


def _world_with_robot_held(scenario, grip: GripEvent, meshcat=None):
    builder = DiagramBuilder()
    world = builder.AddNamedSystem(
        "world", build_world_diagram(scenario, meshcat=meshcat, track_dishes=True))
    hold = builder.AddNamedSystem("hold", ConstantVectorSource(robot_hold_state(scenario)))
    builder.Connect(hold.get_output_port(), world.GetInputPort("robot_desired_state"))
    diagram = builder.Build()
    simulator = Simulator(diagram)
    world_context = world.GetMyMutableContextFromRoot(simulator.get_mutable_context())
    world.GetInputPort("grip").FixValue(world_context, grip)
    return world, simulator, world_context


def test_world_with_tracked_dishes_sees_them_on_the_tables(scenario, meshcat):
    world, simulator, world_context = _world_with_robot_held(scenario, GripEvent(), meshcat)
    plant = world.GetSubsystemByName("plant")
    assert not any(plant.HasModelInstanceNamed(d.name) for d in scenario.dishes)
    visualizer = world.GetSubsystemByName(ILLUSTRATION)
    visualizer.StartRecording(set_transforms_while_recording=False)
    simulator.AdvanceTo(0.2)
    visualizer.StopRecording()
    visualizer.PublishRecording()

    heights = {t.name: t.height for t in scenario.tables}
    assert world.GetOutputPort("dish_states").Eval(world_context) == {
        "plate_a": DishState.TABLE, "cup_b": DishState.TABLE}
    poses = world.GetOutputPort("dish_poses").Eval(world_context)
    camera = overhead_camera(scenario.room, scenario.camera)
    depth = world.GetOutputPort("overhead_depth_image").Eval(world_context).data[:, :, 0]
    label = world.GetOutputPort("overhead_label_image").Eval(world_context).data[:, :, 0]
    labels = world.GetSubsystemByName("object_tracker").labels
    for dish in scenario.dishes:
        np.testing.assert_allclose(poses[dish.name].translation(),
                                   [*dish.position, heights[dish.table]], atol=1e-9)
        top = heights[dish.table] + DISH_SHAPES[dish.kind].height
        u, v = np.round(camera.pixel_of([*dish.position, top])).astype(int)
        assert depth[v, u] == pytest.approx(scenario.camera.height - top, abs=0.01), dish.name
        assert label[v, u] == labels[dish.name], dish.name

    html = meshcat.StaticHtml()
    commands = b"".join(base64.b64decode(data) for data in re.findall(
        r'fetch\("data:application/octet-binary;base64,([A-Za-z0-9+/=]+)"\)', html))
    for dish in scenario.dishes:
        assert dish.name.encode() in commands, dish.name


def test_world_with_a_gripped_dish_holds_it_where_the_robot_holds_still(scenario):
    world, simulator, world_context = _world_with_robot_held(scenario, GripEvent(dish="plate_a"))
    simulator.AdvanceTo(0.1)
    assert world.GetOutputPort("dish_states").Eval(world_context)["plate_a"] is DishState.GRIPPER
    p_WD = world.GetOutputPort("dish_poses").Eval(world_context)["plate_a"].translation()
    np.testing.assert_allclose(p_WD, [1.85, 2.3, 0.75], atol=2e-3)


def test_default_world_keeps_welded_dishes_and_no_grip_port(scenario):
    world = build_world_diagram(scenario)
    assert not world.HasInputPort("grip") and not world.HasOutputPort("dish_states")
    plant = world.GetSubsystemByName("plant")
    assert all(plant.HasModelInstanceNamed(d.name) for d in scenario.dishes)
