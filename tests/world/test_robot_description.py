"""A robot's description file: the shipped UR5e's agrees with its model, and a description
that cannot be used is refused with the field named."""

import math

import pytest

from s3o_drake.world.robot import load_robot
from s3o_drake.world.robot_description import (
    RobotDescriptionError,
    check_model,
    load_robot_description,
    parse_robot_description,
    robot_description_path,
)

UR5E = robot_description_path("ur5e").read_text()
UR5E_ROBOT = load_robot("ur5e")


def test_the_ur5e_description_agrees_with_its_model_and_is_what_the_package_uses():
    ur5e = load_robot_description("ur5e")
    check_model(ur5e)
    assert ur5e == UR5E_ROBOT.description
    assert tuple(ur5e.joints) == UR5E_ROBOT.joints and UR5E_ROBOT.num_positions == 11
    # The stow configuration keeps the gripper pointing down (q2 + q3 + q4 = -pi/2).
    assert sum(UR5E_ROBOT.arm_stow[1:4]) == pytest.approx(-math.pi / 2, abs=1e-12)
    assert math.hypot(0.31, 0.28) == pytest.approx(UR5E_ROBOT.base_radius)


@pytest.mark.parametrize("old, new, path", [
    ("velocity_limits: [3.141592653589793, 3.141592653589793, 3.141592653589793,",
     "velocity_limits: [3.141592653589793, 3.141592653589793, 3.0,", "arm.velocity_limits[2]"),
    ("acceleration_limits: [5.0, 5.0,", "acceleration_limits: [5.0, 4.0,",
     "arm.acceleration_limits[1]"),
    ("wrist_3_joint]", "wrist_4_joint]", "joints"),
    ("grasp_frame: grasp_frame", "grasp_frame: gripper_tip", "tool.grasp_frame"),
    ("bodies: [gripper_base,", "bodies: [palm,", "gripper.bodies"),
    ("joints: [base_x, base_y, base_yaw]", "joints: [base_yaw, base_y, base_x]",
     "base.joints"),
    ("position_upper: [6.283185307179586, 6.283185307179586, 3.141592653589793,",
     "position_upper: [6.283185307179586, 6.283185307179586, 3.0,", "arm.position_upper[2]"),
], ids=["speed", "acceleration", "joint", "frame", "body", "base order", "position"])
def test_a_description_that_disagrees_with_its_model_is_named(old, new, path):
    assert UR5E.count(old) == 1
    with pytest.raises(RobotDescriptionError) as error:
        check_model(parse_robot_description(UR5E.replace(old, new)))
    assert error.value.path == path and "\n" not in str(error.value)


@pytest.mark.parametrize("old, new, path", [
    ("reach: 1.0", "reach: -1.0", "reach"),
    ("reach: 1.0", "reach: 1.0\nspeed: 2.0", "speed"),
    ("stow: [0.0, -1.3,", "stow: [-1.3,", "configurations.stow"),
    ("acceleration_limits: [5.0,", "acceleration_limits: [0.0,", "arm.acceleration_limits[0]"),
    ("joints: [left_finger_joint, right_finger_joint]",
     "joints: [left_finger_joint, elbow_joint]", "joints"),
    ("width: 0.56", "width: wide", "base.width"),
    ("name: ur5e", "name: ''", "name"),
    ("inverse_kinematics: ur", "inverse_kinematics: analytic", "arm.inverse_kinematics"),
    ("stow: [0.0, -1.3, 2.7,", "stow: [0.0, -1.3, 3.2,", "configurations.stow[2]"),
    # The arm's kinematics are read from its model: a typed DH table is not a field.
    ("inverse_kinematics: ur", "inverse_kinematics: ur\n  dh_a: [0.0, -0.425, -0.3922, 0, 0, 0]",
     "arm.dh_a"),
], ids=["negative", "unknown field", "stow", "zero limit", "twice", "type", "empty",
        "ik family", "stow limits", "typed kinematics"])
def test_a_description_that_cannot_be_used_names_the_field(old, new, path):
    assert UR5E.count(old) == 1
    with pytest.raises(RobotDescriptionError) as error:
        parse_robot_description(UR5E.replace(old, new))
    assert error.value.path == path and "\n" not in str(error.value)


def test_an_unknown_robot_is_refused_with_the_names_of_those_there_are():
    with pytest.raises(RobotDescriptionError, match=r"no robot named 'r2d2' \(known: .*ur5e"):
        load_robot_description("r2d2")
