"""The UR family's closed form on lengths read from the arm's model: the UR5e's are its
maker's, its eight branches put the grasp frame where Drake's plant does, and an arm that is
not UR-shaped is refused for it, the robot and the error named."""

import dataclasses

import numpy as np
import pytest
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant

from s3o_drake.feasibility import kinematics
from s3o_drake.feasibility.kinematics import ArmKinematics
from s3o_drake.feasibility.ur_inverse import NUM_BRANCHES, URGeometry, ur_inverse
from s3o_drake.world.angles import wrap
from s3o_drake.world.robot import Robot, RobotFiles, load_robot
from s3o_drake.world.robot_description import RobotDescriptionError

UR5E = load_robot("ur5e")
#: Universal Robots' UR5e DH lengths (m), and the grasp point 0.225 m beyond the flange
#: (models/ur5e/robot.yaml: tool.grasp_offset).
UR5E_LENGTHS = URGeometry(d1=0.1625, a2=-0.425, a3=-0.3922, d4=0.1333, d5=0.0997, d6=0.0996,
                          tool_offset=0.225)


def test_the_ur5es_lengths_read_from_its_model_are_its_makers_to_the_last_digit():
    # Rounded to LENGTH_RESOLUTION, the fit gives the model's own decimals: the same
    # closed-form solutions, to the last bit, as a table typed from the maker's numbers.
    assert kinematics.arm_kinematics(UR5E).ur == UR5E_LENGTHS


def test_every_branch_puts_the_grasp_frame_where_the_plant_does():
    plant = MultibodyPlant(0.0)
    model = UR5E.add_to(Parser(plant))
    plant.Finalize()
    context = plant.CreateDefaultContext()
    A = plant.GetFrameByName(UR5E.arm_base_link, model)
    G = plant.GetFrameByName(UR5E.grasp_frame, model)

    def X_AG(q):
        plant.SetPositions(context, model, UR5E.positions(0.0, 0.0, 0.0, arm=q))
        return plant.CalcRelativeTransform(context, A, G)

    arm = kinematics.arm_kinematics(UR5E)
    q = arm.random_configurations(20, seed=7)
    targets = [X_AG(qi) for qi in q]
    R = np.array([X.rotation().matrix() for X in targets])
    p = np.array([X.translation() for X in targets])
    solutions = ur_inverse(arm.ur, R, p)
    assert solutions.shape == (20, NUM_BRANCHES, 6)
    for i, target in enumerate(targets):
        # The configuration the target came from is among the branches.
        assert np.nanmin(np.abs(wrap(solutions[i] - q[i])).max(axis=1)) < 1e-9
        for candidate in solutions[i][~np.isnan(solutions[i]).any(axis=1)]:
            X = X_AG(candidate)
            np.testing.assert_allclose(X.translation(), target.translation(), atol=1e-9)
            np.testing.assert_allclose(X.rotation().matrix(), target.rotation().matrix(),
                                       atol=1e-9)


def _ur5e_with_a_wrist_offset(tmp_path) -> Robot:
    """The UR5e with its wrist 2 joint 2 cm off wrist 1's axis: six joints, but not the UR
    family's geometry (its table's a4 is zero)."""
    urdf = UR5E.model_file.read_text()
    old = '<origin xyz="0 0 0.1333" rpy="1.5707963267948966 0 0"/>'
    assert urdf.count(old) == 1
    path = tmp_path / "offset_wrist.urdf"
    path.write_text(urdf.replace(old, old.replace('xyz="0 0', 'xyz="0.02 0')))
    description = dataclasses.replace(UR5E.description, model=f"file://{path}")
    return Robot(description, RobotFiles(tmp_path))


def test_an_arm_that_is_not_ur_shaped_is_refused_for_the_closed_form(tmp_path):
    robot = _ur5e_with_a_wrist_offset(tmp_path)
    with pytest.raises(RobotDescriptionError) as error:
        ArmKinematics.of(robot)
    message = str(error.value)
    assert error.value.path == "arm.inverse_kinematics" and "\n" not in message
    assert "'ur5e'" in message and "misses the model's grasp frame by up to" in message
    worst = float(message.split("by up to ")[1].split()[0])
    assert worst > 1e-3  # of the order of the 2 cm offset
    # The same arm is accepted for the numeric family: the check is the closed form's.
    numeric = dataclasses.replace(robot.description.arm, inverse_kinematics="numeric")
    robot = Robot(dataclasses.replace(robot.description, arm=numeric), robot.files)
    assert ArmKinematics.of(robot).ur is None
