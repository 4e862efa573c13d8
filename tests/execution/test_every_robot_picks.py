"""Every shipped robot picks a dish: in a process for that robot (S3O_ROBOT), the feasibility
check finds stops, and from one of them the pickup the ArmController runs is planned (grasp,
pre-grasp, lift, tray; RRT-Connect paths timed by TOPPRA) within the robot's own limits."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from s3o_drake.world.robot_description import robot_names

REPO = Path(__file__).resolve().parents[2]

PICK = r"""
import json
import numpy as np
from s3o_drake.execution.arm.pickup import plan_pickup
from s3o_drake.feasibility.check import FeasibilityChecker
from s3o_drake.feasibility.scene import FeasibilityScene
from s3o_drake.world.angles import facing_yaw
from s3o_drake.world.resources import SCENARIOS_DIR
from s3o_drake.world.robot import ARM_POSITIONS, ROBOT
from s3o_drake.world.scenario import load_scenario

scenario = load_scenario(SCENARIOS_DIR / "small" / "two_dishes.yaml")
scene = FeasibilityScene(scenario.contents)
checker = FeasibilityChecker(scene)
dish = scenario.dishes[0]
p = np.asarray(dish.position, dtype=float)
angles = np.linspace(-np.pi, np.pi, 24, endpoint=False)
xy = np.concatenate([p + r * np.column_stack([np.cos(angles), np.sin(angles)])
                     for r in (0.6, 0.75, 0.9)])
bases = np.column_stack([xy, facing_yaw(xy, p)])
feasible = np.flatnonzero(checker.check_many(bases, dish.name))
plan = plan_pickup(scene, checker, bases[feasible[0]], dish.name, seed=0)
q = np.vstack([s.waypoints for s in plan.segments])[:, ARM_POSITIONS]
print(json.dumps({"robot": scenario.robot.name, "stops": int(feasible.size), "ok": plan.ok,
                  "duration": plan.duration, "joints": q.shape[1],
                  "within": bool(np.all(q >= np.array(ROBOT.arm.position_lower) - 1e-9)
                                 and np.all(q <= np.array(ROBOT.arm.position_upper) + 1e-9))}))
"""


@pytest.mark.parametrize("robot", robot_names())
def test_every_robot_picks_a_dish_within_its_limits(robot):
    env = dict(os.environ, S3O_ROBOT=robot,
               PYTHONPATH=str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    done = subprocess.run([sys.executable, "-c", PICK], capture_output=True, text=True,
                          env=env, cwd=REPO, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    result = json.loads(done.stdout.strip().splitlines()[-1])
    assert result["robot"] == robot and result["stops"] > 0
    assert result["ok"] and 2.0 < result["duration"] < 30.0
    assert result["within"] and result["joints"] == {"ur5e": 6, "panda": 7}.get(robot,
                                                                             result["joints"])
