"""Arm motion for execution: RRT-Connect on Drake's checker, timing, and pickup plans.

The scene (tests/conftest.py) is scenarios/small/two_dishes.yaml: a table (x 1.4..2.6, y
2.1..2.9, top at 0.75 m) with a plate and a cup 0.2 m inside its free south edge; the robot
faces them from y = 1.45.
"""

import itertools
import math
from pathlib import Path

import numpy as np
import pytest
from pydrake.math import RigidTransform

from s3o_drake.execution.arm.arm_motion import (
    CORNER_ROUNDINGS,
    STILL_DURATION,
    curve_collision_free,
    edges_free,
    joint_limits,
    plan_arm_path,
    rounded_corners,
    time_parameterize,
)
from s3o_drake.execution.arm.pickup import (
    FINGER_MAX_VELOCITY,
    SEGMENT_NAMES,
    plan_pickup,
    segment_limits,
)
from s3o_drake.feasibility import ik
from s3o_drake.feasibility.check import FeasibilityChecker
from s3o_drake.feasibility.grasps import rotation_for
from s3o_drake.feasibility.pickup_geometry import LIFT_HEIGHT, X_WA, moved
from s3o_drake.feasibility.reachability.map import ReachabilityMap
from s3o_drake.feasibility.scene import FeasibilityScene
from s3o_drake.world.angles import facing_yaw
from s3o_drake.world.robot import load_robot
from s3o_drake.world.scenario import load_scenario

REPO = Path(__file__).resolve().parents[2]
# The arm's joints among the positions of the scenes' robot, the UR5e.
ARM = load_robot("ur5e").arm_positions
# Facing north towards the table's free edge, 0.65 m from it.
FRONT = np.array([1.85, 1.45, math.pi / 2])


@pytest.fixture(scope="module")
def around_the_table_edge(scene):
    """Two free configurations whose straight joint line hits the table: the gripper level
    below the table top in front of its edge, and pointing down above the table."""
    q0 = scene.q(FRONT)
    below = RigidTransform(rotation_for("side", math.pi / 2), [1.6, 1.95, 0.6])
    above = RigidTransform(rotation_for("top", math.pi / 2), [2.1, 2.4, 0.85])
    qa = moved(q0, FRONT, below, scene.checker, robot=scene.robot)
    qb = moved(q0, FRONT, above, scene.checker, robot=scene.robot)
    assert qa is not None and qb is not None
    assert not scene.checker.CheckEdgeCollisionFree(qa, qb)
    return qa, qb


# ------------------------------------------------------------------------- plan_arm_path

def test_planner_goes_around_an_obstacle(scene, around_the_table_edge):
    qa, qb = around_the_table_edge
    path = plan_arm_path(scene.checker, qa, qb, robot=scene.robot, seed=1, time_limit=5.0)
    assert path is not None and len(path) >= 3
    np.testing.assert_array_equal(path[0], qa)
    np.testing.assert_array_equal(path[-1], qb)
    assert edges_free(scene.checker, path)
    # Only the arm moves.
    np.testing.assert_array_equal(path[:, :3], np.broadcast_to(qa[:3], (len(path), 3)))
    np.testing.assert_array_equal(path[:, 9:], np.broadcast_to(qa[9:], (len(path), 2)))


def test_same_seed_gives_the_same_path(scene, around_the_table_edge):
    qa, qb = around_the_table_edge
    first = plan_arm_path(scene.checker, qa, qb, robot=scene.robot, seed=7)
    second = plan_arm_path(scene.checker, qa, qb, robot=scene.robot, seed=7)
    assert first is not None
    np.testing.assert_array_equal(first, second)


def test_free_straight_line_needs_no_planner(scene):
    q0 = scene.q(FRONT)
    q1 = scene.q(FRONT, scene.robot.arm_stow + np.array([0.3, 0.0, 0.0, 0.0, 0.0, 0.2]))
    path = plan_arm_path(scene.checker, q0, q1, robot=scene.robot)
    assert path.shape == (2, 11)


def test_endpoints_in_collision_are_rejected_by_name(scene, around_the_table_edge):
    qa, _ = around_the_table_edge
    under_table = scene.q([1.85, 2.45, math.pi / 2])
    with pytest.raises(ValueError, match="q_start"):
        plan_arm_path(scene.checker, under_table, qa, robot=scene.robot)
    # The arm stretched out level towards the table, through the table's top.
    into_table = scene.q(FRONT, np.array([math.pi, 0.0, 0.0, 0.0, 0.0, 0.0]))
    with pytest.raises(ValueError, match="q_goal"):
        plan_arm_path(scene.checker, qa, into_table, robot=scene.robot)


# ---------------------------------------------------------------------- time_parameterize

