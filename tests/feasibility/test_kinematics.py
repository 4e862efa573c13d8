"""The arm's kinematics for any serial arm: numeric inverse kinematics for a redundant arm
with narrow joint limits, the same answers as the closed form for the UR5e, and angles kept
inside limits that are not two full turns."""

import math

import numpy as np
import pytest

from s3o_drake.feasibility import kinematics
from s3o_drake.feasibility.joint_chain import JointChain
from s3o_drake.feasibility.kinematics import ArmKinematics, ArmModelError
from s3o_drake.world.robot import load_robot

# A Franka-Panda-class arm with its hand, as the shipped Panda's model has it, with its
# maker's limits and a stow of this test's own.
PANDA_CHAIN = kinematics.arm_kinematics(load_robot("panda")).chain
PANDA_LOWER = np.array([-2.8973, -1.7628, -2.8973, -3.0718, -2.8973, -0.0175, -2.8973])
PANDA_UPPER = np.array([2.8973, 1.7628, 2.8973, -0.0698, 2.8973, 3.7525, 2.8973])
PANDA = ArmKinematics(PANDA_CHAIN, PANDA_LOWER, PANDA_UPPER, "numeric",
                      stow=np.array([0.0, -0.3, 0.0, -2.2, 0.0, 2.0, math.pi / 4]))
UR5E = kinematics.arm_kinematics(load_robot("ur5e"))


def _reachable_targets(arm: ArmKinematics, count: int, seed: int = 0):
    q = np.random.default_rng(seed).uniform(arm.lower, arm.upper, (count, arm.joints))
    return (q, *arm.forward(q))


def test_numeric_ik_reaches_a_redundant_arms_targets_from_its_default_seeds():
    _, R, p = _reachable_targets(PANDA, 300)
    solutions = PANDA.inverse(R, p)
    assert solutions.shape == (300, PANDA.branches, 7) and PANDA.branches == 16
    found = ~np.isnan(solutions).any(axis=-1)
    assert np.array_equal(found, PANDA.exact(solutions, R, p))  # what it returns is exact
    assert PANDA.within_limits(solutions[found]).all()
    assert found.any(axis=1).mean() >= 0.95
    # Different seeds lead to different solutions of the same target (the arm's choices).
    spread = [np.ptp(s[f], axis=0).max() for s, f in zip(solutions, found, strict=True)
              if f.sum() > 1]
    assert np.median(spread) > 0.5


def test_numeric_ik_from_a_nearby_reference_stays_on_its_branch():
    q, R, p = _reachable_targets(PANDA, 200, seed=1)
    inside = PANDA.within_limits(q + 0.15) & PANDA.within_limits(q - 0.15)
    q, R, p = q[inside], R[inside], p[inside]
    reference = q + np.random.default_rng(2).uniform(-0.05, 0.05, q.shape)
    solutions = PANDA.inverse(R, p, reference[:, None])[:, 0]
    found = ~np.isnan(solutions).any(axis=-1)
    assert found.mean() >= 0.97
    assert np.abs(solutions[found] - q[found]).max() < 0.2


def test_numeric_ik_finds_the_ur5es_closed_form_solutions():
    ur5e = UR5E
    numeric = ArmKinematics(ur5e.chain, ur5e.lower, ur5e.upper, "numeric", ur5e.stow)
    _, R, p = _reachable_targets(ur5e, 50, seed=3)
    closed = ur5e.inverse(R, p)
    exact = ur5e.exact(closed, R, p)
    seeds = np.where(exact[..., None], closed, 0.0) + 0.05
    solutions = numeric.inverse(R, p, seeds)
    found = ~np.isnan(solutions).any(axis=-1) & exact
    assert found.sum() >= 0.95 * exact.sum()
    # From 0.05 rad off, all but a few (near a singular wrist, where branches meet) come back.
    gap = np.abs(kinematics.wrap(solutions[found] - closed[found])).max(axis=-1)
    assert (gap < 1e-5).mean() >= 0.95


def test_angles_stay_inside_limits_narrower_than_two_turns():
    # Joint 6 of the Panda turns from -0.0175 to 3.7525 rad: 3.5 rad is in range, although
    # wrapping into [-π, π) would carry it out.
    q = np.zeros(7)
    q[3], q[5] = -1.0, 3.5
    np.testing.assert_allclose(PANDA.into_limits(q), q)
    assert PANDA.within_limits(PANDA.into_limits(q))
    q[0] = 3.0  # joint 1 stops at 2.8973: no turn brings 3.0 in
    assert not PANDA.within_limits(PANDA.into_limits(q))
    # No joint of the Panda turns twice round: nothing is shifted towards a reference.
    assert not PANDA.wrapping.any()
    np.testing.assert_array_equal(PANDA.nearest_turn(q, q + 2 * math.pi), q)
    # The UR5e's joints do, all but the elbow; they turn towards the reference and stay
    # within ±2π.
    assert UR5E.wrapping.tolist() == [True, True, False, True, True, True]
    turned = UR5E.nearest_turn(np.full(6, 3.0), np.full(6, -3.0))
    np.testing.assert_allclose(turned, [3.0 - 2 * math.pi, 3.0 - 2 * math.pi, 3.0,
                                        3.0 - 2 * math.pi, 3.0 - 2 * math.pi,
                                        3.0 - 2 * math.pi])


