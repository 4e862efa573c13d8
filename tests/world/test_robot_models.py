"""Every shipped robot (each folder of models/ with a robot.yaml): what a user of its
description relies on holds in its model. The description agrees with the model
(`check_model`); the arm's kinematics that the feasibility check moves are the model's arm
chain, with the model's limits; its frames and gripper are where it says; its stow
configuration is within the joint limits, at least 1 cm from any self-collision and inside
the footprint."""

import math

import numpy as np
import pytest
from pydrake.geometry import Box, Capsule, Convex, Cylinder, Mesh, Role, Sphere
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph
from pydrake.planning import RobotDiagramBuilder, SceneGraphCollisionChecker
from pydrake.systems.framework import DiagramBuilder

from s3o_drake.feasibility.kinematics import arm_kinematics
from s3o_drake.world.resources import make_parser
from s3o_drake.world.robot import load_robot
from s3o_drake.world.robot_description import (
    RobotDescription,
    check_model,
    mimic_joints,
    robot_names,
)

#: Padding (m) between any two of the robot's bodies in the stow configuration.
SELF_CLEARANCE = 0.01
#: Random arm configurations on which the arm's kinematics are compared with the model.
SAMPLES = 200
#: The tool flange at zero joint angles in the arm's base frame (m), as its maker publishes
#: it: Universal Robots' UR5e DH parameters; Franka's Panda DH table (frankaemika/docs,
#: source/dh-parameters.csv: (0.088, 0, 0.926), pointing down).
PUBLISHED_FLANGE_AT_ZERO = {
    "ur5e": (-0.8172, -0.2329, 0.0628),
    "panda": (0.088, 0.0, 0.926),
}


class RobotModel:
    """A robot's description and its model (one, or its parts composed), alone in a plant,
    with a collision checker."""

    def __init__(self, name: str):
        self.robot = load_robot(name)
        self.description: RobotDescription = self.robot.description
        builder = RobotDiagramBuilder(time_step=0.0)
        self.placed = self.robot.add_model_instances(
            make_parser(builder.plant(), builder.scene_graph()))
        builder.plant().Finalize()
        self.diagram = builder.Build()
        self.plant = self.diagram.plant()
        self.scene_graph = self.diagram.scene_graph()
        self.context = self.diagram.CreateDefaultContext()
        self.plant_context = self.plant.GetMyMutableContextFromRoot(self.context)
        self.checker = SceneGraphCollisionChecker(
            model=self.diagram, robot_model_instances=list(self.placed.instances),
            edge_step_size=0.05)
        self.checker.SetPaddingAllRobotRobotPairs(SELF_CLEARANCE)
        arm = [self.placed.joint(name).position_start() for name in self.description.arm.joints]
        self.lower = self.plant.GetPositionLowerLimits()[arm]
        self.upper = self.plant.GetPositionUpperLimits()[arm]
        self.travel = self.description.gripper.travel

    def frame(self, name: str):
        return self.placed.frame(name)

    def positions(self, arm, fingers=None, base=(0.0, 0.0, 0.0)) -> np.ndarray:
        """The robot's positions (description.joints order) at a base pose (x, y, yaw),
        the gripper open unless `fingers` says."""
        return self.robot.positions(*base, arm=arm, gripper=fingers)

    def set(self, q: np.ndarray) -> None:
        self.placed.set_positions(self.plant_context, q)

    def collision_free(self, q: np.ndarray) -> bool:
        return self.checker.CheckConfigCollisionFree(self.placed.plant_positions(q))

    def pose(self, frame_a: str, frame_b: str) -> RigidTransform:
        """X_AB in the current configuration."""
        return self.plant.CalcRelativeTransform(self.plant_context, self.frame(frame_a),
                                                self.frame(frame_b))


@pytest.fixture(scope="module", params=robot_names())
def robot(request) -> RobotModel:
    return RobotModel(request.param)


