"""The base's and the arm's motions checked together: fast sweeps are checked finely."""

import numpy as np
import pytest
from pydrake.geometry import Role

from s3o_drake.execution.together import TOGETHER_STEP, RobotSweep, free_together
from s3o_drake.feasibility.clearance import shape_corners

BESIDE = (2.0, 1.55, np.pi / 2)
"""A base pose beside the two-dish table (y from 2.1), facing it."""
REACHING = (np.pi, -0.3, 1.0)
"""The arm's first three joints with the hand in the table in front of BESIDE."""


def _corners_W(scene, q: np.ndarray) -> np.ndarray:
    """Every corner of every robot collision shape's bound, in W, the robot at `q`."""
    checker = scene.checker.inner
    plant, inspector = checker.plant(), checker.model().scene_graph().model_inspector()
    context = checker.UpdatePositions(scene.positions.to_plant(q))
    points = []
    for instance in checker.robot_model_instances():
        for index in plant.GetBodyIndices(instance):
            X_WB = plant.EvalBodyPoseInWorld(context, plant.get_body(index))
            for g in inspector.GetGeometries(plant.GetBodyFrameIdOrThrow(index),
                                             Role.kProximity):
                X_WG = X_WB @ inspector.GetPoseInFrame(g)
                points.append(X_WG.multiply(shape_corners(inspector.GetShape(g)).T).T)
    return np.vstack(points)


def test_the_sweep_bounds_how_far_every_point_of_the_robot_moves(scene):
    """Between two nearby configurations no corner of the robot's geometry moves further
    than `moved` says; a base that only drives moves every point by its drive."""
    robot = scene.robot
    sweep = RobotSweep(scene.checker)
    rng = np.random.default_rng(0)
    for _ in range(20):
        q = robot.positions(*rng.uniform([0.0, 0.0, -np.pi], [4.0, 4.0, np.pi]),
                            arm=rng.uniform(-np.pi, np.pi, robot.num_arm_joints))
        step = rng.normal(0.0, 0.05, q.size)
        step[robot.arm_positions.stop:] = 0.0  # the fingers: within their travel
        moved = sweep.moved(sweep.poses(q), sweep.poses(q + step))
        actual = np.linalg.norm(_corners_W(scene, q + step) - _corners_W(scene, q), axis=1)
        assert actual.max() <= moved + 1e-9
    q = robot.positions(*BESIDE)
    driven = robot.positions(BESIDE[0] + 0.03, BESIDE[1] - 0.04, BESIDE[2])
    assert sweep.moved(sweep.poses(q), sweep.poses(driven)) == pytest.approx(0.05)


def _swing(scene, base, start: float, end: float):
    """The base standing at `base`, the arm reaching out (REACHING) and its shoulder
    turning from `start` to `end` (rad) in one TOGETHER_STEP: (base_at, arm_at)."""
    robot = scene.robot

    def arm_at(t: float) -> np.ndarray:
        arm = np.array(robot.arm_stow, dtype=float)
        arm[:3] = REACHING
        arm[0] = start + (end - start) * min(max(t / TOGETHER_STEP, 0.0), 1.0)
        return np.concatenate([arm, robot.gripper_open])

    return (lambda t: base), arm_at


def test_an_arm_that_swings_through_the_table_between_two_checks_is_caught(scene):
    """The shoulder swings the reaching hand across the table within one TOGETHER_STEP:
    free where the step's two configurations are, in the table in between. The check
    looks where the robot goes between them; turned away from the table the same swing is
    free."""
    robot = scene.robot
    base_at, arm_at = _swing(scene, BESIDE, 0.0, 2 * np.pi)
    pans = np.linspace(0.0, 2 * np.pi, 721)
    free = scene.checker.CheckConfigsCollisionFree(
        [robot.positions(*BESIDE, arm=np.r_[pan, REACHING[1:], robot.arm_stow[3:]])
         for pan in pans])
    blocked = np.flatnonzero(~np.asarray(free, dtype=bool))
    assert blocked.size and blocked[-1] - blocked[0] == blocked.size - 1  # one stretch
    start, end = pans[blocked[0] - 2], pans[blocked[-1] + 2]  # free, on either side
    base_at, arm_at = _swing(scene, BESIDE, start, end)
    ends = [robot.positions(*BESIDE, arm=arm_at(t)[:robot.num_arm_joints])
            for t in (0.0, TOGETHER_STEP)]
    assert all(scene.checker.CheckConfigsCollisionFree(ends))
    assert not free_together(lambda t: scene.checker, base_at, arm_at, 0.0, TOGETHER_STEP,
                             robot=robot)
    turned_away = (*BESIDE[:2], -BESIDE[2])
    base_at, arm_at = _swing(scene, turned_away, start, end)
    assert free_together(lambda t: scene.checker, base_at, arm_at, 0.0, TOGETHER_STEP,
                         robot=robot)