def _rates(trajectory, samples: int = 2000) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Sample times and |q̇|, |q̈| there (positions x samples)."""
    times = np.linspace(trajectory.start_time(), trajectory.end_time(), samples)
    v = np.abs(trajectory.MakeDerivative(1).vector_values(times))
    a = np.abs(trajectory.MakeDerivative(2).vector_values(times))
    return times, v, a


def _max_rates(trajectory, samples: int = 2000) -> tuple[np.ndarray, np.ndarray]:
    _, v, a = _rates(trajectory, samples)
    return v.max(axis=1), a.max(axis=1)


def _off_the_edges(q: np.ndarray, path: np.ndarray) -> float:
    """Distance from q to the nearest straight edge of `path`."""
    distances = []
    for p, b in itertools.pairwise(path):
        e = b - p
        s = np.clip(np.dot(q - p, e) / np.dot(e, e), 0.0, 1.0)
        distances.append(float(np.linalg.norm(q - p - s * e)))
    return min(distances)


def _assert_within_limits_and_at_rest(trajectory, path, v_max, a_max):
    """Sampled speeds and accelerations within the limits (0.1 % for sampling between
    TOPPRA's own checks), exact endpoints, at rest at both ends."""
    v, a = _max_rates(trajectory)
    finite_v, finite_a = np.isfinite(v_max), np.isfinite(a_max)
    assert np.all(v[finite_v] <= v_max[finite_v] * 1.001), v / v_max
    assert np.all(a[finite_a] <= a_max[finite_a] * 1.001), a / a_max
    assert trajectory.start_time() == 0.0
    np.testing.assert_allclose(trajectory.value(0.0).ravel(), path[0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(trajectory.value(trajectory.end_time()).ravel(), path[-1],
                               rtol=0, atol=1e-12)
    for t in (0.0, trajectory.end_time()):
        np.testing.assert_allclose(trajectory.EvalDerivative(t, 1).ravel(), 0.0, atol=1e-9)


@pytest.fixture(scope="module")
def plant(scene):
    return scene.checker.plant()


@pytest.fixture(scope="module")
def corner_at_the_table_edge(scene, around_the_table_edge):
    """qa (gripper level below the table top, before its edge) -> raise the shoulder ->
    stretch the elbow out over the table: raised 0.315 rad, the hand just clears the table's
    edge at the corner (barely more than the 0.311 rad that the straight edges need), so
    rounding the corner swings it into the table; raised 0.5 rad, it clears it well."""
    qa, _ = around_the_table_edge

    def path(raise_by: float) -> np.ndarray:
        qc = qa.copy()
        qc[4] -= raise_by  # shoulder lift
        qb = qc.copy()
        qb[5] -= 0.6  # elbow
        return np.stack([qa, qc, qb])

    tight, roomy = path(0.315), path(0.5)
    for p in (tight, roomy):
        assert edges_free(scene.checker, p)
        assert not scene.checker.CheckEdgeCollisionFree(p[0], p[-1])  # a real corner
    return tight, roomy


def test_limits_come_from_the_robot_model(plant):
    v, a = joint_limits(plant)
    np.testing.assert_allclose(v[ARM], math.pi)  # the UR5e's 180 deg/s
    np.testing.assert_allclose(a[ARM], 5.0)
    assert np.all(np.isinf(a[:3]))  # the model gives the base none (it does not move here)


def test_a_straight_edge_gets_the_time_optimal_trapezoid(plant):
    """Along one straight edge TOPPRA's answer is the rest-to-rest trapezoid of the joint that
    needs longest: accelerate at 5 rad/s², cruise at π rad/s, brake (2.0 rad) or a triangle
    (0.5 rad)."""
    q0 = np.zeros(11)
    for move, expected in ((2.0, 2.0 / math.pi + math.pi / 5.0), (0.5, 2 * math.sqrt(0.5 / 5.0))):
        q1 = q0.copy()
        q1[ARM] = [move, -0.5 * move, 0.3, 0.0, 0.1, 0.2]
        timed = time_parameterize(np.stack([q0, q1]), plant)
        assert not timed.smoothed
        assert timed.duration == pytest.approx(expected, rel=2e-3)
        v, a = joint_limits(plant)
        _assert_within_limits_and_at_rest(timed.trajectory, [q0, q1], v, a)


@pytest.mark.parametrize("gap", [5e-11, 1e-8, 5e-6])
def test_waypoints_a_hair_apart_are_one(plant, gap):
    """Waypoints a hair apart (TOPPRA's time scaling of so short an edge has breaks closer
    than Drake's trajectories accept, which ends the process; 1e-8 rad did so in the time
    benchmark) are merged, at the start and at the end, and the motion is the one without
    the repeat, ending exactly at the last waypoint."""
    q0, q1 = np.zeros(11), np.zeros(11)
    q1[ARM] = [0.5, -0.25, 0.3, 0.0, 0.1, 0.2]
    hair, end_hair = q0.copy(), q1.copy()
    hair[ARM.start] += gap
    end_hair[ARM.start] += gap
    plain = time_parameterize(np.stack([q0, q1]), plant)
    timed = time_parameterize(np.stack([q0, hair, q1]), plant)
    assert timed.duration == pytest.approx(plain.duration, rel=1e-4)
    to_end = time_parameterize(np.stack([q0, q1, end_hair]), plant)
    trajectory = to_end.trajectory
    np.testing.assert_allclose(trajectory.value(trajectory.end_time()).ravel(), end_hair,
                               atol=1e-12)


def test_stops_at_each_waypoint_on_the_straight_edges(scene, plant, around_the_table_edge):
    """Without a checker the motion stays on the checked straight edges and stops at each
    waypoint; within lower limits given per position."""
    path = plan_arm_path(scene.checker, *around_the_table_edge, robot=scene.robot, seed=1)
    v, a = joint_limits(plant)
    arm = scene.robot.arm_positions
    v[arm], a[arm] = [1.0, 0.5, 1.0, 2.0, 2.0, 2.0], 2.0
    timed = time_parameterize(path, plant, max_velocity=v, max_acceleration=a)
    assert not timed.smoothed
    trajectory = timed.trajectory
    _assert_within_limits_and_at_rest(trajectory, path, v, a)
    times, speeds, _ = _rates(trajectory, 400)
    assert all(_off_the_edges(trajectory.value(t).ravel(), path) < 1e-9 for t in times)
    # At rest where it passes each inner waypoint.
    for waypoint in path[1:-1]:
        at = np.argmin([np.linalg.norm(trajectory.value(t).ravel() - waypoint) for t in times])
        assert speeds[:, at].max() < 0.1 * v[arm].max()


def test_a_rounded_corner_is_checked_faster_and_within_the_limits(scene, plant,
                                                                  corner_at_the_table_edge):
    _, roomy = corner_at_the_table_edge
    stops = time_parameterize(roomy, plant)
    rounded = time_parameterize(roomy, plant, checker=scene.checker)
    assert rounded.smoothed
    assert curve_collision_free(scene.checker, rounded.trajectory.path())
    assert rounded.duration < 0.95 * stops.duration
    v, a = joint_limits(plant)
    _assert_within_limits_and_at_rest(rounded.trajectory, roomy, v, a)
    # It passes the corner without stopping, close to the waypoint.
    times, speeds, _ = _rates(rounded.trajectory, 400)
    gaps = [np.linalg.norm(rounded.trajectory.value(t).ravel() - roomy[1]) for t in times]
    at = int(np.argmin(gaps))
    assert gaps[at] < 0.4 * np.linalg.norm(roomy[1] - roomy[0])
    assert speeds[:, at].max() > 0.3


def test_a_rounding_that_cuts_into_the_table_is_rejected(scene, plant, corner_at_the_table_edge):
    tight, _ = corner_at_the_table_edge
    # The largest rounding swings the hand into the table edge: the checker says so ...
    assert not curve_collision_free(scene.checker, rounded_corners(tight, CORNER_ROUNDINGS[0]))
    # ... so with only that rounding allowed, the motion stops at the corner instead.
    timed = time_parameterize(tight, plant, checker=scene.checker,
                              roundings=CORNER_ROUNDINGS[:1])
    assert not timed.smoothed
    samples = timed.trajectory.vector_values(np.linspace(0.0, timed.duration, 300)).T
    assert all(_off_the_edges(q, tight) < 1e-9 for q in samples)
    # With every rounding allowed, whatever is chosen was checked.
    timed = time_parameterize(tight, plant, checker=scene.checker)
    assert not timed.smoothed or curve_collision_free(scene.checker, timed.trajectory.path())


def test_timing_rejects_bad_input_and_times_a_still_path(plant):
    q = np.zeros(11)
    with pytest.raises(ValueError, match="path"):
        time_parameterize(np.zeros((2, 6)), plant)
    moved_base = q.copy()
    moved_base[0] = 0.5  # the model gives the base no acceleration limit
    with pytest.raises(ValueError, match="max_acceleration"):
        time_parameterize(np.stack([q, moved_base]), plant)
    still = time_parameterize(np.stack([q, q, q]), plant)
    assert still.duration == pytest.approx(STILL_DURATION)
    np.testing.assert_array_equal(still.trajectory.value(still.duration).ravel(), q)


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
        if segment.smoothed:  # its rounded corners were checked by the same checker
            assert curve_collision_free(checkers[segment.name], trajectory.path())
        v, a = _max_rates(trajectory, 400)
        v_max, a_max = segment_limits(scene.checker.plant(), segment.name, robot=scene.robot)
        assert np.all(v[3:] <= v_max[3:] * 1.001), segment.name
        assert np.all(a[3:] <= a_max[3:] * 1.001), segment.name
        assert np.all(v[9:] <= FINGER_MAX_VELOCITY * 1.001), segment.name
        np.testing.assert_allclose(v[:3], 0.0, atol=1e-12)  # the base stays put
        previous_end = qs[-1]
    np.testing.assert_allclose(previous_end[scene.robot.arm_positions], scene.robot.arm_stow,
                               atol=1e-12)
    np.testing.assert_allclose(previous_end[9:], scene.robot.gripper_open)
    whole = plan.trajectory()
    assert whole.end_time() == pytest.approx(plan.duration)
    t0 = 0.0
    for segment in plan.segments:  # the joined trajectory plays the segments in turn
        for t in (0.0, 0.5 * segment.duration, segment.duration):
            np.testing.assert_allclose(whole.value(t0 + t), segment.trajectory.value(t),
                                       atol=1e-9)
        t0 += segment.duration
    assert 2.0 < plan.duration < 12.0


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
    task = load_scenario(REPO / "scenarios" / "generated" / "task_002.yaml")
    scene = FeasibilityScene(task.contents)
    checker = FeasibilityChecker(scene, ReachabilityMap.load(robot=scene.robot))
    base = np.array([6.368, 2.618, -1.275])
    result = checker.check(base, "cup_3", None)
    assert result.feasible
    q_closed = result.q.copy()
    q_closed[9:] = scene.robot.gripper_closed
    X_WG = scene.grasp_pose(q_closed)
    lifted = X_WG.translation() + np.array([0.0, 0.0, LIFT_HEIGHT])
    straight_up = RigidTransform(X_WG.rotation(), lifted)
    assert moved(q_closed, base, straight_up, ik.grasp_checker(scene, "cup_3"),
                 robot=scene.robot) is None

    plan = plan_pickup(scene, checker, base, "cup_3", seed=0)
    assert plan.ok, plan.reason
    lift = next(s for s in plan.segments if s.name == "lift")
    p_start, p_end = (scene.grasp_pose(q).translation() for q in lift.waypoints[[0, -1]])
    assert p_end[2] - p_start[2] > 0.02
    arm_base = X_WA(base, robot=scene.robot).translation()
    assert np.hypot(*(p_end - arm_base)[:2]) < np.hypot(*(p_start - arm_base)[:2])


def test_an_arm_swung_round_past_a_chair_stows_the_other_way_round():
    """Dense task_089 (seed 2, smooth): a landing turned the base 0.7 rad from its plan while
    the arm swung out towards the pre-grasp, its first joint at 2.93 rad; the pickup failed
    and the way back to the stow's 0 rad was shut by a chair, the stow a turn away was not.
    The UR5e's first joint may turn two whole turns, so the stow is its pose, whatever the
    turn: a stow finds that way, and the path ends there, free."""
    scenario = load_scenario(REPO / "scenarios" / "generated_dense" / "task_089.yaml")
    scene = FeasibilityScene(scenario.contents)
    robot = scene.robot
    q_out = np.array([5.507945357294337, 4.6913977400266935, 3.457925031849662,
                      2.9292844302741936, -1.2289693738030507, 1.514583741309258,
                      -1.8564104390747902, -1.5707981293381645, 2.9292896127034984,
                      0.07000000001339073, 0.06993494942420485])
    q_stow = scene.q(q_out[:3])
    first = np.arange(robot.num_positions)[robot.arm_positions][0]
    assert q_stow[first] == 0.0
    kwargs = {"robot": robot, "time_limit": 1.0, "seed": 3}
    assert plan_arm_path(scene.checker, q_out, q_stow, **kwargs) is None
    path = plan_arm_path(scene.checker, q_out, q_stow, turned_goal=True, **kwargs)
    assert path is not None and edges_free(scene.checker, path)
    assert np.array_equal(path[0], q_out)
    assert path[-1][first] == 2 * math.pi
    arm = np.arange(robot.num_positions)[robot.arm_positions]
    assert np.array_equal(path[-1][arm[1:]], q_stow[arm[1:]])
    # Where the goal's own angles are reached, nothing changes.
    q_near = q_stow.copy()
    q_near[first] = 0.1
    assert np.array_equal(plan_arm_path(scene.checker, q_near, q_stow, **kwargs),
                          plan_arm_path(scene.checker, q_near, q_stow, turned_goal=True,
                                        **kwargs))
