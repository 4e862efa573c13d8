"""GeometryMirror: the camera's copy of the scene holds the perception geometry and follows it."""

from pathlib import Path

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.geometry import (
    Box,
    FramePoseVector,
    GeometryFrame,
    GeometryInstance,
    IllustrationProperties,
    PerceptionProperties,
    RenderLabel,
    Role,
    SceneGraph,
    Sphere,
)
from pydrake.math import RigidTransform
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from s3o_drake.world.builder import build_world_diagram, robot_render_labels
from s3o_drake.world.camera import overhead_camera
from s3o_drake.world.geometry_mirror import AddGeometryMirror
from s3o_drake.world.robot import load_robot
from s3o_drake.world.scenario import load_scenario

UR5E = load_robot("ur5e")

REPO = Path(__file__).resolve().parents[2]
SMALL = REPO / "scenarios" / "small" / "two_dishes.yaml"


def _perception(label: int) -> PerceptionProperties:
    props = PerceptionProperties()
    props.AddProperty("label", "id", RenderLabel(label))
    return props


def _original() -> tuple[SceneGraph, object, object]:
    """A scene graph with an anchored box, a perceived sphere on a frame, and a box on the
    same frame that only has the illustration role."""
    scene_graph = SceneGraph()
    source = scene_graph.RegisterSource("toy")
    floor = GeometryInstance(RigidTransform([0, 0, -0.5]), Box(4, 4, 1), "floor")
    floor.set_perception_properties(_perception(3))
    scene_graph.RegisterAnchoredGeometry(source, floor)
    frame = scene_graph.RegisterFrame(source, GeometryFrame("ball"))
    ball = GeometryInstance(RigidTransform([0, 0, 0.1]), Sphere(0.2), "ball")
    ball.set_perception_properties(_perception(7))
    scene_graph.RegisterGeometry(source, frame, ball)
    drawn = GeometryInstance(RigidTransform(), Box(0.1, 0.1, 0.1), "only_drawn")
    drawn.set_illustration_properties(IllustrationProperties())
    scene_graph.RegisterGeometry(source, frame, drawn)
    return scene_graph, source, frame


def _mirror(original: SceneGraph, source):
    """The copy and the mirror, in a built diagram (returned: it owns them)."""
    builder = DiagramBuilder()
    copy = builder.AddSystem(SceneGraph())
    mirror = AddGeometryMirror(builder, original=original, copy=copy, sources=[source])
    return copy, mirror, builder.Build()


def test_mirror_copies_perception_geometry_only_with_its_labels():
    original, source, _ = _original()
    copy, mirror, _diagram = _mirror(original, source)
    inspector = copy.model_inspector()
    assert inspector.NumGeometriesWithRole(Role.kPerception) == 2
    assert inspector.NumGeometriesWithRole(Role.kIllustration) == 0
    assert inspector.NumAnchoredGeometries() == 1
    labels = {int(inspector.GetPerceptionProperties(g).GetProperty("label", "id"))
              for g in inspector.GetAllGeometryIds()}
    assert labels == {3, 7}
    (twin,) = inspector.FramesForSource(mirror.source_id)
    (ball,) = inspector.GetGeometries(twin, Role.kPerception)
    np.testing.assert_allclose(inspector.GetPoseInFrame(ball).translation(), [0, 0, 0.1])
    assert mirror.get_input_port(0).get_name() == "toy_pose"


def test_mirror_moves_the_twin_where_the_original_frame_is():
    original, source, frame = _original()
    copy, mirror, _diagram = _mirror(original, source)
    context = mirror.CreateDefaultContext()
    X_WF = RigidTransform([1.0, -2.0, 0.3])
    poses = FramePoseVector()
    poses.set_value(frame, X_WF)
    mirror.get_input_port(0).FixValue(context, AbstractValue.Make(poses))
    out = mirror.GetOutputPort("geometry_pose").Eval(context)
    (twin,) = copy.model_inspector().FramesForSource(mirror.source_id)
    assert out.ids() == [twin]
    np.testing.assert_allclose(out.value(twin).GetAsMatrix4(), X_WF.GetAsMatrix4())


def test_camera_sees_the_robot_where_the_simulation_moved_it():
    """In the world diagram the camera's scene is the mirror's: after the base has driven
    away from its start, the robot's labels are at the new place in the image."""
    scenario = load_scenario(SMALL)
    world = build_world_diagram(scenario, track_dishes=True)
    simulator = Simulator(world)
    context = simulator.get_mutable_context()
    x0, y0, yaw0 = scenario.robot.start
    goal = (x0 + 0.5, y0, yaw0)
    robot_labels = list(robot_render_labels(world, scenario.robot_value))

    def robot_centroid_px() -> np.ndarray:
        label = world.GetOutputPort("overhead_label_image").Eval(context).data[:, :, 0]
        v, u = np.nonzero(np.isin(label, robot_labels))
        return np.array([u.mean(), v.mean()])

    world.GetInputPort("robot_desired_state").FixValue(
        context, UR5E.desired_state(UR5E.positions(*scenario.robot.start)))
    before = robot_centroid_px()
    world.GetInputPort("robot_desired_state").FixValue(
        context, UR5E.desired_state(UR5E.positions(*goal)))
    simulator.AdvanceTo(3.0)
    q = world.GetOutputPort("robot_state").Eval(context)[:3]
    np.testing.assert_allclose(q, goal, atol=0.02)
    after = robot_centroid_px()
    # The robot's pixels moved by the base's 0.5 m along the image's u axis (camera x is
    # world x), at the scale of the robot's height band (floor to ~1.2 m).
    camera = overhead_camera(scenario.room, scenario.camera)
    height = scenario.camera.height
    du, dv = after - before
    assert 0.5 * camera.focal / height < du < 0.5 * camera.focal / (height - 1.3)
    assert abs(dv) < 2.0
