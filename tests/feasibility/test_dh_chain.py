"""A serial arm's kinematics from its DH table, in both conventions: the UR5e's chain is
the one the feasibility check uses, and a 7-joint arm published in Craig's convention comes
out where its maker's model puts it."""

import numpy as np
import pytest

from s3o_drake.feasibility import kinematics
from s3o_drake.feasibility.dh_chain import DHChain
from s3o_drake.world.robot import load_robot

UR5E = load_robot("ur5e")
HALF_PI = np.pi / 2
# Franka Emika Panda, Craig's convention: frankaemika/docs, source/dh-parameters.csv (the
# flange's 0.107 m as the tool offset). Its URDF (franka_description) puts the flange at
# (0.088, 0, 0.926) m in panda_link0 at zero joint angles.
PANDA = DHChain(a=[0, 0, 0, 0.0825, -0.0825, 0, 0.088], d=[0.333, 0, 0.316, 0, 0.384, 0, 0],
                alpha=[0, -HALF_PI, HALF_PI, HALF_PI, -HALF_PI, HALF_PI, HALF_PI],
                modified=True, tool_offset=0.107)


def test_a_craig_table_puts_the_flange_where_the_makers_model_does():
    R, p = PANDA.forward(np.zeros(7))
    np.testing.assert_allclose(p, [0.088, 0.0, 0.926], atol=1e-12)
    np.testing.assert_allclose(R[:, 2], [0.0, 0.0, -1.0], atol=1e-12)  # the flange faces down


@pytest.mark.parametrize("chain", [PANDA, kinematics.arm_kinematics(UR5E).chain],
                         ids=["modified, 7", "standard, 6"])
def test_the_jacobian_is_the_derivative_of_the_tool_pose(chain):
    rng = np.random.default_rng(0)
    q = rng.uniform(-2.5, 2.5, (5, chain.joints))
    R, p, J = chain.jacobian(q)
    assert J.shape == (5, 6, chain.joints)
    h = 1e-6
    for i in range(chain.joints):
        dq = np.zeros(chain.joints)
        dq[i] = h
        R1, p1 = chain.forward(q + dq)
        np.testing.assert_allclose((p1 - p) / h, J[:, 3:, i], atol=1e-5)
        # ω from the rotation's change: the skew part of dR R^T / h.
        W = (R1 - R) / h @ np.swapaxes(R, -1, -2)
        omega = np.stack([W[:, 2, 1], W[:, 0, 2], W[:, 1, 0]], axis=-1)
        np.testing.assert_allclose(omega, J[:, :3, i], atol=1e-5)


def test_the_feasibility_chain_is_the_robots_description():
    chain, description = kinematics.arm_kinematics(UR5E).chain, UR5E.description
    assert not chain.modified and chain.joints == 6
    np.testing.assert_array_equal(chain.a, description.arm.dh_a)
    assert chain.tool_offset == description.arm.flange_z + description.tool.grasp_offset
