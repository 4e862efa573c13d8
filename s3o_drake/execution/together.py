"""The base's and the arm's motions checked together, along time.

With smooth motion the arm moves while the base drives (the arm leaves its stow for a
pre-grasp during the base's last approach, and carries a dish to the tray while the base
leaves). Each motion alone is checked where it is planned; what the robot does with both
is checked here, configuration by configuration every TOGETHER_STEP of simulated time,
with Drake's collision checker of the world (`FeasibilityScene.checker`). The navigator
checks its motion against the arm's, the arm controller a prepare against the base's.
"""

from collections.abc import Callable, Sequence

import numpy as np

from s3o_drake.feasibility.robot_checker import RobotChecker
from s3o_drake.world.robot import Robot
from s3o_drake.world.worker_processes import drake_parallelism

TOGETHER_STEP = 0.02
"""The period (s) at which the two motions are checked together: the base moves at most
8 mm and 0.016 rad in it, the arm's joints at most 0.06 rad."""
WAIT_STEP = 0.25
"""A motion that collides with the other's is tried this much later (s), and again,
until it would start once the other has ended."""


def free_together(checker_at: Callable[[float], RobotChecker],
                  base_at: Callable[[float], Sequence[float]],
                  arm_at: Callable[[float], Sequence[float]], start: float, end: float, *,
                  robot: Robot) -> bool:
    """Whether `robot` (the checkers' robot) is collision-free at every TOGETHER_STEP from
    `start` to `end` (s, both included), its base at `base_at(t)` (x, y, yaw, ...) and its
    arm and fingers at `arm_at(t)`, by `checker_at(t)` (the world's checker, or while the
    gripper holds or reaches for a dish the one that lets it touch that dish)."""
    if end < start:
        return True
    times = np.append(np.arange(start, end, TOGETHER_STEP), end)
    batches: dict[int, tuple[RobotChecker, list[np.ndarray]]] = {}
    num_arm = robot.num_arm_joints
    for t in times:
        arm = np.asarray(arm_at(float(t)), dtype=float)
        checker = checker_at(float(t))
        batches.setdefault(id(checker), (checker, []))[1].append(
            robot.positions(*np.asarray(base_at(float(t)))[:3], arm=arm[:num_arm],
                            gripper=arm[num_arm:]))
    return all(all(checker.CheckConfigsCollisionFree(configs, parallelize=drake_parallelism()))
               for checker, configs in batches.values())
