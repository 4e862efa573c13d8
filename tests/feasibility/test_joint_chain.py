"""The arm's chain read from its model agrees with Drake's plant, for every shipped arm."""

import numpy as np
import pytest
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant

from s3o_drake.feasibility.joint_chain import JointChain
from s3o_drake.world.robot import load_robot


def _plant(name: str):
    robot = load_robot(name)
    plant = MultibodyPlant(0.0)
    model = robot.add_to(Parser(plant))
    plant.Finalize()
    return robot, plant, model


def _chain(robot, plant, model, joints=None) -> JointChain:
    return JointChain.of_plant(
        plant, base=plant.GetFrameByName(robot.arm_base_link, model),
        tool=plant.GetFrameByName(robot.grasp_frame, model),
        joints=[plant.GetJointByName(name, model) for name in joints or robot.arm_joints])


@pytest.mark.parametrize("name", ["ur5e", "panda"])
def test_the_chain_moves_the_grasp_frame_as_the_plant_does(name):
    robot, plant, model = _plant(name)
    chain = _chain(robot, plant, model)
    assert chain.joints == robot.num_arm_joints
    lower = np.maximum(plant.GetPositionLowerLimits()[robot.arm_positions], -3.0)
    upper = np.minimum(plant.GetPositionUpperLimits()[robot.arm_positions], 3.0)
    q = np.random.default_rng(0).uniform(lower, upper, (50, robot.num_arm_joints))
    R, p = chain.forward(q)
    context = plant.CreateDefaultContext()
    A = plant.GetFrameByName(robot.arm_base_link, model)
    G = plant.GetFrameByName(robot.grasp_frame, model)
    for k in range(len(q)):
        plant.SetPositions(context, model, robot.positions(0.0, 0.0, 0.0, arm=q[k]))
        X_AG = plant.CalcRelativeTransform(context, A, G)
        np.testing.assert_allclose(p[k], X_AG.translation(), atol=1e-12)
        np.testing.assert_allclose(R[k], X_AG.rotation().matrix(), atol=1e-12)


def test_the_jacobian_is_the_derivative_of_the_chain():
    robot, plant, model = _plant("panda")
    chain = _chain(robot, plant, model)
    q = np.random.default_rng(1).uniform(-1.5, 1.5, (4, robot.num_arm_joints))
    R, _, J = chain.jacobian(q)
    eps = 1e-6
    for i in range(chain.joints):
        step = np.zeros(chain.joints)
        step[i] = eps
        R_plus, p_plus = chain.forward(q + step)
        R_minus, p_minus = chain.forward(q - step)
        np.testing.assert_allclose(J[:, 3:, i], (p_plus - p_minus) / (2 * eps), atol=1e-8)
        # ω: the skew part of dR R^T.
        dR = (R_plus - R_minus) / (2 * eps) @ np.swapaxes(R, -1, -2)
        omega = np.stack([dR[:, 2, 1], dR[:, 0, 2], dR[:, 1, 0]], axis=-1)
        np.testing.assert_allclose(J[:, :3, i], omega, atol=1e-8)


def test_joints_that_are_not_the_way_from_base_to_tool_are_refused():
    robot, plant, model = _plant("ur5e")
    with pytest.raises(ValueError, match="the joints from"):
        _chain(robot, plant, model, robot.arm_joints[:-1])
