"""The world builder: the plant holds the scenario, the camera sees it where it is."""

from pathlib import Path

import numpy as np
import pytest
from pydrake.geometry import Role
from pydrake.math import RigidTransform
from pydrake.multibody.plant import MultibodyPlant
from pydrake.planning import RobotDiagramBuilder
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
from s3o_drake.world.furniture import DISH_SHAPES
from s3o_drake.world.scenario import load_scenario

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def restaurant():
    scenario = load_scenario(REPO / "scenarios" / "restaurant.yaml")
    diagram = build_world_diagram(scenario)
    context = diagram.CreateDefaultContext()
    diagram.GetInputPort("robot_desired_state").FixValue(context, robot_hold_state(scenario))
    return scenario, diagram, context


def _plant(diagram) -> MultibodyPlant:
    return diagram.GetSubsystemByName("plant")


def test_plant_holds_every_model_of_the_scenario(restaurant):
    scenario, diagram, _ = restaurant
    plant = _plant(diagram)
    for item in [*scenario.tables, *scenario.chairs, *scenario.dishes]:
        assert plant.HasModelInstanceNamed(item.name)
    assert plant.HasModelInstanceNamed("robot")
    assert plant.num_positions() == 11  # furniture and dishes are welded; the robot moves


def test_robot_starts_at_its_start_pose(restaurant):
    scenario, diagram, context = restaurant
    plant = _plant(diagram)
    plant_context = plant.GetMyContextFromRoot(context)
    X_WB = plant.EvalBodyPoseInWorld(plant_context, plant.GetBodyByName("base_link"))
    x, y, yaw = scenario.robot.start
    np.testing.assert_allclose(X_WB.translation()[:2], [x, y], atol=1e-9)
    assert X_WB.rotation().ToRollPitchYaw().yaw_angle() == pytest.approx(yaw)


def test_dishes_stand_on_their_tables(restaurant):
    scenario, diagram, context = restaurant
    plant = _plant(diagram)
    plant_context = plant.GetMyContextFromRoot(context)
    heights = {t.name: t.height for t in scenario.tables}
    for dish in scenario.dishes:
        body = plant.GetBodyByName("dish", plant.GetModelInstanceByName(dish.name))
        p_WD = plant.EvalBodyPoseInWorld(plant_context, body).translation()
        np.testing.assert_allclose(p_WD, [*dish.position, heights[dish.table]], atol=1e-9)


def test_a_belief_s_plant_holds_the_perceived_chairs_not_the_true_ones():
    from s3o_drake.belief.known_world import KnownWorld

    scenario = load_scenario(REPO / "scenarios" / "restaurant.yaml")
    builder = RobotDiagramBuilder(time_step=0.0)
    blind = KnownWorld.of(scenario, perceived_chairs=[])
    models = populate_plant(builder.plant(), builder.scene_graph(), blind.contents)
    assert models.chairs == {}
    assert len(models.tables) == 7 and len(models.dishes) == 6
    seen = KnownWorld.of(scenario, perceived_chairs=[(2.0, 2.0, 0.3)])
    builder = RobotDiagramBuilder(time_step=0.0)
    models = populate_plant(builder.plant(), builder.scene_graph(), seen.contents)
    assert list(models.chairs) == ["perceived_0"]


def _label_of(diagram, model_name: str) -> int:
    """The render label SceneGraph gives the perception geometry of a model's body."""
    plant = _plant(diagram)
    scene_graph = diagram.GetSubsystemByName("scene_graph")
    inspector = scene_graph.model_inspector()
    (body_index,) = plant.GetBodyIndices(plant.GetModelInstanceByName(model_name))
    frame_id = plant.GetBodyFrameIdOrThrow(body_index)
    # Welded furniture hands its perception geometry to anchored copies (see world.py).
    assert not inspector.GetGeometries(frame_id, Role.kPerception)
    geometry_ids = [g for g in inspector.GetGeometries(inspector.world_frame_id(),
                                                       Role.kPerception)
                    if inspector.GetName(g).startswith(f"{model_name}::")]
    assert geometry_ids
    labels = {int(inspector.GetPerceptionProperties(g).GetProperty("label", "id"))
              for g in geometry_ids}
    assert len(labels) == 1
    return labels.pop()


def test_overhead_camera_sees_tables_dishes_and_chairs_where_they_are(restaurant):
    scenario, diagram, context = restaurant
    camera = overhead_camera(scenario.room, scenario.camera)
    depth = diagram.GetOutputPort("overhead_depth_image").Eval(context).data[:, :, 0]
    label = diagram.GetOutputPort("overhead_label_image").Eval(context).data[:, :, 0]
    color = diagram.GetOutputPort("overhead_color_image").Eval(context).data
    assert depth.shape == (camera.height, camera.width)
    assert color.shape[:2] == (camera.height, camera.width)
    cam_z = scenario.camera.height

    def pixel(x, y, z):
        u, v = np.round(camera.pixel_of([x, y, z])).astype(int)
        return v, u

    # A table: an off-centre spot on its top, away from its dishes.
    for table in scenario.tables:
        x, y = table.center[0] + 0.25 * table.size[0], table.center[1] - 0.25 * table.size[1]
        if any(np.hypot(x - d.position[0], y - d.position[1]) < 0.2 for d in scenario.dishes):
            x = table.center[0] - 0.25 * table.size[0]
        v, u = pixel(x, y, table.height)
        assert depth[v, u] == pytest.approx(cam_z - table.height, abs=0.01), table.name
        assert label[v, u] == _label_of(diagram, table.name), table.name

    # A dish: its top, a dish's height above the table.
    heights = {t.name: t.height for t in scenario.tables}
    for dish in scenario.dishes:
        top = heights[dish.table] + DISH_SHAPES[dish.kind].height
        v, u = pixel(*dish.position, top)
        assert depth[v, u] == pytest.approx(cam_z - top, abs=0.01), dish.name
        assert label[v, u] == _label_of(diagram, dish.name), dish.name

    # A chair: its seat.
    for chair in scenario.chairs:
        v, u = pixel(chair.pose[0], chair.pose[1], 0.45)
        assert label[v, u] == _label_of(diagram, chair.name), chair.name
        assert depth[v, u] == pytest.approx(cam_z - 0.45, abs=0.02), chair.name

    # Bare floor: far from everything.
    v, u = pixel(5.0, 3.2, 0.0)
    assert depth[v, u] == pytest.approx(cam_z, abs=0.01)


