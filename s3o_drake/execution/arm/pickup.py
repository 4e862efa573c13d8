"""The arm's part of `pickup(o)`: from where the base really stands, pick the dish onto the tray.

`plan_pickup` finds the configurations of the pickup with
`s3o_drake.feasibility.pickup_geometry.pickup_geometry` (the very test that Fea^m's oracle
applies: grasp, pre-grasp, closed fingers, lift, tray and release, with the reach noise
T^m already in the grasp target) and joins them into timed motions over the robot's
positions, in this order:

- approach: RRT-Connect from the current configuration to the pre-grasp;
- descend: straight joint line pre-grasp -> grasp;
- close: the fingers close (the dish stops them in simulation);
- lift: straight joint line to the lifted grasp;
- to_tray: RRT-Connect to the configuration over the tray, gripper held as it grasped
  (down for a top grasp, level for a side grasp so that a cup stays upright);
- release: the fingers open;
- stow: RRT-Connect back to the arm's stow (`Robot.arm_stow`).

An object whose goal is place is not let go over the tray: with `hold`, the pickup ends
with "to_tray", the object held above the tray while the base drives on, and
`manipulation.place.plan_place` later puts it down.

Every motion is timed by `arm_motion.time_parameterize` (Drake's TOPPRA) within
`segment_limits`: the arm's joint limits from the robot model (the UR5e's 180 deg/s,
5 rad/s²), `SLOW` of them near the dish (descend, lift), the fingers at FINGER_MAX_*; the
corners of a multi-waypoint path are rounded where the motion's own checker finds the
rounded curve collision-free. A UR5e pickup then takes a median 7.2 s of simulated time
against 13.0 s with the trapezoids at 1 rad/s that it replaced (docs/execution.md,
`pickup_benchmark`).

The three RRT-Connect paths are what the oracle leaves out; the scene's own checker (1 cm
padding, nothing may be touched) judges approach and stow, the grasping checker
(`ik.grasp_checker`: the gripper's bodies may touch this dish, and only they) the motions
where the gripper is at, or holds, the dish. The checker's dish stays where it stood on the
table: while carrying, the dish in the hand is not part of the collision model (its own
collisions are ignored on the way to the tray), and the model's copy on the table may be
touched only by the gripper.
"""

from dataclasses import dataclass, field

import numpy as np
from pydrake.multibody.plant import MultibodyPlant
from pydrake.trajectories import CompositeTrajectory, PathParameterizedTrajectory, Trajectory

from s3o_drake.execution.arm.arm_motion import (
    joint_limits,
    plan_arm_path,
    shifted,
    time_parameterize,
)
from s3o_drake.feasibility import ik
from s3o_drake.feasibility.check import FeasibilityChecker
from s3o_drake.feasibility.pickup_geometry import PickupGeometry, pickup_geometry, with_gripper
from s3o_drake.feasibility.robot_checker import RobotChecker
from s3o_drake.feasibility.scene import FeasibilityScene
from s3o_drake.world.robot import PositionMap, Robot

SEGMENT_NAMES = ("approach", "descend", "close", "lift", "to_tray", "release", "stow")
#: Near the dish (SLOW_SEGMENTS) the arm keeps to this fraction of its joint limits, so that
#: the hand arrives at the grasp gently and the PD-tracked arm settles before the fingers close.
SLOW = 0.5
SLOW_SEGMENTS = ("descend", "lift", "lower", "retreat")
#: The finger pads' speed and acceleration limits (m/s, m/s²); the plant allows 0.15 m/s.
FINGER_MAX_VELOCITY = 0.1
FINGER_MAX_ACCELERATION = 0.5


def finger_limits(robot: Robot) -> tuple[np.ndarray, np.ndarray]:
    """The speed and acceleration limits of `robot`'s gripper joints, in their own units:
    FINGER_MAX_* of the pads, through each joint's motion per metre of their travel (a
    knuckle's radians for a linkage gripper)."""
    per_metre = robot.finger_joint_per_metre
    return FINGER_MAX_VELOCITY * per_metre, FINGER_MAX_ACCELERATION * per_metre


@dataclass(frozen=True)
class Segment:
    """One timed motion: `trajectory` gives the robot's positions over [0, duration].

    `waypoints` (k, the robot's positions) is the path whose straight edges were checked; the
    trajectory runs along them, stopping at each (`smoothed` False), or along a curve that
    rounds their corners and was itself checked densely (`smoothed` True; see
    `time_parameterize`).
    """

    name: str
    trajectory: PathParameterizedTrajectory
    duration: float
    waypoints: np.ndarray
    smoothed: bool = False


