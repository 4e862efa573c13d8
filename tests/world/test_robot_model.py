"""The mobile manipulator's model: kinematics, actuation, collision geometry and control."""

import itertools
import math

import numpy as np
import pytest
from pydrake.geometry import Box, Cylinder, Role
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.inverse_kinematics import InverseKinematics
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import (
    AddMultibodyPlant,
    AddMultibodyPlantSceneGraph,
    MultibodyPlant,
    MultibodyPlantConfig,
)
from pydrake.solvers import Solve
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import TrajectorySource
from pydrake.trajectories import PiecewisePolynomial

from s3o_drake.world.resources import make_parser
from s3o_drake.world.robot import load_robot

UR5E = load_robot("ur5e")

UR5E_POSITION_LIMITS = (2 * math.pi, 2 * math.pi, math.pi, 2 * math.pi, 2 * math.pi, 2 * math.pi)
UR5E_EFFORT_LIMITS = (150.0, 150.0, 150.0, 28.0, 28.0, 28.0)
#: Published joint speed (180 deg/s, every joint) and the acceleration Universal Robots'
#: ROS 2 driver gives MoveIt (rad/s, rad/s²).
UR5E_SPEED_LIMIT = math.pi
UR5E_ACCELERATION_LIMIT = 5.0
BASE_BODIES = {"base_link", "lidar_link", "tray_link", "pedestal_link", "ur_base_link"}
GRIPPER_BODIES = {"gripper_base", "left_finger", "right_finger"}
# Gripper pointing straight down into the chassis behind the pedestal (upper arm backwards,
# forearm down, wrist down).
ARM_INTO_BASE = np.array([0.0, 0.0, math.pi / 2, -math.pi, -math.pi / 2, 0.0])


class RobotScene:
    """A continuous plant + scene graph holding only the robot, with a diagram context."""

    def __init__(self):
        builder = DiagramBuilder()
        self.plant, self.scene_graph = AddMultibodyPlantSceneGraph(builder, time_step=0.0)
        self.model = UR5E.add_to(make_parser(self.plant))
        self.plant.Finalize()
        self.diagram = builder.Build()
        self.context = self.diagram.CreateDefaultContext()
        self.plant_context = self.plant.GetMyContextFromRoot(self.context)

    def set_positions(self, q):
        self.plant.SetPositions(self.plant_context, self.model, q)

    def query_object(self):
        return self.scene_graph.get_query_output_port().Eval(
            self.scene_graph.GetMyContextFromRoot(self.context)
        )

    def body_name(self, inspector, geometry_id) -> str:
        return self.plant.GetBodyFromFrameId(inspector.GetFrameId(geometry_id)).name()

    def penetrating_body_pairs(self) -> set[tuple[str, str]]:
        query = self.query_object()
        inspector = query.inspector()
        return {
            tuple(sorted((self.body_name(inspector, p.id_A), self.body_name(inspector, p.id_B))))
            for p in query.ComputePointPairPenetration()
        }


@pytest.fixture(scope="module")
def scene() -> RobotScene:
    return RobotScene()


def _support(shape, X_FG: RigidTransform, e_F: np.ndarray) -> float:
    """max over the points p of `shape` (posed at X_FG in frame F) of e_F . p_F."""
    R = X_FG.rotation().matrix()
    centre = float(e_F @ X_FG.translation())
    if isinstance(shape, Box):
        half = np.array([shape.width(), shape.depth(), shape.height()]) / 2
        return centre + float(np.sum(np.abs(R.T @ e_F) * half))
    if isinstance(shape, Cylinder):
        cos_axis = abs(float(e_F @ R[:, 2]))
        sin_axis = math.sqrt(max(0.0, 1.0 - cos_axis**2))
        return centre + shape.radius() * sin_axis + shape.length() / 2 * cos_axis
    raise AssertionError(f"unexpected shape {shape}")


def test_model_size_and_names(scene):
    plant, model = scene.plant, scene.model
    assert plant.GetModelInstanceName(model) == "robot"
    assert plant.num_positions(model) == UR5E.num_positions == 11
    assert plant.num_velocities(model) == 11
    assert plant.num_actuators(model) == 11
    assert plant.num_positions() == 11  # only the robot in this plant


