"""The base's and the arm's motions checked together, along time.

With smooth motion the arm moves while the base drives (the arm leaves its stow for a
pre-grasp during the base's last approach, and carries a dish to the tray while the base
leaves). Each motion alone is checked where it is planned; what the robot does with both
is checked here, configuration by configuration, with Drake's collision checker of the
world (`FeasibilityScene.checker`). The navigator checks its motion against the arm's,
the arm controller a prepare against the base's.

The configurations are taken every TOGETHER_STEP of simulated time, and more finely where
the robot moves fast: no point of the robot moves more than SWEEP_STEP from one checked
configuration to the next (`RobotSweep`, by the robot's kinematics). A fixed time step
alone misses what the arm sweeps past: the shoulder turning at 3 rad/s while the base
turns moves the hand more than 1 cm in 10 ms: twice the checker's padding in one
TOGETHER_STEP.
"""

import math
from collections.abc import Callable, Sequence

import numpy as np
from pydrake.geometry import Role

from s3o_drake.feasibility.clearance import shape_corners
from s3o_drake.feasibility.robot_checker import RobotChecker
from s3o_drake.feasibility.scene import ENVIRONMENT_PADDING
from s3o_drake.world.robot import Robot
from s3o_drake.world.worker_processes import drake_parallelism

TOGETHER_STEP = 0.02
"""The period (s) at which the two motions are checked together at the least: the base
moves at most 8 mm and 0.016 rad in it; the arm's joints up to 0.06 rad, which SWEEP_STEP
divides further."""
SWEEP_STEP = ENVIRONMENT_PADDING / 2
"""The most (m) any point of the robot moves from one configuration checked together to
the next. Between two, a point is within half of this of where it is in one of them: a
motion that passes keeps three quarters of the checker's padding from the known world."""
WAIT_STEP = 0.25
"""A motion that collides with the other's is tried this much later (s), and again,
until it would start once the other has ended."""


class RobotSweep:
    """How far the robot's collision geometry moves between two configurations (m), by
    forward kinematics on `checker`'s plant: for each body that has collision geometry, its
    origin's displacement plus its rotation's angle times the radius of its geometry about
    the origin, the most any of its points moves in a straight line; the largest over the
    bodies."""

    def __init__(self, checker: RobotChecker) -> None:
        inner = checker.inner
        plant = inner.plant()
        inspector = inner.model().scene_graph().model_inspector()
        self._plant, self._context = plant, plant.CreateDefaultContext()
        self._to_plant = checker.positions.to_plant
        self._bodies, radii = [], []
        for instance in inner.robot_model_instances():
            for index in plant.GetBodyIndices(instance):
                geometries = inspector.GetGeometries(plant.GetBodyFrameIdOrThrow(index),
                                                     Role.kProximity)
                if not geometries:
                    continue
                self._bodies.append(plant.get_body(index))
                radii.append(max(
                    float(np.linalg.norm(inspector.GetPoseInFrame(g).multiply(
                        shape_corners(inspector.GetShape(g)).T), axis=0).max())
                    for g in geometries))
        self._radii = np.array(radii)

    def poses(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The positions (k, 3) and rotation matrices (k, 3, 3) in W of the bodies, the
        robot at positions `q` (`Robot.joints` order)."""
        self._plant.SetPositions(self._context, self._to_plant(np.asarray(q, dtype=float)))
        X_WB = [self._plant.EvalBodyPoseInWorld(self._context, b) for b in self._bodies]
        return (np.array([X.translation() for X in X_WB]),
                np.array([X.rotation().matrix() for X in X_WB]))

    def moved(self, a: tuple[np.ndarray, np.ndarray], b: tuple[np.ndarray, np.ndarray]) -> float:
        """The most any point of the robot moves from poses `a` to poses `b` (`poses`)."""
        (p_a, R_a), (p_b, R_b) = a, b
        cos = (np.einsum("kij,kij->k", R_a, R_b) - 1.0) / 2.0  # trace(R_aᵀ R_b)
        angle = np.arccos(np.clip(cos, -1.0, 1.0))
        return float(np.max(np.linalg.norm(p_b - p_a, axis=1) + angle * self._radii))


def free_together(checker_at: Callable[[float], RobotChecker],
                  base_at: Callable[[float], Sequence[float]],
                  arm_at: Callable[[float], Sequence[float]], start: float, end: float, *,
                  robot: Robot) -> bool:
    """Whether `robot` (the checkers' robot) is collision-free from `start` to `end` (s),
    at every TOGETHER_STEP (both ends included) and in between wherever it moves more than
    SWEEP_STEP, its base at `base_at(t)` (x, y, yaw, ...) and its arm and fingers at
    `arm_at(t)`, by `checker_at(t)` (the world's checker, or while the gripper holds or
    reaches for a dish the one that lets it touch that dish)."""
    if end < start:
        return True
    num_arm = robot.num_arm_joints

    def config(t: float) -> np.ndarray:
        arm = np.asarray(arm_at(t), dtype=float)
        return robot.positions(*np.asarray(base_at(t))[:3], arm=arm[:num_arm],
                               gripper=arm[num_arm:])

    coarse = np.append(np.arange(start, end, TOGETHER_STEP), end)
    configs = [config(float(t)) for t in coarse]
    sweep = RobotSweep(checker_at(float(start)))
    poses = [sweep.poses(q) for q in configs]
    times = list(coarse)
    for k in range(len(coarse) - 1):
        steps = math.ceil(sweep.moved(poses[k], poses[k + 1]) / SWEEP_STEP)
        for t in np.linspace(coarse[k], coarse[k + 1], steps + 1)[1:-1]:
            times.append(float(t))
            configs.append(config(float(t)))
    batches: dict[int, tuple[RobotChecker, list[np.ndarray]]] = {}
    for t, q in zip(times, configs, strict=True):
        checker = checker_at(float(t))
        batches.setdefault(id(checker), (checker, []))[1].append(q)
    return all(all(checker.CheckConfigsCollisionFree(configs, parallelize=drake_parallelism()))
               for checker, configs in batches.values())
