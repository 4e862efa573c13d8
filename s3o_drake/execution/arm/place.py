"""The arm's part of `place(o)`: put the object held in the gripper down at its place.

An object whose goal is place was picked with `plan_pickup(..., hold=True)` and is held
above the tray, with the grasp it was picked with. Its place target (`goals.PlaceTarget`)
stands in the checker's scene as an object of its kind at the place (`goals.
place_target_dishes`), and putting the object down there is the reverse of picking that
target up: `plan_place` finds the target's pickup configurations with the same test as
Fea^m (`pickup_geometry`, restricted to the grasp the object is held with, so that the
hand never has to re-grasp), then joins, over the robot's positions:

- approach: RRT-Connect from where the arm holds the object to the target's pre-grasp,
  the fingers kept closed on the object;
- lower: straight joint line pre-grasp -> grasp: the object comes down onto its surface;
- release: the fingers open;
- retreat: straight joint line back to the pre-grasp;
- stow: RRT-Connect back to the arm's stow.

Each is timed by TOPPRA as a pickup's motions are (`pickup.timed_segment`; lower and retreat
at SLOW). The checkers are the pickup's: the scene's own (1 cm padding) for approach and
stow, the target's grasping checker (the gripper may touch the target, and only it) for
the motions at the place. The held object itself is not in the collision model, as on the
way to the tray.
"""

import numpy as np

from s3o_drake.execution.arm.arm_motion import plan_arm_path
from s3o_drake.execution.arm.pickup import PickupPlan, start_geometry, timed_segment
from s3o_drake.feasibility import ik
from s3o_drake.feasibility.check import FeasibilityChecker
from s3o_drake.feasibility.grasps import GRASP_KINDS
from s3o_drake.feasibility.landing import pickup_poses
from s3o_drake.feasibility.pickup_geometry import pickup_geometry, with_gripper
from s3o_drake.feasibility.scene import FeasibilityScene

PLACE_SEGMENTS = ("approach", "lower", "release", "retreat", "stow")


def place_grasps(scene: FeasibilityScene, checker: FeasibilityChecker, base: np.ndarray,
                 target: str, *, landing_noise: np.ndarray | None = None) -> list[str]:
    """The kinds of grasp ("top", "side") that an object held with could be put down with
    at place target `target`, sent to base pose `base`: what its pickup should prefer,
    since the hand never re-grasps. Without `landing_noise`, those that work from `base`
    itself; with it (dx, dy, dyaw) per row, those that work from some of the landings it
    gives (as the execution lands: `landing.pickup_poses`), the grasp that works from most
    of them first. Where several work from the stop, the landing decides which one the
    place will need (often one alone), and the mixed-task study found places failing no_ik
    with the grasp the noise-free stop had let the pickup choose."""
    base = np.asarray(base, dtype=float).reshape(3)
    if landing_noise is None:
        poses = base[None]
    else:
        noise = np.asarray(landing_noise, dtype=float).reshape(-1, 3)
        p_WT, _ = scene.dish_p_WD(target)
        poses, landed = pickup_poses(checker.base_free, np.tile(base[:2], (len(noise), 1)),
                                     p_WT[:2], noise)
        poses = poses[landed]
    works = {g: sum(pickup_geometry(scene, checker, q, target, grasp=g).ok for q in poses)
             for g in GRASP_KINDS}
    # sorted() is stable: equally good grasps keep GRASP_KINDS' order.
    return sorted((g for g in GRASP_KINDS if works[g] > 0), key=lambda g: -works[g])


def plan_place(scene: FeasibilityScene, checker: FeasibilityChecker, base: np.ndarray,
               target: str, *, grasp: str, q_start: np.ndarray,
               reach_offset: np.ndarray | None = None, seed: int = 0,
               time_limit: float = 5.0) -> PickupPlan:
    """The timed arm motions that put the held object down at place target `target` (a
    dish of `scene`) from base pose `base` (x, y, yaw), holding it with `grasp` ("top" or
    "side").

    `q_start` is the robot's positions now (the fingers as they hold the object; its
    base entries are replaced by `base`); `reach_offset` the reach noise (moves where the
    object is put down); `seed` and `time_limit` go to `plan_arm_path`. Not ok with reason
    "base_collision", "no_ik" (no grasp of that kind at the target, or no pre-grasp on its
    branch) or "no_path" (no collision-free motion).
    """
    q0, geometry = start_geometry(scene, checker, base, target, q_start=q_start,
                                  reach_offset=reach_offset, grasp=grasp)
    if not geometry.ok:
        return PickupPlan(False, geometry.reason, grasp=grasp)
    c = geometry.configurations
    robot = scene.robot
    fingers = q0[robot.gripper_positions]
    q_pre = with_gripper(c.q_pre, fingers, robot=robot)
    q_down = with_gripper(c.q_grasp, fingers, robot=robot)
    free = scene.checker
    at_place = ik.grasp_checker(scene, target)
    fail = PickupPlan(False, "no_path", grasp=grasp)
    try:
        approach = plan_arm_path(free, q0, q_pre, robot=robot, time_limit=time_limit,
                                 seed=seed)
    except ValueError:
        return fail  # the arm stands in collision, within the padding: no path from here
    # pickup_geometry checked the straight motions at the place (descend and close, here
    # run backwards); the fingers open from where they hold the object.
    if approach is None or not at_place.CheckEdgeCollisionFree(q_down, c.q_grasp):
        return fail
    stow = plan_arm_path(free, c.q_pre, c.q_stow, robot=robot, time_limit=time_limit,
                         seed=seed, turned_goal=True)
    if stow is None:
        return fail
    segments = [timed_segment("approach", approach, free, robot=robot),
                timed_segment("lower", np.stack([q_pre, q_down]), at_place, robot=robot),
                timed_segment("release", np.stack([q_down, c.q_grasp]), at_place, robot=robot),
                timed_segment("retreat", np.stack([c.q_grasp, c.q_pre]), at_place, robot=robot),
                timed_segment("stow", stow, free, robot=robot)]
    return PickupPlan(True, "ok", segments, grasp=grasp)