def test_camera_maps_pixels_back_to_the_floor():
    scenario = load_scenario(REPO / "scenarios" / "small" / "two_dishes.yaml")
    camera = overhead_camera(scenario.room, scenario.camera)
    for p_W in ([0.0, 0.0, 0.0], [4.0, 4.0, 0.0], [1.0, 3.0, 0.75]):
        u, v = camera.pixel_of(p_W)
        np.testing.assert_allclose(camera.point_at(u, v, p_W[2]), p_W, atol=1e-9)
    # The room's corners are in view, north at the top.
    u0, v0 = camera.pixel_of([0.0, 0.0, 0.0])
    u1, v1 = camera.pixel_of([4.0, 4.0, 0.0])
    assert 0 < u0 < u1 < camera.width and 0 < v1 < v0 < camera.height
    assert isinstance(camera.X_WC, RigidTransform)


def test_robot_holds_its_start_pose_in_simulation():
    scenario = load_scenario(REPO / "scenarios" / "small" / "two_dishes.yaml")
    builder = DiagramBuilder()
    world = builder.AddNamedSystem("world", build_world_diagram(scenario))
    hold = builder.AddSystem(ConstantVectorSource(robot_hold_state(scenario)))
    builder.Connect(hold.get_output_port(), world.GetInputPort("robot_desired_state"))
    diagram = builder.Build()
    simulator = Simulator(diagram)
    simulator.AdvanceTo(0.5)
    world = diagram.GetSubsystemByName("world")
    x = world.GetOutputPort("robot_state").Eval(
        world.GetMyContextFromRoot(simulator.get_context()))
    hold = robot_hold_state(scenario)
    np.testing.assert_allclose(x[:11], hold[:11], atol=1e-3)
    np.testing.assert_allclose(x[11:], 0.0, atol=1e-3)


def test_gravity_acts_on_the_robot_and_its_actuators_carry_it():
    """The robot has gravity, and "gravity_compensation" feeds its actuators the torques
    that cancel it (a robot with gravity disabled asked SAP for all-zero impulses at rest,
    where it failed to converge: builder._add_gravity_compensation). Held stretched out
    level, where gravity pulls hardest, the arm stays within 1 mm-rad of its pose."""
    scenario = load_scenario(REPO / "scenarios" / "small" / "two_dishes.yaml")
    level = np.array(robot_hold_state(scenario))
    # The UR5e stretched out along its -x, over the open floor (the base turned round).
    level[2], level[3:9] = np.pi, [0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    builder = DiagramBuilder()
    world = builder.AddNamedSystem("world", build_world_diagram(scenario))
    hold = builder.AddSystem(ConstantVectorSource(level))
    builder.Connect(hold.get_output_port(), world.GetInputPort("robot_desired_state"))
    diagram = builder.Build()
    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    plant = world.GetSubsystemByName("plant")
    plant_context = plant.GetMyMutableContextFromRoot(context)
    plant.SetPositions(plant_context, level[:11])
    tau_g = plant.CalcGravityGeneralizedForces(plant_context)
    assert abs(tau_g[4]) > 20.0  # the shoulder carries the stretched arm (N m)
    compensation = world.GetSubsystemByName("gravity_compensation")
    u = compensation.get_output_port_generalized_force().Eval(
        compensation.GetMyContextFromRoot(context))
    np.testing.assert_allclose(u, -tau_g, atol=1e-9)
    simulator.AdvanceTo(1.0)
    np.testing.assert_allclose(plant.GetPositions(plant_context), level[:11], atol=1e-3)


def test_meshcat_gets_drakes_visualizers_as_the_scenarios_visualization_says(meshcat):
    """`visualization` (Drake's VisualizationConfig) decides what Meshcat shows: by default
    the illustration (what the playback records), the proximity geometry in a live view
    only; none at all without a Meshcat (the studies' runs)."""
    scenario = load_scenario(REPO / "scenarios" / "small" / "two_dishes.yaml")

    def visualizers(**kwargs) -> set[str]:
        world = build_world_diagram(scenario, **kwargs)
        return {s.get_name() for s in world.GetSystems() if "meshcat" in s.get_name()}

    assert visualizers(meshcat=meshcat, show_collisions=False) == {ILLUSTRATION}
    assert visualizers(meshcat=meshcat, show_collisions=True) == {
        ILLUSTRATION, "meshcat_visualizer(proximity)"}
    assert visualizers(meshcat=None) == set()
    scenario.visualization.publish_inertia = True
    scenario.visualization.publish_illustration = False
    assert visualizers(meshcat=meshcat, show_collisions=False) == {
        "meshcat_visualizer(inertia)"}
