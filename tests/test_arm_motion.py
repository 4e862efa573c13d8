"""Arm motion for execution: RRT-Connect on Drake's checker, timing, and pickup plans.

The scene is scenarios/small/two_dishes.yaml: a table (x 1.4..2.6, y 2.1..2.9, top at 0.75 m)
with a plate and a cup 0.2 m inside its free south edge; the robot faces them from y = 1.45.
"""

import itertools
import math
from pathlib import Path

import numpy as np
import pytest
from pydrake.math import RigidTransform

from s3o_drake.execution.arm_motion import (
    ARM,
    edges_free,
    plan_arm_path,
    time_parameterize,
)
from s3o_drake.execution.pickup import FINGER_MAX_VELOCITY, SEGMENT_NAMES, plan_pickup
from s3o_drake.feasibility import ik
from s3o_drake.feasibility.check import FeasibilityChecker, facing_yaw
from s3o_drake.feasibility.grasps import rotation_for
from s3o_drake.feasibility.pickup_geometry import LIFT_HEIGHT, X_WA, moved
from s3o_drake.feasibility.reachability import ReachabilityMap
from s3o_drake.feasibility.scene import FeasibilityScene
from s3o_drake.robot import ARM_STOW, GRIPPER_CLOSED, GRIPPER_OPEN
from s3o_drake.scenario import load_scenario

REPO = Path(__file__).resolve().parent.parent
SCENE = REPO / "scenarios" / "small" / "two_dishes.yaml"
# Facing north towards the table's free edge, 0.65 m from it.
FRONT = np.array([1.85, 1.45, math.pi / 2])
ARM_VELOCITY = 1.0  # the default limit (rad/s)


@pytest.fixture(scope="module")
def scene():
    return FeasibilityScene(load_scenario(SCENE))


@pytest.fixture(scope="module")
def checker(scene):
    return FeasibilityChecker(scene, ReachabilityMap.load())


@pytest.fixture(scope="module")
def around_the_table_edge(scene):
    """Two free configurations whose straight joint line hits the table: the gripper level
    below the table top in front of its edge, and pointing down above the table."""
    q0 = scene.q(FRONT)
    below = RigidTransform(rotation_for("side", math.pi / 2), [1.6, 1.95, 0.6])
    above = RigidTransform(rotation_for("top", math.pi / 2), [2.1, 2.4, 0.85])
    qa = moved(q0, FRONT, below, scene.checker)
    qb = moved(q0, FRONT, above, scene.checker)
    assert qa is not None and qb is not None
    assert not scene.checker.CheckEdgeCollisionFree(qa, qb)
    return qa, qb


# ------------------------------------------------------------------------- plan_arm_path

def test_planner_goes_around_an_obstacle(scene, around_the_table_edge):
    qa, qb = around_the_table_edge
    path = plan_arm_path(scene.checker, qa, qb, seed=1, time_limit=5.0)
    assert path is not None and len(path) >= 3
    np.testing.assert_array_equal(path[0], qa)
    np.testing.assert_array_equal(path[-1], qb)
    assert edges_free(scene.checker, path)
    # Only the arm moves.
    np.testing.assert_array_equal(path[:, :3], np.broadcast_to(qa[:3], (len(path), 3)))
    np.testing.assert_array_equal(path[:, 9:], np.broadcast_to(qa[9:], (len(path), 2)))


def test_same_seed_gives_the_same_path(scene, around_the_table_edge):
    qa, qb = around_the_table_edge
    first = plan_arm_path(scene.checker, qa, qb, seed=7)
    second = plan_arm_path(scene.checker, qa, qb, seed=7)
    assert first is not None
    np.testing.assert_array_equal(first, second)


def test_free_straight_line_needs_no_planner(scene):
    q0 = scene.q(FRONT)
    q1 = scene.q(FRONT, ARM_STOW + np.array([0.3, 0.0, 0.0, 0.0, 0.0, 0.2]))
    path = plan_arm_path(scene.checker, q0, q1)
    assert path.shape == (2, 11)


def test_endpoints_in_collision_are_rejected_by_name(scene, around_the_table_edge):
    qa, _ = around_the_table_edge
    under_table = scene.q([1.85, 2.45, math.pi / 2])
    with pytest.raises(ValueError, match="q_start"):
        plan_arm_path(scene.checker, under_table, qa)
    # The arm stretched out level towards the table, through the table's top.
    into_table = scene.q(FRONT, np.array([math.pi, 0.0, 0.0, 0.0, 0.0, 0.0]))
    with pytest.raises(ValueError, match="q_goal"):
        plan_arm_path(scene.checker, qa, into_table)


# ---------------------------------------------------------------------- time_parameterize

def _max_rates(trajectory, samples: int = 400) -> tuple[np.ndarray, np.ndarray]:
    times = np.linspace(trajectory.start_time(), trajectory.end_time(), samples)
    v = np.abs(np.column_stack([trajectory.EvalDerivative(t, 1) for t in times]))
    a = np.abs(np.column_stack([trajectory.EvalDerivative(t, 2) for t in times]))
    return v.max(axis=1), a.max(axis=1)