def test_joint_order_is_concatenation(scene):
    plant, model = scene.plant, scene.model
    names = plant.GetPositionNames(model, add_model_instance_prefix=False, always_add_suffix=False)
    assert tuple(names) == UR5E.joints
    velocity_names = plant.GetVelocityNames(
        model, add_model_instance_prefix=False, always_add_suffix=False
    )
    assert tuple(velocity_names) == UR5E.joints
    for i, joint_name in enumerate(UR5E.joints):
        joint = plant.GetJointByName(joint_name, model)
        assert joint.num_positions() == 1
        assert joint.position_start() == i
        assert joint.velocity_start() == i
    # The desired-state input is in actuator order; it must be the position order too.
    actuated = [
        plant.get_joint_actuator(i).joint().name() for i in plant.GetJointActuatorIndices(model)
    ]
    assert tuple(actuated) == UR5E.joints

    q = UR5E.positions(1.0, 2.0, 0.5)
    np.testing.assert_array_equal(q[:3], [1.0, 2.0, 0.5])
    np.testing.assert_array_equal(q[3:9], UR5E.arm_stow)
    np.testing.assert_array_equal(q[9:], UR5E.gripper_open)
    scene.set_positions(q)
    for joint_name, value in zip(UR5E.joints, q, strict=True):
        joint = plant.GetJointByName(joint_name, model)
        assert joint.GetOnePosition(scene.plant_context) == value


def test_robot_positions_rejects_wrong_sizes():
    with pytest.raises(ValueError, match="arm"):
        UR5E.positions(0.0, 0.0, 0.0, arm=np.zeros(5))
    with pytest.raises(ValueError, match="gripper"):
        UR5E.positions(0.0, 0.0, 0.0, gripper=np.zeros(3))
    with pytest.raises(ValueError):
        UR5E.arm_stow[0] = 1.0  # the named configurations are read-only


def test_desired_state_layout():
    q = UR5E.positions(0.1, 0.2, 0.3)
    xd = UR5E.desired_state(q)
    assert xd.shape == (22,)
    np.testing.assert_array_equal(xd[:11], q)
    np.testing.assert_array_equal(xd[11:], np.zeros(11))


def test_arm_joint_limits_are_ur5e(scene):
    plant, model = scene.plant, scene.model
    for joint_name, limit in zip(UR5E.arm_joints, UR5E_POSITION_LIMITS, strict=True):
        joint = plant.GetJointByName(joint_name, model)
        assert joint.position_lower_limits()[0] == pytest.approx(-limit)
        assert joint.position_upper_limits()[0] == pytest.approx(limit)
        assert joint.velocity_upper_limits()[0] == pytest.approx(math.pi)
        assert joint.velocity_lower_limits()[0] == pytest.approx(-math.pi)
    for actuator_index in plant.GetJointActuatorIndices(model):
        actuator = plant.get_joint_actuator(actuator_index)
        if actuator.joint().name() in UR5E.arm_joints:
            i = UR5E.arm_joints.index(actuator.joint().name())
            assert actuator.effort_limit() == pytest.approx(UR5E_EFFORT_LIMITS[i])
    yaw = plant.GetJointByName("base_yaw", model)
    assert np.isinf(yaw.position_upper_limits()[0]) and np.isinf(yaw.position_lower_limits()[0])
    for finger in UR5E.gripper_joints:
        joint = plant.GetJointByName(finger, model)
        assert joint.position_lower_limits()[0] == 0.0
        assert joint.position_upper_limits()[0] == pytest.approx(UR5E.finger_travel)


def test_arm_acceleration_limits_parse_and_fit_the_rated_torques(scene):
    """The URDF's drake:acceleration (5 rad/s², Universal Robots' MoveIt value) reaches the
    plant, and is one the UR5e can deliver: every joint at ±5 rad/s² and ±π rad/s at once,
    worst signs, with gravity (the simulation compensates it, a real arm must carry it),
    |M(q)| q̈ + |C(q, v) v| + |g(q)| stays within the rated joint torques."""
    plant, model = scene.plant, scene.model
    a_max = plant.GetAccelerationUpperLimits()
    np.testing.assert_array_equal(a_max[3:9], UR5E_ACCELERATION_LIMIT)
    np.testing.assert_array_equal(plant.GetAccelerationLowerLimits()[3:9],
                                  -UR5E_ACCELERATION_LIMIT)
    np.testing.assert_allclose(plant.GetVelocityUpperLimits()[3:9], UR5E_SPEED_LIMIT)
    context = plant.CreateDefaultContext()
    rng = np.random.default_rng(0)
    # Stretched out level (the largest gravity torque) and random configurations.
    arms = [np.zeros(6)] + [rng.uniform(-math.pi, math.pi, 6) for _ in range(40)]
    worst = np.zeros(6)
    for arm in arms:
        plant.SetPositions(context, model, UR5E.positions(0.0, 0.0, 0.0, arm=arm))
        M = plant.CalcMassMatrix(context)[3:9, 3:9]
        g = plant.CalcGravityGeneralizedForces(context)[3:9]
        inertial = np.abs(M) @ a_max[3:9]
        for signs in itertools.product((-1.0, 1.0), repeat=6):
            v = np.zeros(11)
            v[3:9] = UR5E_SPEED_LIMIT * np.array(signs)
            plant.SetVelocities(context, model, v)
            bias = plant.CalcBiasTerm(context)[3:9]
            worst = np.maximum(worst, (inertial + np.abs(bias) + np.abs(g))
                               / np.array(UR5E_EFFORT_LIMITS))
    assert np.all(worst < 1.0), worst


