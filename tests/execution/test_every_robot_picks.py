"""Every shipped robot picks a dish, all of them in one process: the feasibility check finds
stops, and from one of them the pickup the ArmController runs is planned (grasp, pre-grasp,
lift, tray; RRT-Connect paths timed by TOPPRA) within the robot's own limits."""

import dataclasses
import functools

import numpy as np
import pytest

from s3o_drake.execution.arm.pickup import plan_pickup
from s3o_drake.experiments.limit import finger_stroke_time
from s3o_drake.feasibility.check import FeasibilityChecker
from s3o_drake.feasibility.kinematics import arm_kinematics
from s3o_drake.feasibility.scene import FeasibilityScene
from s3o_drake.world.angles import facing_yaw
from s3o_drake.world.resources import SCENARIOS_DIR
from s3o_drake.world.robot import load_robot
from s3o_drake.world.robot_description import robot_names
from s3o_drake.world.scenario import load_scenario

SMALL = SCENARIOS_DIR / "small" / "two_dishes.yaml"


@pytest.fixture(scope="module")
def checkers():
    """`checkers(name, method="map")`: robot `name`'s feasibility check in the small scene,
    each scene and check made once for the module's tests (the Gen3's scene serves three:
    building one is much of a test's time)."""
    contents = load_scenario(SMALL).contents

    @functools.cache
    def scene(name: str) -> FeasibilityScene:
        return FeasibilityScene(dataclasses.replace(contents, robot=load_robot(name)))

    @functools.cache
    def checker(name: str, method: str = "map") -> FeasibilityChecker:
        return FeasibilityChecker(scene(name), method=method)

    return checker


# Each robot's value is put into the small scene's contents directly.
@pytest.mark.parametrize("name", robot_names())
def test_every_robot_picks_a_plate_and_a_cup_within_its_limits(name, checkers):
    """The Gen3's 2F-85 pinches both at the rim: its pads swing out as they close, and its
    fingers' whole linkage may touch the dish."""
    robot = load_robot(name)
    scenario = load_scenario(SMALL)
    checker = checkers(name)
    scene = checker.scene
    assert scene.robot is robot
    arm = arm_kinematics(robot)  # the model's limits
    for dish in scenario.dishes:
        p = np.asarray(dish.position, dtype=float)
        angles = np.linspace(-np.pi, np.pi, 24, endpoint=False)
        xy = np.concatenate([p + r * np.column_stack([np.cos(angles), np.sin(angles)])
                             for r in (0.6, 0.75, 0.9)])
        bases = np.column_stack([xy, facing_yaw(xy, p)])
        feasible = np.flatnonzero(checker.check_many(bases, dish.name))
        assert feasible.size > 0, dish.kind
        plan = plan_pickup(scene, checker, bases[feasible[0]], dish.name, seed=0)
        assert plan.ok and 2.0 < plan.duration < 30.0, (dish.kind, plan.reason)
        q = np.vstack([s.waypoints for s in plan.segments])[:, robot.arm_positions]
        assert q.shape[1] == {"ur5e": 6}.get(name, 7)
        assert np.all(q >= arm.lower - 1e-9)
        assert np.all(q <= arm.upper + 1e-9)
        # The fingers close at the pads' speed, or slower where the model's joint limit says
        # so (the 2F-85's knuckle, 0.5 rad/s: 1.7 s); not at the pads' speed taken for a
        # joint's (a knuckle turns 19 rad for a metre of its pads' travel: 8 s).
        (close,) = [s for s in plan.segments if s.name == "close"]
        assert finger_stroke_time(robot=robot) <= close.duration + 1e-3
        assert close.duration < 2.0


GEN3_MAP = load_robot("gen3").files.reachability_map


def _gen3_stops(checker: FeasibilityChecker, radii: tuple[float, ...], bearings: int):
    scene = checker.scene
    dish = load_scenario(SMALL).dishes[0]  # the plate
    p = np.asarray(dish.position, dtype=float)
    angles = np.linspace(-np.pi, np.pi, bearings, endpoint=False)
    xy = np.concatenate([p + r * np.column_stack([np.cos(angles), np.sin(angles)])
                         for r in radii])
    bases = np.column_stack([xy, facing_yaw(xy, p)])
    return scene, checker, dish.name, bases, np.flatnonzero(checker.check_many(bases, dish.name))


# One ring of stops: the exhaustive IK check costs about 0.1 s a stop.
@pytest.mark.parametrize(("method", "radii", "bearings"), [
    ("ik", (0.75,), 12),
    pytest.param("map", (0.75,), 24, marks=pytest.mark.skipif(
        not GEN3_MAP.exists(), reason=f"the Gen3's reachability map is not built ({GEN3_MAP})")),
])
def test_the_gen3_finds_stops_for_a_dish(method, radii, bearings, checkers):
    scene, checker, dish, bases, feasible = _gen3_stops(checkers("gen3", method), radii,
                                                        bearings)
    assert feasible.size > 0
    result = checker.check(bases[feasible[0]], dish)
    assert result.feasible and result.q.shape == (scene.robot.num_positions,) == (11,)
    arm = arm_kinematics(scene.robot)
    assert np.all(result.q[scene.robot.arm_positions] >= arm.lower - 1e-9)
    assert np.all(result.q[scene.robot.arm_positions] <= arm.upper + 1e-9)