def test_timing_respects_limits_and_stays_on_the_path():
    path = np.array([[0.0, 0.0], [1.0, 0.5], [1.0, 0.52], [-1.0, 2.0]])
    trajectory = time_parameterize(path, max_velocity=[1.0, 0.5], max_acceleration=2.0)
    v, a = _max_rates(trajectory)
    assert np.all(v <= np.array([1.0, 0.5]) + 1e-9)
    assert np.all(a <= 2.0 + 1e-6)
    np.testing.assert_allclose(trajectory.value(trajectory.start_time()).ravel(), path[0])
    np.testing.assert_allclose(trajectory.value(trajectory.end_time()).ravel(), path[-1])
    np.testing.assert_allclose(trajectory.EvalDerivative(trajectory.end_time(), 1).ravel(), 0,
                               atol=1e-12)
    # Every sample lies on one of the straight segments.
    for t in np.linspace(trajectory.start_time(), trajectory.end_time(), 97):
        q = trajectory.value(t).ravel()
        off = [np.linalg.norm(np.cross(np.append(b - a, 0), np.append(q - a, 0)))
               / np.linalg.norm(b - a) for a, b in itertools.pairwise(path)]
        assert min(off) < 1e-9


# ----------------------------------------------------------------------------- pickups

@pytest.mark.parametrize("dish", ["plate_a", "cup_b"])
def test_pickup_from_in_front_is_collision_free_and_ends_stowed(scene, checker, dish):
    base = FRONT.copy()
    base[0] = scene.dish_p_WD(dish)[0][0]
    q_start = scene.q(base)
    plan = plan_pickup(scene, checker, base, dish, q_start=q_start, seed=0)
    assert plan.ok and plan.reason == "ok", plan.reason
    assert [s.name for s in plan.segments] == list(SEGMENT_NAMES)
    holding = ik.grasp_checker(scene, dish)
    checkers = {"approach": scene.checker, "release": scene.checker, "stow": scene.checker,
                "descend": holding, "close": holding, "lift": holding, "to_tray": holding}
    previous_end = q_start
    for segment in plan.segments:
        trajectory = segment.trajectory
        times = np.linspace(trajectory.start_time(), trajectory.end_time(), 50)
        qs = [trajectory.value(t).ravel() for t in times]
        np.testing.assert_allclose(qs[0], previous_end, atol=1e-12)
        free = checkers[segment.name].CheckConfigsCollisionFree(qs)
        assert all(free), segment.name
        assert edges_free(checkers[segment.name], segment.waypoints), segment.name
        v, _ = _max_rates(trajectory, 200)
        assert np.all(v[ARM] <= ARM_VELOCITY + 1e-9), segment.name
        assert np.all(v[9:] <= FINGER_MAX_VELOCITY + 1e-9), segment.name
        np.testing.assert_allclose(v[:3], 0.0, atol=1e-12)  # the base stays put
        previous_end = qs[-1]
    np.testing.assert_allclose(previous_end[ARM], ARM_STOW, atol=1e-12)
    np.testing.assert_allclose(previous_end[9:], GRIPPER_OPEN)
    whole = plan.trajectory()
    assert whole.end_time() == pytest.approx(plan.duration)
    assert 3.0 < plan.duration < 40.0


def test_pickup_out_of_reach_or_in_collision_fails_with_a_reason(scene, checker):
    far = np.array([0.65, 0.70, 0.0])  # 2 m from the plate
    far[2] = facing_yaw(far[:2], scene.dish_p_WD("plate_a")[0])
    plan = plan_pickup(scene, checker, far, "plate_a")
    assert not plan.ok and plan.reason == "no_ik" and plan.segments == []
    under = np.array([1.85, 2.45, math.pi / 2])
    plan = plan_pickup(scene, checker, under, "plate_a")
    assert not plan.ok and plan.reason == "base_collision"


def test_at_arm_s_length_the_lift_draws_the_dish_in():
    """A stop that the benchmark's S3O-GROP* plan chose for cup_3 of task_002, 1.03 m
    from it: the grasp is reachable but the hand cannot rise 9 cm straight up there; the
    pickup still succeeds, lifting the cup up and towards the arm."""
    scene = FeasibilityScene(load_scenario(REPO / "scenarios" / "generated" / "task_002.yaml"))
    checker = FeasibilityChecker(scene, ReachabilityMap.load())
    base = np.array([6.368, 2.618, -1.275])
    result = checker.check(base, "cup_3", None)
    assert result.feasible
    q_closed = result.q.copy()
    q_closed[9:] = GRIPPER_CLOSED
    X_WG = scene.grasp_pose(q_closed)
    lifted = X_WG.translation() + np.array([0.0, 0.0, LIFT_HEIGHT])
    straight_up = RigidTransform(X_WG.rotation(), lifted)
    assert moved(q_closed, base, straight_up, ik.grasp_checker(scene, "cup_3")) is None

    plan = plan_pickup(scene, checker, base, "cup_3", seed=0)
    assert plan.ok, plan.reason
    lift = next(s for s in plan.segments if s.name == "lift")
    p_start, p_end = (scene.grasp_pose(q).translation() for q in lift.waypoints[[0, -1]])
    assert p_end[2] - p_start[2] > 0.02
    arm_base = X_WA(base).translation()
    assert np.hypot(*(p_end - arm_base)[:2]) < np.hypot(*(p_start - arm_base)[:2])
