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


#: The end of the UR5e's `arm.limits_source`, where a test inserts `arm.limit_overrides`.
LIMITS_END = "in this\n    model (the URDF's comment).\n"


def _with_override(entry: str) -> str:
    """The UR5e's description with one limit override, `entry` its flow mapping's fields."""
    assert UR5E.count(LIMITS_END) == 1
    return UR5E.replace(LIMITS_END, LIMITS_END + f"  limit_overrides:\n    - {{{entry}}}\n")


@pytest.mark.parametrize("old, new, path", [
    ("wrist_3_joint]", "wrist_4_joint]", "joints"),
    ("grasp_frame: grasp_frame", "grasp_frame: gripper_tip", "tool.grasp_frame"),
    ("bodies: [gripper_base,", "bodies: [palm,", "gripper.bodies"),
    ("joints: [base_x, base_y, base_yaw]", "joints: [base_yaw, base_y, base_x]",
     "base.joints"),
    ("stow: [0.0, -1.3, 2.7,", "stow: [0.0, -1.3, 3.2,", "configurations.stow[2]"),
], ids=["joint", "frame", "body", "base order", "stow limits"])
def test_a_description_that_disagrees_with_its_model_is_named(old, new, path):
    assert UR5E.count(old) == 1
    with pytest.raises(RobotDescriptionError) as error:
        check_model(parse_robot_description(UR5E.replace(old, new)))
    assert error.value.path == path and "\n" not in str(error.value)


@pytest.mark.parametrize("old, new, path", [
    ("reach: 1.0", "reach: -1.0", "reach"),
    ("reach: 1.0", "reach: 1.0\nspeed: 2.0", "speed"),
    ("stow: [0.0, -1.3,", "stow: [-1.3,", "configurations.stow"),
    ("joints: [left_finger_joint, right_finger_joint]",
     "joints: [left_finger_joint, elbow_joint]", "joints"),
    ("width: 0.56", "width: wide", "base.width"),
    ("name: ur5e", "name: ''", "name"),
    ("inverse_kinematics: ur", "inverse_kinematics: analytic", "arm.inverse_kinematics"),
    # The arm's kinematics and limits are read from its model: typing them is not a field.
    ("inverse_kinematics: ur", "inverse_kinematics: ur\n  dh_a: [0.0, -0.425, -0.3922, 0, 0, 0]",
     "arm.dh_a"),
    ("inverse_kinematics: ur", "inverse_kinematics: ur\n  velocity_limits: [3.0]",
     "arm.velocity_limits"),
], ids=["negative", "unknown field", "stow", "twice", "type", "empty", "ik family",
        "typed kinematics", "typed limits"])
def test_a_description_that_cannot_be_used_names_the_field(old, new, path):
    assert UR5E.count(old) == 1
    with pytest.raises(RobotDescriptionError) as error:
        parse_robot_description(UR5E.replace(old, new))
    assert error.value.path == path and "\n" not in str(error.value)


def test_an_unknown_robot_is_refused_with_the_names_of_those_there_are():
    with pytest.raises(RobotDescriptionError, match=r"no robot named 'r2d2' \(known: .*ur5e"):
        load_robot_description("r2d2")


@pytest.mark.parametrize("entry, path", [
    ("joint: elbow_joint, velocity: 0.0, source: a test", "arm.limit_overrides[0].velocity"),
    ("joint: elbow_joint, acceleration: .inf, source: a test",
     "arm.limit_overrides[0].acceleration"),
    ("joint: elbow_joint, position_upper: 3.0", "arm.limit_overrides[0].source"),
    ("joint: finger_joint, velocity: 1.0, source: a test", "arm.limit_overrides[0].joint"),
    ("joint: elbow_joint, source: a test", "arm.limit_overrides[0]"),
], ids=["zero speed", "infinite", "no source", "not an arm joint", "nothing"])
def test_a_limit_override_that_cannot_be_used_names_the_field(entry, path):
    with pytest.raises(RobotDescriptionError) as error:
        parse_robot_description(_with_override(entry))
    assert error.value.path == path and "\n" not in str(error.value)


def test_a_limit_override_replaces_the_models_where_the_robot_is_parsed():
    from pydrake.multibody.parsing import Parser
    from pydrake.multibody.plant import MultibodyPlant

    from s3o_drake.world.robot import Robot

    description = parse_robot_description(_with_override(
        "joint: elbow_joint, position_lower: -2.5, velocity: 2.0, acceleration: 4.0, "
        "source: a test"))
    check_model(description)
    (override,) = description.arm.limit_overrides
    assert override.position_upper is None and override.source == "a test"
    plant = MultibodyPlant(0.0)
    model = Robot(description, UR5E_ROBOT.files).add_to(Parser(plant))
    plant.Finalize()
    elbow = plant.GetJointByName("elbow_joint", model)
    assert elbow.position_lower_limits()[0] == -2.5
    assert elbow.position_upper_limits()[0] == math.pi  # the model's
    assert elbow.velocity_upper_limits()[0] == 2.0 and elbow.velocity_lower_limits()[0] == -2.0
    assert elbow.acceleration_upper_limits()[0] == 4.0
    shoulder = plant.GetJointByName("shoulder_lift_joint", model)
    assert shoulder.velocity_upper_limits()[0] == math.pi  # not overridden
    # An override that leaves the stow configuration outside is refused with the model.
    with pytest.raises(RobotDescriptionError) as error:
        check_model(parse_robot_description(_with_override(
            "joint: elbow_joint, position_upper: 2.5, source: a test")))
    assert error.value.path == "configurations.stow[2]"
