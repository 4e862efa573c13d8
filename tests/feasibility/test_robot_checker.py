"""The scene's collision checker speaks the robot's positions: the identity for a robot that
is one model instance (the same arrays reach Drake), a lift with the mimic joints following
for a robot of parts (the Gen3: 11 positions, 16 in the plant)."""

import dataclasses
import itertools

import numpy as np
import pytest

from s3o_drake.execution.arm.arm_motion import joint_limits, time_parameterize
from s3o_drake.execution.arm.pickup import segment_limits
from s3o_drake.feasibility.scene import FeasibilityScene
from s3o_drake.world.robot import load_robot
from s3o_drake.world.robot_description import mimic_joints

# Facing the table's free south edge (scenarios/small/two_dishes.yaml).
FRONT = np.array([1.85, 1.45, np.pi / 2])


def _scene(scenario, name: str) -> FeasibilityScene:
    return FeasibilityScene(dataclasses.replace(scenario.contents, robot=load_robot(name)))


@pytest.fixture(scope="module")
def gen3_scene(scenario) -> FeasibilityScene:
    return _scene(scenario, "gen3")


def _arm_configurations(robot, count: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    arms = robot.arm_stow + rng.uniform(-0.6, 0.6, (count, robot.num_arm_joints))
    return np.array([robot.positions(*FRONT, arm=arm) for arm in arms])


@pytest.mark.parametrize("name", ["ur5e", "panda"])
def test_a_single_instance_robots_positions_reach_drake_unchanged(scenario, name):
    scene = _scene(scenario, name)
    positions = scene.positions
    assert positions.is_identity and positions.num_plant == scene.robot.num_positions
    q = scene.q(FRONT)
    # The very arrays: no copy, no arithmetic, so the same floats and the same answers.
    assert positions.to_plant(q) is q
    v = scene.plant.GetVelocityUpperLimits()
    assert positions.to_robot(v) is v and positions.rate_limits_to_plant(v) is v
    qs = _arm_configurations(scene.robot, 8)
    inner = scene.checker.inner
    assert [scene.checker.CheckConfigCollisionFree(q) for q in qs] == \
        [inner.CheckConfigCollisionFree(q) for q in qs]
    assert list(scene.checker.CheckConfigsCollisionFree(list(qs))) == \
        list(inner.CheckConfigsCollisionFree(list(qs)))
    edges = list(itertools.pairwise(qs))
    assert [scene.checker.CheckEdgeCollisionFree(a, b) for a, b in edges] == \
        [inner.CheckEdgeCollisionFree(a, b) for a, b in edges]
    lower, upper = scene.checker.position_limits()
    np.testing.assert_array_equal(lower, scene.plant.GetPositionLowerLimits())
    np.testing.assert_array_equal(upper, scene.plant.GetPositionUpperLimits())


def test_a_robot_of_parts_is_checked_with_its_mimic_joints_following(gen3_scene):
    scene, robot = gen3_scene, gen3_scene.robot
    positions = scene.positions
    assert not positions.is_identity
    assert (positions.num_robot, positions.num_plant) == (11, 16)
    q = robot.positions(*FRONT, gripper=np.array([0.5]))
    lifted = positions.to_plant(q)
    assert lifted.shape == (16,)
    np.testing.assert_array_equal(positions.to_robot(lifted), q)
    np.testing.assert_array_equal(lifted, scene.robot_instances.plant_positions(q))
    placed = scene.robot_instances
    for follower, leader, multiplier, offset in mimic_joints(robot.description):
        assert lifted[placed.joint(follower).position_start()] == pytest.approx(
            multiplier * lifted[placed.joint(leader).position_start()] + offset)
    # Many at once, row by row.
    qs = _arm_configurations(robot, 6)
    np.testing.assert_array_equal(positions.to_plant(qs),
                                  np.array([positions.to_plant(q) for q in qs]))
    # Affine: the lift of a straight line's midpoint is the midpoint of the lifts, so the
    # checker's edges between lifted configurations are the robot's edges.
    a, b = qs[0], robot.positions(*FRONT, gripper=robot.gripper_closed)
    np.testing.assert_allclose(positions.to_plant((a + b) / 2),
                               (positions.to_plant(a) + positions.to_plant(b)) / 2,
                               rtol=0, atol=1e-15)
    # The checker's answers are Drake's on the lifted configurations.
    inner = scene.checker.inner
    free = [scene.checker.CheckConfigCollisionFree(q) for q in qs]
    assert free == [inner.CheckConfigCollisionFree(positions.to_plant(q)) for q in qs]
    assert list(scene.checker.CheckConfigsCollisionFree(list(qs))) == free
    assert any(free)
    assert scene.checker.CheckEdgeCollisionFree(qs[0], qs[0]) == free[0]
    # An arm-only edge is as long as in the robot's positions (the mimic joints stay).
    assert scene.checker.ComputeConfigurationDistance(qs[0], qs[1]) == pytest.approx(
        np.linalg.norm(qs[0] - qs[1]))
    lower, upper = scene.checker.position_limits()
    assert lower.shape == upper.shape == (11,)
    np.testing.assert_array_equal(lower[robot.arm_positions], np.asarray(
        scene.plant.GetPositionLowerLimits())[positions.indices[robot.arm_positions]])
    # A clone of the checker speaks the robot's positions too (the grasping checkers).
    assert scene.checker.Clone().CheckConfigCollisionFree(qs[0]) == free[0]


def test_a_robot_of_parts_motion_is_timed_in_its_own_positions(gen3_scene):
    scene, robot = gen3_scene, gen3_scene.robot
    positions = scene.positions
    q0 = robot.positions(*FRONT)
    arm = robot.arm_stow + np.array([0.4, -0.3, 0.2, 0.3, -0.2, 0.1, 0.5])
    q1 = robot.positions(*FRONT, arm=arm, gripper=np.array([0.6]))
    q2 = robot.positions(*FRONT, arm=robot.arm_stow + 0.2, gripper=np.array([0.3]))
    assert all(limits.shape == (11,) for limits in joint_limits(scene.plant, positions))
    # The fingers' limits are the pickup's (the model gives no acceleration limit).
    v, a = segment_limits(scene.plant, "stow", robot=robot, positions=positions)
    for path in (np.stack([q0, q1]), np.stack([q0, q1, q2])):
        timed = time_parameterize(path, scene.plant, max_velocity=v, max_acceleration=a,
                                  positions=positions)
        trajectory = timed.trajectory
        assert trajectory.rows() == 11
        np.testing.assert_allclose(trajectory.value(trajectory.end_time()).ravel(), path[-1],
                                   atol=1e-9)
        times = np.linspace(0, trajectory.end_time(), 200)
        speeds = np.abs(trajectory.MakeDerivative(1).vector_values(times))
        moving = np.isfinite(v)
        assert np.all(speeds[moving] <= v[moving, None] * (1 + 1e-6))
        # The mimic joints' lifted limits repeat their leaders': timing the lifted path in
        # the plant's positions takes as long.
        lifted = time_parameterize(positions.to_plant(path), scene.plant,
                                   max_velocity=positions.rate_limits_to_plant(v),
                                   max_acceleration=positions.rate_limits_to_plant(a))
        assert timed.duration == pytest.approx(lifted.duration, rel=1e-6)