def test_masses(scene):
    plant, model = scene.plant, scene.model
    mass = {
        plant.get_body(i).name(): plant.get_body(i).default_mass()
        for i in plant.GetBodyIndices(model)
    }
    base = sum(mass[name] for name in BASE_BODIES - {"ur_base_link"})
    arm = sum(
        mass[name]
        for name in (
            "ur_base_link",
            "shoulder_link",
            "upper_arm_link",
            "forearm_link",
            "wrist_1_link",
            "wrist_2_link",
            "wrist_3_link",
        )
    )
    gripper = sum(mass[name] for name in GRIPPER_BODIES)
    assert base == pytest.approx(100.0, abs=2.0)
    assert arm == pytest.approx(20.6, abs=1.5)
    assert gripper == pytest.approx(1.0, abs=0.1)
    for name in ("base_x_link", "base_y_link"):
        assert 0.0 < mass[name] < 0.1


def test_tool_flange_at_zero_angles_matches_ur5e(scene):
    plant = scene.plant
    scene.set_positions(UR5E.positions(0.3, -0.2, 1.0, arm=np.zeros(6)))
    X_AT = plant.CalcRelativeTransform(
        scene.plant_context,
        plant.GetFrameByName(UR5E.arm_base_link),
        plant.GetFrameByName(UR5E.tool_frame),
    )
    np.testing.assert_allclose(X_AT.translation(), [-0.8172, -0.2329, 0.0628], atol=1e-4)


def test_arm_mount_and_tray_frames(scene):
    plant = scene.plant
    scene.set_positions(UR5E.positions(0.0, 0.0, 0.0))
    base = plant.GetFrameByName(UR5E.base_link)
    X_BA = plant.CalcRelativeTransform(
        scene.plant_context, base, plant.GetFrameByName(UR5E.arm_base_link)
    )
    np.testing.assert_allclose(X_BA.translation(), UR5E.arm_mount_xyz, atol=1e-12)
    assert X_BA.rotation().IsNearlyIdentity(1e-12)
    X_BT = plant.CalcRelativeTransform(
        scene.plant_context, base, plant.GetFrameByName(UR5E.tray_link)
    )
    np.testing.assert_allclose(X_BT.translation(), UR5E.tray_xyz, atol=1e-12)
    X_BL = plant.CalcRelativeTransform(
        scene.plant_context, base, plant.GetFrameByName(UR5E.lidar_link)
    )
    assert X_BL.translation()[2] == pytest.approx(0.45, abs=0.02)
    assert X_BL.translation()[0] > 0.2  # near the front


def test_grasp_frame_beyond_flange(scene):
    plant = scene.plant
    scene.set_positions(UR5E.positions(0.0, 0.0, 0.0, gripper=UR5E.gripper_closed))
    X_TG = plant.CalcRelativeTransform(
        scene.plant_context,
        plant.GetFrameByName(UR5E.tool_frame),
        plant.GetFrameByName(UR5E.grasp_frame),
    )
    assert X_TG.rotation().IsNearlyIdentity(1e-12)
    np.testing.assert_allclose(X_TG.translation(), [0.0, 0.0, UR5E.grasp_offset], atol=1e-12)
    assert 0.22 <= UR5E.grasp_offset <= 0.24
    # The grasp frame is centred between the fingers at any opening.
    for opening in (0.0, 0.03, UR5E.finger_travel):
        scene.set_positions(UR5E.positions(0, 0, 0, gripper=[opening, opening]))
        grasp = plant.GetFrameByName(UR5E.grasp_frame)
        p_GL = plant.GetFrameByName("left_finger").CalcPose(scene.plant_context, grasp)
        p_GR = plant.GetFrameByName("right_finger").CalcPose(scene.plant_context, grasp)
        np.testing.assert_allclose(p_GL.translation()[1], opening, atol=1e-12)
        np.testing.assert_allclose(p_GR.translation()[1], -opening, atol=1e-12)


