"""The arm's part of `pickup(o)`: from where the base really stands, pick the dish onto the tray.

`plan_pickup` turns one feasibility check (the grasp configuration of
`FeasibilityChecker.check`, with the reach noise T^m already in its target) into timed
motions over the robot's 11 positions, in this order:

- approach: RRT-Connect from the current configuration to the pre-grasp, the grasp pose
  backed off `APPROACH_BACKOFF` against the approach axis (top grasp: above the dish; side
  grasp: behind it), solved on the grasp's IK branch; when that pose or the straight line
  from it to the grasp collides (a side grasp of a cup beyond a plate would sweep the hand
  through the plate), back and up, from above, then half as far are tried;
- descend: straight joint line pre-grasp -> grasp;
- close: the fingers close (the dish stops them in simulation);
- lift: straight joint line to the grasp pose raised by `LIFT_HEIGHT` (for a top grasp this
  is the pre-grasp);
- to_tray: RRT-Connect to the release configuration, the grasp frame `TRAY_CLEARANCE`
  above the tray's centre, gripper held as it grasped (down for a top grasp, level for a
  side grasp so that a cup stays upright);
- release: the fingers open;
- stow: RRT-Connect back to ARM_STOW.

Every motion is timed by `arm_motion.time_parameterize` (Drake's TOPPRA) within
`segment_limits`: the UR5e's joint limits from the robot model (180 deg/s, 5 rad/s²), `SLOW`
of them near the dish (descend, lift), the fingers at FINGER_MAX_*; the corners of a
multi-waypoint path are rounded where the motion's own checker finds the rounded curve
collision-free. A pickup then takes a median 7.2 s of simulated time against 13.0 s with the
trapezoids at 1 rad/s that it replaced (docs/execution.md, `pickup_benchmark`).

Which collision checker judges each motion: the scene's own (1 cm padding, nothing may be
touched) for approach, release and stow; the grasping checker (`ik.grasp_checker`: the
gripper's bodies may touch this dish, and only they) for descend, close, lift and to_tray,
where the gripper is at, or holds, the dish. The checker's dish stays where it stood on the
table: while carrying, the dish in the hand is not part of the collision model (its own
collisions are ignored on the way to the tray), and the model's copy on the table may be
touched only by the gripper.
"""

import math
from dataclasses import dataclass, field

import numpy as np
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.plant import MultibodyPlant
from pydrake.planning import SceneGraphCollisionChecker
from pydrake.trajectories import CompositeTrajectory, PathParameterizedTrajectory, Trajectory

from s3o_drake.execution.arm_motion import (
    ARM,
    joint_limits,
    plan_arm_path,
    shifted,
    time_parameterize,
)
from s3o_drake.feasibility import ik
from s3o_drake.feasibility import kinematics as kin
from s3o_drake.feasibility.check import FeasibilityChecker
from s3o_drake.feasibility.grasps import R_BEARING_SIDE, R_BEARING_TOP
from s3o_drake.feasibility.scene import FeasibilityScene
from s3o_drake.robot import (
    ARM_MOUNT_XYZ,
    ARM_STOW,
    GRIPPER_CLOSED,
    GRIPPER_OPEN,
    NUM_POSITIONS,
    TRAY_XYZ,
)

SEGMENT_NAMES = ("approach", "descend", "close", "lift", "to_tray", "release", "stow")
REASONS = ("ok", "no_ik", "no_path", "base_collision")
#: Pre-grasp distance from the grasp pose against the approach axis (m).
APPROACH_BACKOFF = 0.09
#: How far the grasped dish is lifted straight up (m).
LIFT_HEIGHT = 0.09
#: How far the lift may also draw the dish towards the arm when straight up is out of reach (m).
LIFT_INWARD = 0.08
#: Height of the grasp frame above the tray's floor at release (m): the dish's bottom
#: then clears the 3 cm rim (a cup held at 6 cm up its side sits ~4 cm above the floor).
TRAY_CLEARANCE = 0.10
#: Near the dish (SLOW_SEGMENTS) the arm keeps to this fraction of its joint limits, so that
#: the hand arrives at the grasp gently and the PD-tracked arm settles before the fingers close.
SLOW = 0.5
SLOW_SEGMENTS = ("descend", "lift")
#: Finger speed and acceleration limits (m/s, m/s²); the plant allows 0.15 m/s.
FINGER_MAX_VELOCITY = 0.1
FINGER_MAX_ACCELERATION = 0.5
#: IK tolerance of the derived poses (pre-grasp, lift, tray): rad and m.
POSE_TOLERANCE = 1e-4
#: Joints that turn ±2π (all but the elbow): their angles may be shifted by 2π.
_WRAPPING = np.array([True, True, False, True, True, True])