@pytest.mark.parametrize("arm", [PANDA, UR5E], ids=["panda", "ur5e"])
def test_random_configurations_are_deterministic_and_inside_the_limits(arm):
    q = arm.random_configurations(500, seed=4)
    np.testing.assert_array_equal(q, arm.random_configurations(500, seed=4))
    assert arm.within_limits(q).all()
    assert (np.abs(q) <= math.pi).all()



@pytest.mark.parametrize("where", ["first", "last"])
def test_an_arm_whose_end_joints_do_not_turn_about_A_and_G_is_refused(where):
    # The reachability map turns a stored configuration by the first joint (about A's z)
    # and by the last (about G's approach axis): a first joint tilted off A's vertical or
    # beside it, or a tool beside the last joint's axis or tilted off it, cannot be mapped.
    tilt, beside = np.eye(4), np.eye(4)
    tilt[1:3, 1:3] = [[math.cos(0.1), -math.sin(0.1)], [math.sin(0.1), math.cos(0.1)]]
    beside[0, 3] = 0.01
    for X in (tilt, beside):
        fixed = PANDA_CHAIN.fixed.copy()
        if where == "first":  # the first joint's frame moved in A
            fixed[0] = fixed[0] @ X
        else:  # G moved in the last joint's frame
            fixed[-1] = X @ fixed[-1]
        with pytest.raises(ArmModelError, match="must turn") as error:
            ArmKinematics(JointChain(fixed, PANDA_CHAIN.axes), PANDA_LOWER, PANDA_UPPER)
        assert error.value.path == ("arm.joints[0]" if where == "first" else "arm.joints[6]")


def test_end_joints_about_minus_z_turn_the_other_way_within_a_makers_rounding():
    # Kinova writes its joint 1 flipped by 3.1416 (7.3e-6 rad from pi): the first joint of
    # the Gen3 turns about -z of A, and its last about -z of G. The map turns them by minus
    # the bearing and the wrist turn; the UR5e's and the Panda's turn about +z.
    assert UR5E.turn_signs == (1.0, 1.0)
    assert kinematics.arm_kinematics(load_robot("panda")).turn_signs == (1.0, 1.0)
    gen3 = kinematics.arm_kinematics(load_robot("gen3"))
    assert gen3.turn_signs == (-1.0, -1.0)
    # A lean of ten times the tolerance is refused.
    fixed = PANDA_CHAIN.fixed.copy()
    lean = 10 * kinematics.TURNING_AXIS_TOLERANCE
    fixed[0][1:3, 1:3] = [[math.cos(lean), -math.sin(lean)], [math.sin(lean), math.cos(lean)]]
    with pytest.raises(ArmModelError, match="must turn"):
        ArmKinematics(JointChain(fixed, PANDA_CHAIN.axes), PANDA_LOWER, PANDA_UPPER)


def test_the_gen3s_numeric_ik_reaches_grasps_in_front_of_the_base_and_the_map_turns_them():
    from s3o_drake.feasibility.reachability.map import R_KIND, place

    robot = load_robot("gen3")
    arm = kinematics.arm_kinematics(robot)
    # Top grasps over a table top 0.75 m high (A is 0.66 m up) and a side grasp, 0.4 to
    # 0.7 m ahead of the arm's base.
    R = np.stack([R_KIND["top"], R_KIND["top"], R_KIND["top"], R_KIND["side"]])
    p = np.array([[0.4, 0.0, 0.15], [0.55, 0.0, 0.12], [0.7, 0.0, 0.1], [0.6, 0.0, 0.12]])
    solutions = arm.inverse(R, p)
    exact = arm.exact(solutions, R, p)
    assert exact.any(axis=1).all()
    # Turned to a bearing and a wrist turn, a stored solution grasps there.
    for k in range(len(p)):
        q0 = solutions[k][exact[k]][0]
        for bearing, turn in ((0.7, 0.0), (-1.2, math.pi / 2)):
            q = place(q0, bearing, turn, robot=robot)
            R_q, p_q = arm.forward(q)
            c, s = math.cos(bearing), math.sin(bearing)
            Rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
            cw, sw = math.cos(turn), math.sin(turn)
            Rw = np.array([[cw, -sw, 0.0], [sw, cw, 0.0], [0.0, 0.0, 1.0]])
            # Within what the axis's lean allows (2 r e, kinematics.TURNING_AXIS_TOLERANCE).
            np.testing.assert_allclose(p_q, Rz @ p[k], atol=3e-5)
            np.testing.assert_allclose(R_q, Rz @ R[k] @ Rw, atol=3e-5)
