"""Every shipped robot picks a dish, all of them in one process: the feasibility check finds
stops, and from one of them the pickup the ArmController runs is planned (grasp, pre-grasp,
lift, tray; RRT-Connect paths timed by TOPPRA) within the robot's own limits."""

import dataclasses

import numpy as np
import pytest

from s3o_drake.execution.arm.pickup import plan_pickup
from s3o_drake.feasibility.check import FeasibilityChecker
from s3o_drake.feasibility.kinematics import arm_kinematics
from s3o_drake.feasibility.scene import FeasibilityScene
from s3o_drake.world.angles import facing_yaw
from s3o_drake.world.resources import SCENARIOS_DIR
from s3o_drake.world.robot import load_robot
from s3o_drake.world.robot_description import robot_names
from s3o_drake.world.scenario import load_scenario


@pytest.mark.parametrize("name", robot_names())
def test_every_robot_picks_a_dish_within_its_limits(name):
    robot = load_robot(name)
    scenario = load_scenario(SCENARIOS_DIR / "small" / "two_dishes.yaml")
    scene = FeasibilityScene(dataclasses.replace(scenario.contents, robot=robot))
    assert scene.robot is robot
    checker = FeasibilityChecker(scene)
    dish = scenario.dishes[0]
    p = np.asarray(dish.position, dtype=float)
    angles = np.linspace(-np.pi, np.pi, 24, endpoint=False)
    xy = np.concatenate([p + r * np.column_stack([np.cos(angles), np.sin(angles)])
                         for r in (0.6, 0.75, 0.9)])
    bases = np.column_stack([xy, facing_yaw(xy, p)])
    feasible = np.flatnonzero(checker.check_many(bases, dish.name))
    assert feasible.size > 0
    plan = plan_pickup(scene, checker, bases[feasible[0]], dish.name, seed=0)
    assert plan.ok and 2.0 < plan.duration < 30.0
    q = np.vstack([s.waypoints for s in plan.segments])[:, robot.arm_positions]
    assert q.shape[1] == {"ur5e": 6, "panda": 7}.get(name, q.shape[1])
    arm = arm_kinematics(robot)  # the model's limits
    assert np.all(q >= arm.lower - 1e-9)
    assert np.all(q <= arm.upper + 1e-9)