def test_every_actuator_has_pd_gains(scene):
    plant, model = scene.plant, scene.model
    indices = plant.GetJointActuatorIndices(model)
    assert len(indices) == 11
    for i in indices:
        actuator = plant.get_joint_actuator(i)
        assert actuator.has_controller(), actuator.name()
        gains = actuator.get_controller_gains()
        assert gains.p > 0 and gains.d > 0, actuator.name()
        assert actuator.effort_limit() > 0 and np.isfinite(actuator.effort_limit())
    effort = {
        plant.get_joint_actuator(i).joint().name(): plant.get_joint_actuator(i).effort_limit()
        for i in indices
    }
    # The base drives ~123 kg at 0.5 m/s^2 with plenty of margin.
    assert effort["base_x"] >= 5 * 123 * 0.5
    assert effort["base_y"] >= 5 * 123 * 0.5


@pytest.mark.parametrize("arm", [UR5E.arm_stow, np.zeros(6)], ids=["stow", "zero"])
@pytest.mark.parametrize("base", [(0.0, 0.0, 0.0), (3.2, -1.5, 2.4), (-7.0, 4.0, -0.9)])
def test_no_self_collision(scene, arm, base):
    for gripper in (UR5E.gripper_open, UR5E.gripper_closed):
        scene.set_positions(UR5E.positions(*base, arm=arm, gripper=gripper))
        query = scene.query_object()
        assert not query.HasCollisions()
        assert scene.penetrating_body_pairs() == set()


def test_stow_keeps_clearance(scene):
    scene.set_positions(UR5E.positions(0.0, 0.0, 0.0))
    query = scene.query_object()
    distances = query.ComputeSignedDistancePairwiseClosestPoints(max_distance=0.05)
    assert min(d.distance for d in distances) > 0.01


def test_gripper_folded_into_base_collides(scene):
    scene.set_positions(UR5E.positions(1.0, 1.0, 0.3, arm=ARM_INTO_BASE))
    assert scene.query_object().HasCollisions()
    pairs = scene.penetrating_body_pairs()
    assert any({a, b} & GRIPPER_BODIES and {a, b} & BASE_BODIES for a, b in pairs), pairs


def test_arm_folded_onto_itself_collides(scene):
    # Elbow folded almost fully: the wrist runs into the shoulder and the upper arm.
    arm = np.array([math.pi, -math.pi / 2 - 0.6, 2.9, 0.0, 0.0, 0.0])
    scene.set_positions(UR5E.positions(0.0, 0.0, 0.0, arm=arm))
    pairs = scene.penetrating_body_pairs()
    assert ("shoulder_link", "wrist_1_link") in pairs or ("upper_arm_link", "wrist_1_link") in pairs


def test_fingers_touching_is_not_a_collision(scene):
    scene.set_positions(UR5E.positions(0.0, 0.0, 0.0, gripper=UR5E.gripper_closed))
    query = scene.query_object()
    inspector = query.inspector()
    left = scene.plant.GetBodyByName("left_finger").index()
    right = scene.plant.GetBodyByName("right_finger").index()
    left_ids = inspector.GetGeometries(scene.plant.GetBodyFrameIdOrThrow(left), Role.kProximity)
    right_ids = inspector.GetGeometries(scene.plant.GetBodyFrameIdOrThrow(right), Role.kProximity)
    assert left_ids and right_ids
    assert all(inspector.CollisionFiltered(a, b) for a in left_ids for b in right_ids)


@pytest.mark.parametrize("base", [(0.0, 0.0, 0.0), (2.0, -1.0, 0.7), (-3.0, 5.0, -2.5)])
def test_robot_positions_place_base_link(scene, base):
    x, y, yaw = base
    scene.set_positions(UR5E.positions(x, y, yaw))
    X_WB = scene.plant.GetFrameByName(UR5E.base_link).CalcPoseInWorld(scene.plant_context)
    X_WB_expected = RigidTransform(RotationMatrix.MakeZRotation(yaw), [x, y, 0.0])
    assert X_WB.IsNearlyEqualTo(X_WB_expected, 1e-12)