@dataclass(frozen=True)
class Segment:
    """One timed motion: `trajectory` gives the robot's 11 positions over [0, duration].

    `waypoints` (n, 11) is the path whose straight edges were checked; the trajectory runs
    along them, stopping at each (`smoothed` False), or along a curve that rounds their
    corners and was itself checked densely (`smoothed` True; see `time_parameterize`).
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


def segment_limits(plant: MultibodyPlant, name: str) -> tuple[np.ndarray, np.ndarray]:
    """Speed and acceleration limits of the 11 positions in segment `name`: the arm's from
    the robot model (the UR5e's; models/robot/mobile_manipulator.urdf), the fingers' the
    gentler FINGER_MAX_*, all times SLOW in SLOW_SEGMENTS; the base does not move within a
    pickup (the model's limits, unused)."""
    v, a = joint_limits(plant)
    v[9:] = np.minimum(v[9:], FINGER_MAX_VELOCITY)
    a[9:] = np.minimum(a[9:], FINGER_MAX_ACCELERATION)
    if name in SLOW_SEGMENTS:
        v, a = v * SLOW, a * SLOW
    return v, a


def _segment(name: str, path: np.ndarray, checker: SceneGraphCollisionChecker) -> Segment:
    """`path` timed by TOPPRA within `segment_limits`, its corners rounded where `checker`
    finds the rounded curve collision-free."""
    v, a = segment_limits(checker.plant(), name)
    timed = time_parameterize(path, checker.plant(), max_velocity=v, max_acceleration=a,
                              checker=checker)
    return Segment(name, timed.trajectory, timed.duration, path, timed.smoothed)


def X_WA(base: np.ndarray) -> RigidTransform:
    """Pose of the arm's base frame A (axes parallel to base_link's) for a base (x, y, yaw)."""
    x, y, yaw = base
    R = RotationMatrix.MakeZRotation(yaw)
    return RigidTransform(R, np.array([x, y, 0.0]) + R @ np.array(ARM_MOUNT_XYZ))


def _nearest_turn(q: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """q with its ±2π joints shifted by whole turns towards `reference`, inside ±2π."""
    shifted = q.copy()
    turns = np.round((reference - q) / (2 * math.pi))
    shifted[_WRAPPING] += 2 * math.pi * turns[_WRAPPING]
    out = np.abs(shifted) > 2 * math.pi
    shifted[out] -= np.sign(shifted[out]) * 2 * math.pi
    return shifted


def solve_arm(R_AG: np.ndarray, p_AG: np.ndarray, reference: np.ndarray) -> list[np.ndarray]:
    """Arm configurations putting G at (R_AG, p_AG), the nearest to `reference` first.

    Newton steps from `reference` (the same IK branch, when it reaches) come first, then
    the closed-form solutions of every branch, each turned as near `reference` as allowed.
    """
    found = []
    q, angle, distance = kin.refine(reference[None], R_AG[None], p_AG[None], iterations=20)
    if angle[0] < POSE_TOLERANCE and distance[0] < POSE_TOLERANCE:
        found.append(_nearest_turn(q[0], reference))
    branches = kin.inverse(R_AG[None], p_AG[None])[0]
    branches = [_nearest_turn(b, reference) for b in branches if not np.isnan(b).any()]
    branches.sort(key=lambda b: float(np.linalg.norm(b - reference)))
    for b in branches:
        R, p = kin.forward(b)
        angle, distance = kin.pose_error(R, p, R_AG, p_AG)
        if angle < POSE_TOLERANCE and distance < POSE_TOLERANCE:
            found.append(b)
    return found


def _moved(q: np.ndarray, base: np.ndarray, X_WG_target: RigidTransform,
           checker: SceneGraphCollisionChecker) -> np.ndarray | None:
    """q (11) with the arm moved so that G is at X_WG_target, collision-free, or None."""
    X_AG = X_WA(base).inverse() @ X_WG_target
    for arm in solve_arm(X_AG.rotation().matrix(), X_AG.translation(), q[ARM]):
        candidate = q.copy()
        candidate[ARM] = arm
        if checker.CheckConfigCollisionFree(candidate):
            return candidate
    return None


def tray_configuration(base: np.ndarray, grasp: str, q_from: np.ndarray,
                       checker: SceneGraphCollisionChecker) -> np.ndarray | None:
    """The robot's 11 positions at release over the tray (fingers as in `q_from`), or None.

    G is `TRAY_CLEARANCE` above the tray's centre; a top grasp keeps the gripper pointing
    down, a side grasp keeps it level (a cup stays upright). Headings of the approach axis
    are tried from pointing backwards round to sideways; per heading, the configuration
    nearest ARM_STOW that is collision-free wins.
    """
    p_BT = np.array(TRAY_XYZ) + np.array([0.0, 0.0, TRAY_CLEARANCE])
    p_AG = p_BT - np.array(ARM_MOUNT_XYZ)
    R_bearing = R_BEARING_TOP if grasp == "top" else R_BEARING_SIDE
    for heading in (math.pi, 0.5 * math.pi, -0.5 * math.pi, 0.75 * math.pi, -0.75 * math.pi,
                    0.0):
        R_AG = (RotationMatrix.MakeZRotation(heading) @ R_bearing).matrix()
        for arm in solve_arm(R_AG, p_AG, np.asarray(ARM_STOW)):
            q = q_from.copy()
            q[:3] = base
            q[ARM] = arm
            if checker.CheckConfigCollisionFree(q):
                return q
    return None


def _with_gripper(q: np.ndarray, gripper: np.ndarray) -> np.ndarray:
    out = q.copy()
    out[9:] = gripper
    return out


def plan_pickup(scene: FeasibilityScene, checker: FeasibilityChecker, base: np.ndarray,
                dish: str, *, reach_offset: np.ndarray | None = None,
                q_start: np.ndarray | None = None, seed: int = 0,
                time_limit: float = 5.0) -> PickupPlan:
    """The timed arm motions that pick `dish` onto the tray from base pose `base` (x, y, yaw).

    `base` is where the robot really stands; `reach_offset` is the reach noise (moves the
    grasp target, as in `FeasibilityChecker.check`); `q_start` the robot's 11 positions now
    (default: ARM_STOW, gripper open; its base entries are replaced by `base`). `seed` and
    `time_limit` (seconds per RRT-Connect query) go to `plan_arm_path`. Not ok with reason
    "base_collision" (the base stands in collision), "no_ik" (no collision-free grasp, or no
    pre-grasp/lift on its branch) or "no_path" (some motion found no collision-free path).
    """
    base = np.asarray(base, dtype=float).reshape(3)
    q0 = scene.q(base) if q_start is None else np.asarray(q_start, dtype=float).copy()
    if q0.shape != (NUM_POSITIONS,):
        raise ValueError(f"q_start: expected {NUM_POSITIONS} positions, got shape {q0.shape}")
    q0[:3] = base
    result = checker.check(base, dish, reach_offset)
    if not result.feasible:
        reason = "base_collision" if result.reason == "base_collision" else "no_ik"
        return PickupPlan(False, reason)
    free = scene.checker
    holding = ik.grasp_checker(scene, dish)
    q_grasp = _with_gripper(result.q, GRIPPER_OPEN)
    # The same grasp with its ±2π joints a whole turn nearer to where the arm is now: the
    # same geometry (so just as collision-free), less to turn.
    q_grasp[ARM] = _nearest_turn(q_grasp[ARM], q0[ARM])
    X_WG = scene.grasp_pose(q_grasp)
    approach_axis = X_WG.rotation().col(2)
    up = np.array([0.0, 0.0, 1.0])
    # Straight back along the approach axis first; when that sweeps the hand through a
    # neighbouring dish (a cup beyond a plate), back and up, then from above, then shorter.
    q_pre = None
    for offset in (-APPROACH_BACKOFF * approach_axis,
                   -APPROACH_BACKOFF * approach_axis + 0.5 * APPROACH_BACKOFF * up,
                   APPROACH_BACKOFF * up,
                   -0.5 * APPROACH_BACKOFF * approach_axis,
                   0.5 * APPROACH_BACKOFF * up,
                   0.3 * APPROACH_BACKOFF * up):
        q_pre = _moved(q_grasp, base, RigidTransform(X_WG.rotation(),
                                                     X_WG.translation() + offset), free)
        if q_pre is not None and holding.CheckEdgeCollisionFree(q_pre, q_grasp):
            break
        q_pre = None
    q_closed = _with_gripper(q_grasp, GRIPPER_CLOSED)
    # Straight up first. At the edge of the arm's reach (where the planner's stops often
    # are: Fea^m only asks for the grasp) the hand cannot rise 9 cm there, so the dish is
    # also drawn in towards the arm, as a person lifts a plate at arm's length.
    inward = X_WA(base).translation() - X_WG.translation()
    inward[2] = 0.0
    inward /= max(float(np.linalg.norm(inward)), 1e-9)
    q_lift = None
    for offset in (LIFT_HEIGHT * up, LIFT_HEIGHT * up + LIFT_INWARD * inward,
                   0.6 * LIFT_HEIGHT * up + LIFT_INWARD * inward, 0.45 * LIFT_HEIGHT * up,
                   0.3 * LIFT_HEIGHT * up):
        lift_target = RigidTransform(X_WG.rotation(), X_WG.translation() + offset)
        q_lift = _moved(q_closed, base, lift_target, holding)
        if q_lift is not None and holding.CheckEdgeCollisionFree(q_closed, q_lift):
            break
        q_lift = None
    if q_pre is None or q_lift is None:
        return PickupPlan(False, "no_ik", grasp=result.grasp)
    q_tray = tray_configuration(base, result.grasp, q_closed, holding)
    if q_tray is None:
        return PickupPlan(False, "no_path", grasp=result.grasp)
    q_release = _with_gripper(q_tray, GRIPPER_OPEN)
    q_stow = _with_gripper(scene.q(base), GRIPPER_OPEN)
    if not free.CheckConfigCollisionFree(q_release):
        return PickupPlan(False, "no_path", grasp=result.grasp)

    q_open = _with_gripper(q0, GRIPPER_OPEN)
    opening = not np.allclose(q0[9:], GRIPPER_OPEN)
    # Fingers not open: they open first, where the arm stands.
    if opening and not free.CheckEdgeCollisionFree(q0, q_open):
        return PickupPlan(False, "no_path", grasp=result.grasp)
    approach = plan_arm_path(free, q_open, q_pre, time_limit=time_limit, seed=seed)
    if approach is None:
        return PickupPlan(False, "no_path", grasp=result.grasp)
    if opening:
        approach = np.vstack([q0[None, :], approach])
    segments = []
    segments.append(_segment("approach", approach, free))
    straight = (("descend", q_pre, q_grasp, holding),
                ("close", q_grasp, q_closed, holding),
                ("lift", q_closed, q_lift, holding))
    for name, a, b, edge_checker in straight:
        if not edge_checker.CheckEdgeCollisionFree(a, b):
            return PickupPlan(False, "no_path", grasp=result.grasp)
        segments.append(_segment(name, np.stack([a, b]), edge_checker))
    for name, a, b, path_checker in (("to_tray", q_lift, q_tray, holding),
                                     ("release", q_tray, q_release, free),
                                     ("stow", q_release, q_stow, free)):
        if name == "release":
            path = np.stack([a, b]) if path_checker.CheckEdgeCollisionFree(a, b) else None
        else:
            path = plan_arm_path(path_checker, a, b, time_limit=time_limit, seed=seed)
        if path is None:
            return PickupPlan(False, "no_path", grasp=result.grasp)
        segments.append(_segment(name, path, path_checker))
    return PickupPlan(True, "ok", segments, grasp=result.grasp)
