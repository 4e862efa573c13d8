"""The world of a robot of parts (models/gen3: several model instances): the diagram's
robot ports through selection matrices, the object tracker, the feasibility scene's
collision checker and the exported directives; and a single-instance robot's world as it
always was (the plant's own ports, no system more)."""


import numpy as np
import pytest
from pydrake.multibody.parsing import LoadModelDirectives, Parser, ProcessModelDirectives
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph
from pydrake.multibody.tree import BodyIndex
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from s3o_drake.feasibility.scene import FeasibilityScene
from s3o_drake.world.builder import (
    build_world_diagram,
    populate_plant,
    robot_hold_state,
    robot_render_labels,
)
from s3o_drake.world.directives import write_directives
from s3o_drake.world.resources import RESTAURANT
from s3o_drake.world.scenario import load_scenario, with_overrides

#: The systems of the restaurant's world with tracked dishes for a single-instance robot:
#: the robot's own ports are the plant's (same-runs identity: no system of ours between).
SINGLE_INSTANCE_SYSTEMS = ["camera_scene_graph", "geometry_mirror", "gravity_compensation",
                           "gravity_to_actuators", "object_tracker", "overhead_camera", "plant",
                           "protective_stop", "scene_graph", "target_sensor"]


@pytest.fixture(scope="module")
def restaurant():
    return load_scenario(RESTAURANT)


@pytest.fixture(scope="module")
def gen3_scenario(restaurant):
    return with_overrides(restaurant, ("robot.name=gen3",))


def _port_names(world):
    return ([world.get_input_port(i).get_name() for i in range(world.num_input_ports())],
            [world.get_output_port(i).get_name() for i in range(world.num_output_ports())])


def test_a_single_instance_robots_world_keeps_the_plants_own_ports(restaurant):
    world = build_world_diagram(restaurant, track_dishes=True)
    assert sorted(s.get_name() for s in world.GetSystems()) == SINGLE_INSTANCE_SYSTEMS
    assert _port_names(world) == (
        ["grip", "target_request", "robot_desired_state"],
        ["target_sighting", "gripper_status", "dish_poses", "dish_states", "robot_state",
         "base_bumper", "overhead_color_image", "overhead_depth_image",
         "overhead_label_image", "query_object", "body_poses"])
    plant = world.GetSubsystemByName("plant")
    robot = plant.GetModelInstanceByName("robot")
    context = world.CreateDefaultContext()
    np.testing.assert_array_equal(
        world.GetOutputPort("robot_state").Eval(context),
        plant.get_state_output_port(robot).Eval(plant.GetMyContextFromRoot(context)))


def test_a_robot_of_parts_world_holds_a_setpoint(gen3_scenario):
    robot = gen3_scenario.robot_value
    world = build_world_diagram(gen3_scenario, track_dishes=True)
    names = {s.get_name() for s in world.GetSystems()}
    assert names - set(SINGLE_INSTANCE_SYSTEMS) == {
        "robot_state_selector", "robot_desired_state_to_robot::base",
        "robot_desired_state_to_robot::arm", "robot_desired_state_to_robot::gripper"}
    n = robot.num_positions
    assert world.GetInputPort("robot_desired_state").size() == 2 * n == 22
    assert world.GetOutputPort("robot_state").size() == 2 * n
    simulator = Simulator(world)
    context = simulator.get_mutable_context()
    hold = robot_hold_state(gen3_scenario)
    hold[n - 1] = 0.3  # the knuckle part-closed: its mimic joints must follow
    world.GetInputPort("robot_desired_state").FixValue(context, hold)
    simulator.AdvanceTo(0.3)
    x = world.GetOutputPort("robot_state").Eval(context)
    np.testing.assert_allclose(x[:n], hold[:n], atol=5e-3)
    np.testing.assert_allclose(x[n:], 0.0, atol=1e-3)
    # SAP holds the couplers: the gripper's mimic joints follow its knuckle.
    plant = world.GetSubsystemByName("plant")
    placed = robot.instances_in(plant)
    tip = placed.joint("robotiq_85_right_finger_tip_joint")
    assert tip.get_angle(plant.GetMyContextFromRoot(context)) == pytest.approx(
        x[n - 1], abs=2e-3)
    # The object tracker reads the same state: the dishes stay on their tables.
    assert set(world.GetOutputPort("dish_states").Eval(context).values()) == {"table"}
    # Every part's geometry is the robot's to the camera.
    assert len(placed.instances) == 3
    assert len(robot_render_labels(world, robot)) > 1


def test_a_robot_of_parts_feasibility_scene_checks_all_its_instances(gen3_scenario):
    scene = FeasibilityScene(gen3_scenario.contents)
    robot = scene.robot
    # Drake's checker takes the plant's positions (the robot's and the gripper's mimic
    # joints); the scene's takes the robot's and lifts them.
    assert scene.checker.plant().num_positions() == 16
    q = robot.positions(*gen3_scenario.robot.start)
    assert q.shape == (11,) and not scene.positions.is_identity
    lifted = scene.positions.to_plant(q)
    np.testing.assert_array_equal(lifted, scene.robot_instances.plant_positions(q))
    np.testing.assert_array_equal(scene.positions.to_robot(lifted), q)
    assert scene.checker.CheckConfigCollisionFree(q)
    assert scene.checker.inner.CheckConfigCollisionFree(lifted)
    assert scene.grasp_pose(robot.positions(*gen3_scenario.robot.start)).translation()[2] > 0.5
    # The stowed arm stays over the footprint (mesh geometry: its hulls' vertices).
    assert scene.robot_radius <= robot.base_radius + 1e-9


def test_a_robot_of_parts_exports_as_its_directives(gen3_scenario, tmp_path):
    contents = gen3_scenario.contents
    dmd = write_directives(contents, tmp_path, "gen3_restaurant")
    built, built_geometry = AddMultibodyPlantSceneGraph(DiagramBuilder(), 0.0)
    populate_plant(built, built_geometry, contents)
    built.Finalize()
    loaded, loaded_geometry = AddMultibodyPlantSceneGraph(DiagramBuilder(), 0.0)
    parser = Parser(loaded)
    parser.package_map().AddPackageXml(str(tmp_path / "package.xml"))
    ProcessModelDirectives(LoadModelDirectives(str(dmd)), loaded, parser)
    loaded.Finalize()
    # The files are the package's own: no URL of the project's package is left.
    assert "package://s3o_drake/" not in "".join(
        p.read_text() for p in tmp_path.rglob("*.urdf"))
    assert loaded.num_positions() == built.num_positions() == 16
    assert (loaded_geometry.model_inspector().num_geometries()
            == built_geometry.model_inspector().num_geometries())
    built_context, loaded_context = built.CreateDefaultContext(), loaded.CreateDefaultContext()
    for i in range(built.num_bodies()):
        body = built.get_body(BodyIndex(i))
        instance = built.GetModelInstanceName(body.model_instance())
        if not instance.startswith("robot"):
            continue
        twin = loaded.GetBodyByName(body.name(), loaded.GetModelInstanceByName(instance))
        np.testing.assert_allclose(
            loaded.EvalBodyPoseInWorld(loaded_context, twin).GetAsMatrix4(),
            built.EvalBodyPoseInWorld(built_context, body).GetAsMatrix4(), atol=1e-12,
            err_msg=f"{instance}::{body.name()}")