def test_footprint_polygon():
    assert math.isclose(UR5E.base_radius, math.hypot(0.31, 0.28))
    footprint = UR5E.footprint(0.0, 0.0, 0.0)
    assert footprint.area == pytest.approx(0.62 * 0.56)
    assert footprint.bounds == pytest.approx((-0.31, -0.28, 0.31, 0.28))
    turned = UR5E.footprint(1.0, 2.0, math.pi / 2)
    assert turned.area == pytest.approx(0.62 * 0.56)
    assert turned.bounds == pytest.approx((1.0 - 0.28, 2.0 - 0.31, 1.0 + 0.28, 2.0 + 0.31))
    oblique = UR5E.footprint(-1.0, 0.5, 0.4)
    assert oblique.area == pytest.approx(0.62 * 0.56)
    assert oblique.centroid.coords[0] == pytest.approx((-1.0, 0.5))
    corner = np.array(oblique.exterior.coords[0])
    assert np.linalg.norm(corner - [-1.0, 0.5]) == pytest.approx(UR5E.base_radius)


def test_stowed_robot_stays_inside_footprint(scene):
    """All geometry (visual and collision) in stow lies within the footprint in x and y."""
    x, y, yaw = 1.0, -2.0, 0.8
    scene.set_positions(UR5E.positions(x, y, yaw))
    query = scene.query_object()
    inspector = query.inspector()
    X_BW = (
        scene.plant.GetFrameByName(UR5E.base_link).CalcPoseInWorld(scene.plant_context).inverse()
    )
    geometry_ids = inspector.GetAllGeometryIds()
    assert len(geometry_ids) > 30
    top = 0.0
    for geometry_id in geometry_ids:
        X_BG = X_BW @ query.GetPoseInWorld(geometry_id)
        shape = inspector.GetShape(geometry_id)
        for e_B, half in (([1, 0, 0], 0.31), ([0, 1, 0], 0.28)):
            for sign in (1, -1):
                extent = _support(shape, X_BG, sign * np.array(e_B, dtype=float))
                assert extent <= half + 1e-9, inspector.GetName(geometry_id)
        top = max(top, _support(shape, X_BG, np.array([0.0, 0.0, 1.0])))
    assert top < 1.45  # a compact stow


def _simulate_robot(time_step, trajectory, q0, duration):
    builder = DiagramBuilder()
    plant, _ = AddMultibodyPlant(
        MultibodyPlantConfig(time_step=time_step, discrete_contact_approximation="sap"), builder
    )
    model = UR5E.add_to(make_parser(plant))
    plant.set_gravity_enabled(model, False)
    plant.Finalize()
    source = builder.AddSystem(TrajectorySource(trajectory, output_derivative_order=1))
    builder.Connect(source.get_output_port(), plant.get_desired_state_input_port(model))
    simulator = Simulator(builder.Build())
    plant_context = plant.GetMyContextFromRoot(simulator.get_mutable_context())
    plant.SetPositions(plant_context, model, q0)
    errors = []
    for t in np.arange(0.0, duration + 1e-9, 0.02):
        simulator.AdvanceTo(t)
        errors.append(plant.GetPositions(plant_context, model) - trajectory.value(t).ravel())
    return np.abs(np.array(errors))


def test_holds_stow_with_fixed_desired_state():
    builder = DiagramBuilder()
    plant, _ = AddMultibodyPlant(
        MultibodyPlantConfig(time_step=1e-3, discrete_contact_approximation="sap"), builder
    )
    model = UR5E.add_to(make_parser(plant))
    plant.set_gravity_enabled(model, False)
    plant.Finalize()
    diagram = builder.Build()
    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    plant_context = plant.GetMyContextFromRoot(context)
    q_desired = UR5E.positions(0.5, -0.3, 0.2)
    plant.get_desired_state_input_port(model).FixValue(
        plant_context, UR5E.desired_state(q_desired)
    )
    # Starting at the setpoint, the robot stays there.
    plant.SetPositions(plant_context, model, q_desired)
    for t in np.arange(0.1, 1.0 + 1e-9, 0.1):
        simulator.AdvanceTo(t)
        error = np.abs(plant.GetPositions(plant_context, model) - q_desired)
        assert error.max() < 1e-3, t
    # Pushed 2 cm / 20 mrad off the setpoint, the PD controllers pull it back.
    plant.SetPositions(plant_context, model, q_desired + np.r_[0.02, -0.02, 0.02, [0.02] * 6, 0, 0])
    plant.SetVelocities(plant_context, model, np.zeros(UR5E.num_positions))
    simulator.AdvanceTo(2.0)
    error = np.abs(plant.GetPositions(plant_context, model) - q_desired)
    assert error.max() < 1e-3
    simulator.AdvanceTo(2.5)
    error = np.abs(plant.GetPositions(plant_context, model) - q_desired)
    assert error.max() < 1e-4
    assert np.abs(plant.GetVelocities(plant_context, model)).max() < 1e-3