def _support(shape, X_FG: RigidTransform, e_F: np.ndarray) -> float:
    """max over the points p of `shape` (posed at X_FG in frame F) of e_F . p_F."""
    R = X_FG.rotation().matrix()
    centre = float(e_F @ X_FG.translation())
    if isinstance(shape, Box):
        half = np.array([shape.width(), shape.depth(), shape.height()]) / 2
        return centre + float(np.sum(np.abs(R.T @ e_F) * half))
    if isinstance(shape, Sphere):
        return centre + shape.radius()
    cos_axis = abs(float(e_F @ R[:, 2]))
    if isinstance(shape, Capsule):
        return centre + shape.radius() + shape.length() / 2 * cos_axis
    if isinstance(shape, Cylinder):
        sin_axis = math.sqrt(max(0.0, 1.0 - cos_axis**2))
        return centre + shape.radius() * sin_axis + shape.length() / 2 * cos_axis
    if isinstance(shape, Mesh | Convex):
        hull = shape.GetConvexHull()
        p_FV = X_FG.multiply(np.array([hull.vertex(i) for i in range(hull.num_vertices())]).T)
        return float(np.max(e_F @ p_FV))
    raise AssertionError(f"unexpected shape {shape}")


@pytest.mark.parametrize("name", robot_names())
def test_the_fingertip_offset_is_the_fingers_farthest_reach_over_their_stroke(name):
    """A grasp leaves `fingertip_offset` above the table: no collision geometry of the
    gripper reaches farther along the tool's z, anywhere between open and closed (a linkage
    gripper's pads swing out as they close), and one reaches that far (within 0.5 mm)."""
    robot = load_robot(name)
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlantSceneGraph(builder, 0.0)
    placed = robot.add_model_instances(Parser(plant, scene_graph))
    plant.Finalize()
    context = plant.CreateDefaultContext()
    inspector = scene_graph.model_inspector()
    tool = placed.frame(robot.tool_frame)
    bodies = [placed.body(b) for b in robot.gripper_bodies]
    reach = []
    for s in np.linspace(0.0, 1.0, 17):
        q = robot.positions(0.0, 0.0, 0.0)
        q[robot.gripper_positions] = robot.gripper_open + s * (robot.gripper_closed -
                                                                robot.gripper_open)
        placed.set_positions(context, q)
        X_TW = tool.CalcPoseInWorld(context).inverse()
        reach.append(max(
            _support(inspector.GetShape(g), X_TW @ plant.EvalBodyPoseInWorld(context, body)
                     @ inspector.GetPoseInFrame(g), np.array([0.0, 0.0, 1.0]))
            for body in bodies for g in plant.GetCollisionGeometriesForBody(body)))
    assert max(reach) == pytest.approx(robot.fingertip_offset, abs=5e-4), reach


def test_the_description_agrees_with_its_model(robot):
    """Its joints are the model's, but for those that mimic another (a linkage gripper's),
    and the gripper opens and closes between its joints' limits."""
    check_model(robot.description)
    assert robot.plant.num_positions() == (len(robot.description.joints)
                                           + len(mimic_joints(robot.description)))
    for name, opened, closed in zip(robot.description.gripper.joints, robot.robot.gripper_open,
                                    robot.robot.gripper_closed, strict=True):
        joint = robot.placed.joint(name)
        limits = joint.position_lower_limits()[0], joint.position_upper_limits()[0]
        assert sorted((opened, closed)) == pytest.approx(limits, abs=1e-12)


def test_the_arms_kinematics_are_the_models_arm_chain(robot):
    """What the feasibility check moves puts the grasp frame where Drake does, in the arm's
    base frame, over the joint limits, which are the model's."""
    d = robot.description
    arm = arm_kinematics(load_robot(d.name))
    np.testing.assert_array_equal(arm.lower, robot.lower)
    np.testing.assert_array_equal(arm.upper, robot.upper)
    rng = np.random.default_rng(0)
    arms = rng.uniform(robot.lower, robot.upper, size=(SAMPLES, len(d.arm.joints)))
    R_AG, p_AG = arm.forward(arms)
    for i, q in enumerate(arms):
        robot.set(robot.positions(q, base=(0.4, -1.3, 2.0)))
        X_AG = robot.pose(d.arm.base_link, d.tool.grasp_frame)
        np.testing.assert_allclose(X_AG.translation(), p_AG[i], rtol=0, atol=1e-12)
        np.testing.assert_allclose(X_AG.rotation().matrix(), R_AG[i], rtol=0, atol=1e-12)


def test_the_flange_at_zero_angles_is_where_its_maker_says(robot):
    name = robot.description.name
    if name not in PUBLISHED_FLANGE_AT_ZERO:
        pytest.skip(f"no published flange position for {name!r}")
    d = robot.description
    robot.set(robot.positions(np.zeros(len(d.arm.joints))))
    # The tool frame is the flange turned about its z: the same point.
    X_AT = robot.pose(d.arm.base_link, d.tool.frame)
    np.testing.assert_allclose(X_AT.translation(), PUBLISHED_FLANGE_AT_ZERO[name], atol=1e-4)


