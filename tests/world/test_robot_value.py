"""A robot is a value: two robots in one process, each loaded and checked once."""

import numpy as np
import pytest
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant

from s3o_drake.world.robot import Robot, load_robot
from s3o_drake.world.robot_description import RobotDescriptionError


def test_two_robots_side_by_side_in_one_process():
    ur5e, panda = load_robot("ur5e"), load_robot("panda")
    assert isinstance(ur5e, Robot) and isinstance(panda, Robot)
    assert (ur5e.name, panda.name) == ("ur5e", "panda")
    assert (ur5e.num_arm_joints, panda.num_arm_joints) == (6, 7)
    assert (ur5e.num_positions, panda.num_positions) == (11, 12)
    assert ur5e.files.time_model.parent.name == "ur5e"
    assert panda.files.time_model.parent.name == "panda"
    # Each parses into a plant of its own, its positions in the value's joint order.
    for robot in (ur5e, panda):
        plant = MultibodyPlant(0.0)
        model = robot.add_to(Parser(plant))
        plant.Finalize()
        assert plant.num_positions(model) == robot.num_positions
        q = robot.positions(1.0, 2.0, 0.5)
        plant.SetPositions(plant.CreateDefaultContext(), model, q)
        assert [plant.get_joint(i).name() for i in plant.GetJointIndices(model)
                if plant.get_joint(i).num_positions()][:robot.num_positions] == list(
                    robot.joints)


def test_loading_again_is_cheap_and_gives_the_same_value():
    assert load_robot("ur5e") is load_robot("ur5e")
    assert load_robot() is load_robot("ur5e")  # a missing name means the UR5e


def test_an_unknown_robot_is_refused_with_the_field_named():
    with pytest.raises(RobotDescriptionError) as error:
        load_robot("r2d2")
    assert error.value.path == "robot" and "ur5e" in str(error.value)


def test_positions_and_desired_state_have_the_robot_s_layout():
    panda = load_robot("panda")
    q = panda.positions(1.0, 2.0, 0.5)
    np.testing.assert_array_equal(q[panda.arm_positions], panda.arm_stow)
    np.testing.assert_array_equal(q[panda.gripper_positions], panda.gripper_open)
    assert panda.desired_state(q).shape == (2 * panda.num_positions,)
    with pytest.raises(ValueError, match="arm: expected 7 joint angles, got 6"):
        panda.positions(0.0, 0.0, 0.0, arm=load_robot("ur5e").arm_stow)
    footprint = panda.footprint(0.0, 0.0, 0.0)
    assert footprint.area == pytest.approx(panda.base_length * panda.base_width)
    assert panda.inscribed_radius == panda.base_width / 2