def test_tracks_moving_base_setpoint():
    q0 = UR5E.positions(0.0, 0.0, 0.0)
    times = [0.0, 0.5, 1.5, 2.5, 3.0]
    base = np.array([[0, 0, 0], [0, 0, 0], [0.4, 0.2, 0.5], [0.8, 0.4, 1.0], [0.8, 0.4, 1.0]])
    knots = np.hstack([base, np.tile(q0[3:], (len(times), 1))]).T
    trajectory = PiecewisePolynomial.CubicShapePreserving(
        times, knots, zero_end_point_derivatives=True
    )
    errors = _simulate_robot(2e-3, trajectory, q0, duration=3.5)
    assert errors[:, :2].max() < 0.01  # base x, y (m) while accelerating
    assert errors[:, 2].max() < 0.01  # base yaw (rad)
    assert errors[:, 3:].max() < 0.002  # arm and fingers disturbed by the base's motion
    assert errors[-1].max() < 1e-3  # settled at the end


def test_parses_with_a_plain_parser():
    plant = MultibodyPlant(0.0)
    first = UR5E.add_to(Parser(plant))
    second = UR5E.add_to(Parser(plant), name="robot2")
    plant.Finalize()
    assert plant.GetModelInstanceName(first) == "robot"
    assert plant.GetModelInstanceName(second) == "robot2"
    assert plant.num_positions() == 22
    with pytest.raises(ValueError, match="robot"):
        unfinalized = MultibodyPlant(0.0)
        UR5E.add_to(Parser(unfinalized))
        UR5E.add_to(Parser(unfinalized))


def _solve_top_grasp(scene, p_WQ, seed_arm):
    """IK: grasp_frame at p_WQ pointing down, base locked at the origin, no self-collision."""
    plant = scene.plant
    ik = InverseKinematics(plant, scene.plant_context, with_joint_limits=True)
    q = ik.q()
    prog = ik.prog()
    prog.AddBoundingBoxConstraint(np.zeros(3), np.zeros(3), q[:3])
    prog.AddBoundingBoxConstraint(UR5E.gripper_open, UR5E.gripper_open, q[9:])
    grasp = plant.GetFrameByName(UR5E.grasp_frame)
    ik.AddPositionConstraint(grasp, np.zeros(3), plant.world_frame(), p_WQ, p_WQ)
    ik.AddAngleBetweenVectorsConstraint(
        grasp, [0.0, 0.0, 1.0], plant.world_frame(), [0.0, 0.0, -1.0], 0.0, 0.0
    )
    ik.AddMinimumDistanceLowerBoundConstraint(0.01)
    q_seed = UR5E.positions(0.0, 0.0, 0.0, arm=seed_arm)
    prog.AddQuadraticErrorCost(0.01 * np.eye(len(q_seed)), q_seed, q)
    prog.SetInitialGuess(q, q_seed)
    result = Solve(prog)
    return result.is_success(), result.GetSolution(q)


def test_top_grasp_reaches_table_height(scene):
    p_WQ = np.array([0.8, 0.0, 0.78])
    # Arm forward: upper arm up and forward, elbow up, wrist down.
    seed = np.array([0.2, -2.0, -1.5, -1.2, math.pi / 2, 0.0])
    success, q = _solve_top_grasp(scene, p_WQ, seed)
    assert success
    scene.set_positions(q)
    X_WG = scene.plant.GetFrameByName(UR5E.grasp_frame).CalcPoseInWorld(scene.plant_context)
    np.testing.assert_allclose(X_WG.translation(), p_WQ, atol=1e-4)
    np.testing.assert_allclose(X_WG.rotation().matrix()[:, 2], [0, 0, -1], atol=1e-4)
    np.testing.assert_allclose(q[:3], 0.0, atol=1e-9)
    assert not scene.query_object().HasCollisions()