def test_frames_and_gripper_are_where_the_description_says(robot):
    """The arm's base and the tray at their places in the base link, the grasp frame
    `grasp_offset` along the tool frame's z with the same axes, and centred between the
    fingers, which open along its y."""
    d = robot.description
    robot.set(robot.positions(d.configurations.stow))
    X_BA = robot.pose(d.base.link, d.arm.base_link)
    np.testing.assert_allclose(X_BA.translation(), d.arm.mount_xyz, atol=1e-12)
    assert X_BA.rotation().IsNearlyIdentity(1e-12)
    X_BT = robot.pose(d.base.link, d.tray.link)
    np.testing.assert_allclose(X_BT.translation(), d.tray.xyz, atol=1e-12)
    X_TG = robot.pose(d.tool.frame, d.tool.grasp_frame)
    assert X_TG.rotation().IsNearlyIdentity(1e-12)
    np.testing.assert_allclose(X_TG.translation(), [0.0, 0.0, d.tool.grasp_offset], atol=1e-12)
    assert d.tool.fingertip_offset > d.tool.grasp_offset
    if len(d.gripper.joints) != 2:
        return  # a linkage gripper's pads swing: test_robot_parts.py measures its opening
    left, right = (robot.placed.joint(j).child_body().name() for j in d.gripper.joints)
    for opening in (0.0, robot.travel / 2, robot.travel):
        robot.set(robot.positions(d.configurations.stow, fingers=[opening, opening]))
        p_GL = robot.pose(d.tool.grasp_frame, left).translation()
        p_GR = robot.pose(d.tool.grasp_frame, right).translation()
        assert p_GL[1] == pytest.approx(opening, abs=1e-12)
        assert p_GR[1] == pytest.approx(-opening, abs=1e-12)


def test_stow_is_within_the_limits_and_clear_of_self_collision(robot):
    d = robot.description
    stow = np.array(d.configurations.stow)
    assert np.all(robot.lower <= stow) and np.all(stow <= robot.upper)
    for fingers in (robot.robot.gripper_open, robot.robot.gripper_closed):
        for base in ((0.0, 0.0, 0.0), (3.2, -1.5, 2.4)):
            q = robot.positions(stow, fingers=fingers, base=base)
            assert robot.collision_free(q), (fingers, base)


def test_stowed_robot_stays_inside_the_footprint(robot):
    """Every geometry of the robot (collision and visual) in the stow configuration lies
    within the footprint in the base's x and y: its extent along ±x and ±y (exact for
    boxes, cylinders, capsules and spheres) at most half the length and width."""
    d = robot.description
    x, y, yaw = 1.0, -2.0, 0.8
    robot.set(robot.positions(d.configurations.stow, base=(x, y, yaw)))
    query = robot.scene_graph.get_query_output_port().Eval(
        robot.scene_graph.GetMyContextFromRoot(robot.context))
    inspector = query.inspector()
    X_WB = RigidTransform(RotationMatrix.MakeZRotation(yaw), [x, y, 0.0])
    assert robot.pose(d.base.link, d.base.link).IsExactlyIdentity()
    assert robot.frame(d.base.link).CalcPoseInWorld(
        robot.plant_context).IsNearlyEqualTo(X_WB, 1e-12)
    X_BW = X_WB.inverse()
    arm_bodies = {robot.placed.joint(j).child_body().index() for j in d.arm.joints}
    seen_arm = False
    for role in (Role.kProximity, Role.kIllustration):
        for geometry_id in inspector.GetAllGeometryIds(role):
            X_BG = X_BW @ query.GetPoseInWorld(geometry_id)
            shape = inspector.GetShape(geometry_id)
            body = robot.plant.GetBodyFromFrameId(inspector.GetFrameId(geometry_id))
            seen_arm |= body.index() in arm_bodies
            for e_B, half in (([1.0, 0, 0], d.base.length / 2), ([0, 1.0, 0], d.base.width / 2)):
                for sign in (1.0, -1.0):
                    extent = _support(shape, X_BG, sign * np.array(e_B))
                    assert extent <= half + 1e-9, (body.name(), inspector.GetName(geometry_id))
    assert seen_arm