@dataclass
class PickupPlan:
    """Either ok with the segments in order, or not ok with why ("no_ik", "no_path",
    "base_collision")."""

    ok: bool
    reason: str
    segments: list[Segment] = field(default_factory=list)
    grasp: str | None = None

    @property
    def duration(self) -> float:
        return sum(s.duration for s in self.segments)

    def trajectory(self) -> Trajectory:
        """The segments joined into one trajectory starting at t = 0."""
        if not self.segments:
            raise ValueError("an unsuccessful plan has no trajectory")
        pieces, t0 = [], 0.0
        for segment in self.segments:
            pieces.append(shifted(segment.trajectory, t0))
            t0 += segment.duration
        return CompositeTrajectory(pieces)


def segment_limits(plant: MultibodyPlant, name: str, *, robot: Robot,
                   positions: PositionMap | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Speed and acceleration limits of `robot`'s positions in segment `name` (the plant's
    are the robot's, or the robot's are among them at `positions`): the arm's from
    the robot model (models/<robot>/, their sources in its robot.yaml), the fingers' the
    gentler FINGER_MAX_*, all times SLOW in SLOW_SEGMENTS; the base does not move within a
    pickup (the model's limits, unused)."""
    v, a = joint_limits(plant, positions)
    fingers = robot.gripper_positions
    finger_v, finger_a = finger_limits(robot)
    v[fingers] = np.minimum(v[fingers], finger_v)
    a[fingers] = np.minimum(a[fingers], finger_a)
    if name in SLOW_SEGMENTS:
        v, a = v * SLOW, a * SLOW
    return v, a


def timed_segment(name: str, path: np.ndarray, checker: RobotChecker, *,
                  robot: Robot) -> Segment:
    """`path` (positions of `robot`, the checker's) timed by TOPPRA within `segment_limits`,
    its corners rounded where `checker` finds the rounded curve collision-free."""
    positions = checker.positions
    v, a = segment_limits(checker.plant(), name, robot=robot, positions=positions)
    timed = time_parameterize(path, checker.plant(), max_velocity=v, max_acceleration=a,
                              checker=checker, positions=positions)
    return Segment(name, timed.trajectory, timed.duration, path, timed.smoothed)


def start_geometry(scene: FeasibilityScene, checker: FeasibilityChecker, base: np.ndarray,
                   target: str, *, q_start: np.ndarray | None,
                   reach_offset: np.ndarray | None, grasp: str | None
                   ) -> tuple[np.ndarray, PickupGeometry]:
    """Where an arm motion at `target` starts, the robot's positions (`q_start`,
    default the arm stowed and the gripper open, its base entries set to `base`), and the
    configurations of picking `target` from there (`pickup_geometry`); shared by a pickup
    and a place. Raises ValueError for a `q_start` of another shape."""
    robot = scene.robot
    base = np.asarray(base, dtype=float).reshape(3)
    q0 = scene.q(base) if q_start is None else np.asarray(q_start, dtype=float).copy()
    if q0.shape != (robot.num_positions,):
        raise ValueError(f"q_start: expected {robot.num_positions} positions, "
                         f"got shape {q0.shape}")
    q0[:3] = base
    return q0, pickup_geometry(scene, checker, base, target, reach_offset=reach_offset,
                               q_arm=q0[robot.arm_positions], grasp=grasp)


def plan_pickup(scene: FeasibilityScene, checker: FeasibilityChecker, base: np.ndarray,
                dish: str, *, reach_offset: np.ndarray | None = None,
                q_start: np.ndarray | None = None, seed: int = 0,
                time_limit: float = 5.0, hold: bool = False,
                grasp: str | None = None, stow: bool = True) -> PickupPlan:
    """The timed arm motions that pick `dish` onto the tray from base pose `base` (x, y, yaw)
    (with `hold`: that pick it and hold it above the tray, ending with "to_tray"; without
    `stow`: that leave the arm over the tray after "release", where the next pickup's
    approach starts).

    `base` is where the robot really stands; `reach_offset` is the reach noise (moves the
    grasp target, as in `FeasibilityChecker.check`); `q_start` the robot's positions now
    (default: the arm stowed, gripper open; its base entries are replaced by `base`). `seed` and
    `time_limit` (seconds per RRT-Connect query) go to `plan_arm_path`. Not ok with reason
    "base_collision" (the base stands in collision), "no_ik" (no collision-free grasp, or no
    pre-grasp/lift on its branch) or "no_path" (some motion found no collision-free path).
    `grasp` ("top" or "side"), when given, is the only kind of grasp tried.
    """
    q0, geometry = start_geometry(scene, checker, base, dish, q_start=q_start,
                                  reach_offset=reach_offset, grasp=grasp)
    if not geometry.ok:
        return PickupPlan(False, geometry.reason, grasp=geometry.grasp)
    c = geometry.configurations
    robot = scene.robot
    free = scene.checker
    holding = ik.grasp_checker(scene, dish)
    fail = PickupPlan(False, "no_path", grasp=c.grasp)
    q_open = with_gripper(q0, robot.gripper_open, robot=robot)
    opening = not np.allclose(q0[robot.gripper_positions], robot.gripper_open)
    # Fingers not open: they open first, where the arm stands.
    if opening and not free.CheckEdgeCollisionFree(q0, q_open):
        return fail
    approach = plan_arm_path(free, q_open, c.q_pre, robot=robot, time_limit=time_limit,
                             seed=seed)
    if approach is None:
        return fail
    if opening:
        approach = np.vstack([q0[None, :], approach])
    # pickup_geometry checked the straight motions (descend, close, lift, release).
    segments = [timed_segment("approach", approach, free, robot=robot),
                timed_segment("descend", np.stack([c.q_pre, c.q_grasp]), holding, robot=robot),
                timed_segment("close", np.stack([c.q_grasp, c.q_closed]), holding, robot=robot),
                timed_segment("lift", np.stack([c.q_closed, c.q_lift]), holding, robot=robot)]
    rest = (("to_tray", c.q_lift, c.q_tray, holding),
            ("release", c.q_tray, c.q_release, free),
            ("stow", c.q_release, c.q_stow, free))
    for name, a, b, path_checker in rest[:1] if hold else rest if stow else rest[:2]:
        if name == "release":
            path = np.stack([a, b])
        else:
            path = plan_arm_path(path_checker, a, b, robot=robot, time_limit=time_limit,
                                 seed=seed, turned_goal=name == "stow")
        if path is None:
            return fail
        segments.append(timed_segment(name, path, path_checker, robot=robot))
    return PickupPlan(True, "ok", segments, grasp=c.grasp)


def plan_reach(scene: FeasibilityScene, checker: FeasibilityChecker, base: np.ndarray,
               q_start: np.ndarray, target: str | None, *, seed: int = 0,
               time_limit: float = 5.0) -> PickupPlan:
    """The timed arm motion ("reach", RRT-Connect) from the robot's positions `q_start` to
    `target`'s pre-grasp as seen from base pose `base` (x, y, yaw), or with no `target` to
    the arm's stow; checked with the base standing at `base`. Not ok with the pickup's reasons
    (`plan_pickup`)."""
    robot = scene.robot
    q0 = np.asarray(q_start, dtype=float).copy()
    q0[:3] = np.asarray(base, dtype=float).reshape(3)
    free = scene.arm_checker(q0)
    if target is None:
        goal = with_gripper(scene.q(q0[:3]), q0[robot.gripper_positions], robot=robot)
    else:
        geometry = pickup_geometry(scene, checker, q0[:3], target,
                                   q_arm=q0[robot.arm_positions])
        if not geometry.ok:
            return PickupPlan(False, geometry.reason, grasp=geometry.grasp)
        goal = geometry.configurations.q_pre
    try:
        path = plan_arm_path(free, q0, goal, robot=robot, time_limit=time_limit, seed=seed,
                             turned_goal=target is None)
    except ValueError:
        return PickupPlan(False, "no_path")  # the arm stands in collision, within the padding
    if path is None:
        return PickupPlan(False, "no_path")
    return PickupPlan(True, "ok", [timed_segment("reach", path, free, robot=robot)])


def plan_release(scene: FeasibilityScene, base: np.ndarray, q_start: np.ndarray, *,
                 seed: int = 0, time_limit: float = 5.0) -> PickupPlan:
    """The timed arm motions that let go of a held object where the arm holds it, above
    the tray (where a pickup with `hold` left it), and stow: "release" (the fingers open),
    "stow" (RRT-Connect to the arm's stow). Not ok with reason "no_path"."""
    robot = scene.robot
    q0 = np.asarray(q_start, dtype=float).copy()
    q0[:3] = np.asarray(base, dtype=float).reshape(3)
    free = scene.arm_checker(q0)
    q_open = with_gripper(q0, robot.gripper_open, robot=robot)
    q_stow = with_gripper(scene.q(q0[:3]), robot.gripper_open, robot=robot)
    fail = PickupPlan(False, "no_path")
    if not free.CheckEdgeCollisionFree(q0, q_open):
        return fail
    try:
        stow = plan_arm_path(free, q_open, q_stow, robot=robot, time_limit=time_limit,
                             seed=seed, turned_goal=True)
    except ValueError:
        return fail  # the arm stands in collision, within the padding
    if stow is None:
        return fail
    return PickupPlan(True, "ok", [
        timed_segment("release", np.stack([q0, q_open]), free, robot=robot),
        timed_segment("stow", stow, free, robot=robot)])
