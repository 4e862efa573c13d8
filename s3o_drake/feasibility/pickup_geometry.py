"""The configurations of an executed pickup: the one test shared by the ArmController and Fea^m.

A pickup, as the ArmController runs it (`s3o_drake.execution.arm.pickup.plan_pickup`), passes
through these configurations of the robot's positions, from where the base stands:

- grasp: a collision-free arm configuration at one of the dish's grasps
  (`FeasibilityChecker.free_grasps`, in its order: the 1 cm clearance, joint limits);
- pre-grasp: the grasp pose backed off `APPROACH_BACKOFF` against the approach axis (top
  grasp: above the dish; side grasp: behind it), on the grasp's IK branch; when that pose
  or the straight line from it to the grasp collides (a side grasp of a cup beyond a plate
  would sweep the hand through the plate), back and up, from above, then shorter are tried;
- closed: the fingers closed at the grasp (the straight finger motion must be free);
- lift: the grasp pose raised `LIFT_HEIGHT`, or at the edge of reach also drawn in towards
  the arm by `LIFT_INWARD`, or raised less; the straight line to it must be free;
- tray: the grasp frame `TRAY_CLEARANCE` above the tray's centre (`tray_configuration`),
  and release: the same with the fingers open, free by the scene's own checker;
- stow: the arm stowed.

`pickup_geometry` finds them, trying the grasp configurations in order until one has a
pre-grasp and a lift, and says why not when none has: "base_collision" (the base stands in
collision), "no_ik" (no collision-free grasp, or no pre-grasp or lift on any grasp's branch)
or "no_path" (no free tray or release configuration). What it leaves to the execution are
the three joint-space paths between these configurations (approach, to the tray, stow), which
OMPL's RRT-Connect searches; how rarely they decide an outcome is measured by
`s3o bench oracle-pinning` (docs/feasibility.md).

Which checker judges each configuration: the scene's own (1 cm padding, nothing may be
touched) for the pre-grasp, release and stow; the grasping checker (`ik.grasp_checker`: the
gripper's bodies may touch this dish, and only they) for the grasp, the descent, closing,
the lift and the tray, where the gripper is at, or holds, the dish.

Whether the fingers catch the dish is geometry too: the reach noise must leave the real dish
within the gripper's tolerance of where it aims (`grasp_tolerance`); otherwise the motion
runs and the pickup fails "missed". Putting an object down at its place is judged the same
way (the pickup of an object of its kind standing there, `manipulation.place`); there the
reach noise decides instead whether it stands within PLACE_TOLERANCE of its place
(`place_probability`).
"""

import math
from collections.abc import Generator
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from pydrake.math import RigidTransform, RotationMatrix
from scipy.special import erf

from s3o_drake.feasibility import ik
from s3o_drake.feasibility import kinematics as kin
from s3o_drake.feasibility.check import FeasibilityChecker
from s3o_drake.feasibility.grasps import R_BEARING_SIDE, R_BEARING_TOP
from s3o_drake.feasibility.robot_checker import RobotChecker
from s3o_drake.feasibility.scene import FeasibilityScene
from s3o_drake.world.goals import placed_object
from s3o_drake.world.gripper import grasp_tolerance, holds_whole
from s3o_drake.world.placing import PLACE_TOLERANCE
from s3o_drake.world.robot import Robot

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
#: IK tolerance of the derived poses (pre-grasp, lift, tray): rad and m.
POSE_TOLERANCE = 1e-4
_UP = np.array([0.0, 0.0, 1.0])


def catch_probability(kind: str, reach_std: float, *, robot: Robot) -> float:
    """P(caught) by `robot` under isotropic Gaussian reach noise of `reach_std` per axis:
    the norm of the noise is Rayleigh distributed."""
    if reach_std <= 0:
        return 1.0
    return 1.0 - math.exp(-0.5 * (grasp_tolerance(kind, robot=robot) / reach_std) ** 2)


def place_error_stds(kind: str, reach_std: float, *, robot: Robot) -> tuple[float, float]:
    """The standard deviations (m) of where an object of `kind` is put down, off its place,
    along two perpendicular horizontal axes.

    Two reach errors add up. The put-down aims off by the place's own reach noise
    (`reach_std` per axis). The object also sits off-centre in the hand by the reach error
    of its pickup, except across the fingers where they centre an object held whole
    (`gripper.holds_whole`; the object tracker does the same): one axis keeps both errors,
    the other only the place's, or both for a pinched rim.
    """
    both = math.sqrt(2.0) * reach_std
    return both, both if not holds_whole(kind, robot=robot) else reach_std


def place_probability(kind: str, reach_std: float, *, robot: Robot) -> float:
    """P(an object of `kind`, put down by `robot` with reach noise `reach_std`, stands within
    PLACE_TOLERANCE of its place): the probability that the zero-mean Gaussian of
    `place_error_stds` falls in that disc, integrated over one axis."""
    if reach_std <= 0:
        return 1.0
    a, b = place_error_stds(kind, reach_std, robot=robot)
    x = np.linspace(-PLACE_TOLERANCE, PLACE_TOLERANCE, 2001)
    half_chord = np.sqrt(np.maximum(PLACE_TOLERANCE**2 - x**2, 0.0))
    density = np.exp(-0.5 * (x / a) ** 2) / (a * math.sqrt(2.0 * math.pi))
    return float(np.trapezoid(density * erf(half_chord / (b * math.sqrt(2.0))), x))


def goal_probability(target: str, kind: str, reach_std: float, *, robot: Robot) -> float:
    """The factor of the reach noise in Fea^m of `target` (of `kind`) for `robot`: a pick's
    catch (`catch_probability`), or for a place target (`goals.placed_object`) the object
    standing within tolerance of its place (`place_probability`; the held object is not
    caught again)."""
    if placed_object(target) is not None:
        return place_probability(kind, reach_std, robot=robot)
    return catch_probability(kind, reach_std, robot=robot)


@dataclass(frozen=True)
class PickupConfigurations:
    """The robot's positions at each stop of a pickup (see the module docstring)."""

    grasp: str
    q_grasp: np.ndarray
    q_pre: np.ndarray
    q_closed: np.ndarray
    q_lift: np.ndarray
    q_tray: np.ndarray
    q_release: np.ndarray
    q_stow: np.ndarray


@dataclass(frozen=True)
class PickupGeometry:
    """The answer of `pickup_geometry`: ok with the configurations, or not ok with why
    ("base_collision", "no_ik" or "no_path"); `grasp` names the grasp that got furthest."""

    ok: bool
    reason: str
    configurations: PickupConfigurations | None = None
    grasp: str | None = None


def X_WA(base: np.ndarray, *, robot: Robot) -> RigidTransform:
    """Pose of `robot`'s arm base frame A (axes parallel to base_link's) for a base
    (x, y, yaw)."""
    x, y, yaw = base
    R = RotationMatrix.MakeZRotation(yaw)
    return RigidTransform(R, np.array([x, y, 0.0]) + R @ np.array(robot.arm_mount_xyz))


def nearest_turn(q: np.ndarray, reference: np.ndarray, *, robot: Robot) -> np.ndarray:
    """Angles q (..., n) of `robot`'s arm with their two-turn joints shifted by whole turns
    towards `reference` (broadcast), inside their limits: the same geometry (so just as
    collision-free), less to turn."""
    return kin.arm_kinematics(robot).nearest_turn(q, reference)


def solve_arm(R_AG: np.ndarray, p_AG: np.ndarray, reference: np.ndarray,
              seeds: np.ndarray | None = None, *, robot: Robot) -> list[np.ndarray]:
    """Configurations of `robot`'s arm putting G at (R_AG, p_AG), each turned as near
    `reference` as allowed, the nearest first: the closed-form solutions of every branch
    (UR family), or those damped least squares reaches from `reference` and from `seeds`
    (k, n) (another arm; a target near the reference needs no other seed)."""
    return solve_arm_many(np.asarray(R_AG)[None], np.asarray(p_AG)[None], reference,
                          seeds, robot=robot)[0]


def solve_arm_many(R_AG: np.ndarray, p_AG: np.ndarray, reference: np.ndarray,
                   seeds: np.ndarray | None = None, *, robot: Robot) -> list[list[np.ndarray]]:
    """`solve_arm` for targets (m, 3, 3), (m, 3) and references (n,) or (m, n) at once
    (vectorised: the oracle asks for thousands of targets)."""
    arm = kin.arm_kinematics(robot)
    m, n = len(p_AG), arm.joints
    references = np.broadcast_to(np.asarray(reference, dtype=float), (m, n))
    starts = references[:, None]
    if seeds is not None:
        extra = np.broadcast_to(np.asarray(seeds, dtype=float).reshape(1, -1, n),
                                (m, len(seeds), n))
        starts = np.concatenate([starts, extra], axis=1)
    branches = arm.inverse(R_AG, p_AG, starts)  # (m, B, n)
    exact = arm.exact(branches, R_AG, p_AG, POSE_TOLERANCE)
    turned = arm.nearest_turn(np.nan_to_num(branches), references[:, None])
    exact &= arm.within_limits(turned)
    gap = np.where(exact, np.linalg.norm(turned - references[:, None], axis=-1), np.inf)
    order = np.argsort(gap, axis=1, kind="stable")
    return [[turned[k, b] for b in order[k] if exact[k, b]] for k in range(m)]


def moved(q: np.ndarray, base: np.ndarray, X_WG_target: RigidTransform,
          checker: RobotChecker, *, robot: Robot) -> np.ndarray | None:
    """q (`robot`'s positions) with the arm moved so that G is at X_WG_target,
    collision-free, or None."""
    X_AG_target = X_WA(base, robot=robot).inverse() @ X_WG_target
    R = X_AG_target.rotation().matrix()
    arms = solve_arm(R, X_AG_target.translation(), q[robot.arm_positions], robot=robot)
    return _first_free(q, arms, checker, robot=robot)


def _first_free(q: np.ndarray, arms: list[np.ndarray], checker: RobotChecker,
                *, robot: Robot) -> np.ndarray | None:
    """q (`robot`'s positions) with the first of `arms` that is collision-free, or None."""
    for arm in arms:
        candidate = q.copy()
        candidate[robot.arm_positions] = arm
        if checker.CheckConfigCollisionFree(candidate):
            return candidate
    return None


def _first_offset(q: np.ndarray, solutions: list[list[np.ndarray]],
                  checker: RobotChecker,
                  edge_checker: RobotChecker, *, robot: Robot) -> np.ndarray | None:
    """q moved to the first target (of `solutions`, one list of arms per target, in order)
    where the arm is free by `checker` and the straight line from q is free by
    `edge_checker`, or None."""
    for arms in solutions:
        moved_q = _first_free(q, arms, checker, robot=robot)
        if moved_q is not None and edge_checker.CheckEdgeCollisionFree(moved_q, q):
            return moved_q
    return None


def _pre_grasp_offsets(R_AG: np.ndarray) -> np.ndarray:
    """The pre-grasps' offsets from grasps (n, 3, 3), in the order tried: (n, 6, 3).

    Straight back along the approach axis first; when that sweeps the hand through a
    neighbouring dish (a cup beyond a plate), back and up, then from above, then shorter.
    """
    back = -APPROACH_BACKOFF * R_AG[:, :, 2]
    up = np.broadcast_to(APPROACH_BACKOFF * _UP, back.shape)
    return np.stack([back, back + 0.5 * up, up, 0.5 * back, 0.5 * up, 0.3 * up], axis=1)


def _lift_offsets(p_AG: np.ndarray) -> np.ndarray:
    """The lifts' offsets from grasps at p_AG (n, 3), in the order tried: (n, 5, 3).

    Straight up first. At the edge of the arm's reach the hand cannot rise 9 cm there, so
    the dish is also drawn in towards the arm, as a person lifts a plate at arm's length.
    """
    inward = -p_AG * [1.0, 1.0, 0.0]  # towards A's origin, horizontally
    inward /= np.maximum(np.linalg.norm(inward, axis=1, keepdims=True), 1e-9)
    up = np.broadcast_to(LIFT_HEIGHT * _UP, inward.shape)
    drawn = LIFT_INWARD * inward
    return np.stack([up, up + drawn, 0.6 * up + drawn, 0.45 * up, 0.3 * up], axis=1)


def _arm_solutions(q_grasps: np.ndarray, *, robot: Robot) -> list[tuple[list, list]]:
    """For grasp configurations (n, `robot`'s positions): the IK solutions of every
    pre-grasp and every lift target, in the order tried, near the grasp's arm (one
    vectorised solve: a numeric arm's costs little more for more targets)."""
    arms = q_grasps[:, robot.arm_positions]
    R, p = kin.arm_kinematics(robot).forward(arms)
    pre_grasps, lifts = _pre_grasp_offsets(R), _lift_offsets(p)
    offsets = np.concatenate([pre_grasps, lifts], axis=1)
    pre, k = pre_grasps.shape[1], offsets.shape[1]
    solutions = solve_arm_many(np.repeat(R, k, axis=0), (p[:, None] + offsets).reshape(-1, 3),
                               np.repeat(arms, k, axis=0), robot=robot)
    return [(solutions[i * k:i * k + pre], solutions[i * k + pre:(i + 1) * k])
            for i in range(len(arms))]


@lru_cache(maxsize=8)
def tray_arms(grasp: str, *, robot: Robot) -> tuple[np.ndarray, ...]:
    """`robot`'s arm configurations at release over the tray, in the order they are tried.

    G is `TRAY_CLEARANCE` above the tray's centre; a top grasp keeps the gripper pointing
    down, a side grasp keeps it level (a cup stays upright). Headings of the approach axis
    go from pointing backwards round to sideways; per heading, the solutions nearest the
    stow configuration first (an arm without a closed form starts from there and from its
    default seeds). In the arm's frame they do not depend on where the base stands, so they
    are solved once per robot.
    """
    p_BT = np.array(robot.tray_xyz) + np.array([0.0, 0.0, TRAY_CLEARANCE])
    p_AG = p_BT - np.array(robot.arm_mount_xyz)
    R_bearing = R_BEARING_TOP if grasp == "top" else R_BEARING_SIDE
    arms = []
    for heading in (math.pi, 0.5 * math.pi, -0.5 * math.pi, 0.75 * math.pi, -0.75 * math.pi,
                    0.0):
        R_AG = (RotationMatrix.MakeZRotation(heading) @ R_bearing).matrix()
        arms += solve_arm(R_AG, p_AG, np.asarray(robot.arm_stow),
                          kin.arm_kinematics(robot).seeds, robot=robot)
    return tuple(arms)


def tray_configuration(base: np.ndarray, grasp: str, q_from: np.ndarray,
                       checker: RobotChecker, *, robot: Robot) -> np.ndarray | None:
    """`robot`'s positions at release over the tray (fingers as in `q_from`), or None:
    the first of `tray_arms` that is collision-free."""
    for arm in tray_arms(grasp, robot=robot):
        q = q_from.copy()
        q[:3] = base
        q[robot.arm_positions] = arm
        if checker.CheckConfigCollisionFree(q):
            return q
    return None


def with_gripper(q: np.ndarray, gripper: np.ndarray, *, robot: Robot) -> np.ndarray:
    """q (`robot`'s positions) with the fingers at `gripper`."""
    out = q.copy()
    out[robot.gripper_positions] = gripper
    return out


def _complete(base: np.ndarray, grasp: str, q_grasp: np.ndarray, solutions: tuple[list, list],
              free: RobotChecker, holding: RobotChecker, *,
              robot: Robot) -> tuple[PickupConfigurations | None, bool]:
    """The rest of `robot`'s pickup from one grasp configuration (see the module
    docstring): the configurations, or None; and whether a lift was found (for the
    reason)."""
    pre_solutions, lift_solutions = solutions
    q_pre = _first_offset(q_grasp, pre_solutions, free, holding, robot=robot)
    if q_pre is None:
        return None, False
    q_closed = with_gripper(q_grasp, robot.gripper_closed, robot=robot)
    if not holding.CheckEdgeCollisionFree(q_grasp, q_closed):
        return None, False
    q_lift = _first_offset(q_closed, lift_solutions, holding, holding, robot=robot)
    if q_lift is None:
        return None, False
    q_tray = tray_configuration(base, grasp, q_closed, holding, robot=robot)
    if q_tray is None:
        return None, True
    q_release = with_gripper(q_tray, robot.gripper_open, robot=robot)
    if not free.CheckConfigCollisionFree(q_release) or \
            not free.CheckEdgeCollisionFree(q_tray, q_release):
        return None, True
    q_stow = with_gripper(robot.positions(*base), robot.gripper_open, robot=robot)
    return PickupConfigurations(grasp, q_grasp, q_pre, q_closed, q_lift, q_tray, q_release,
                                q_stow), True


def _grasp_start(q: np.ndarray, q_arm: np.ndarray, *, robot: Robot) -> np.ndarray:
    """A grasp configuration (n, `robot`'s positions) with the fingers open and its two-turn
    joints as near the arm's `q_arm` as they go."""
    q_grasp = np.array(q, dtype=float)
    q_grasp[..., robot.gripper_positions] = robot.gripper_open
    q_grasp[..., robot.arm_positions] = nearest_turn(q_grasp[..., robot.arm_positions], q_arm,
                                                     robot=robot)
    return q_grasp


def pickup_geometry(scene: FeasibilityScene, checker: FeasibilityChecker, base: np.ndarray,
                    dish: str, *, reach_offset: np.ndarray | None = None,
                    q_arm: np.ndarray | None = None, grasp: str | None = None) -> PickupGeometry:
    """The configurations of picking `dish` from base pose `base` (x, y, yaw), or why not.

    `reach_offset` moves the grasp target in the world (the dish's true place and the reach
    noise, as in `FeasibilityChecker.check`); `q_arm` is where the arm is now (default
    stowed; the grasp's ±2π joints are turned as near it as they go); `grasp` ("top" or
    "side"), when given, is the only kind of grasp tried (putting an object down holds it
    as it was picked).
    See the module docstring.
    """
    (answer,) = _in_lockstep([_pickup_steps(scene, checker, base, dish, reach_offset=reach_offset,
                                            q_arm=q_arm, grasp=grasp)], robot=scene.robot)
    return answer


#: `_pickup_steps` yields a grasp configuration, is sent its `_arm_solutions`, and returns
#: the pickup's answer.
_PickupSteps = Generator[np.ndarray, tuple[list, list], PickupGeometry]


def _pickup_steps(scene: FeasibilityScene, checker: FeasibilityChecker, base: np.ndarray,
                  dish: str, *, reach_offset: np.ndarray | None, q_arm: np.ndarray | None,
                  grasp: str | None) -> _PickupSteps:
    """`pickup_geometry` as steps: it yields each grasp configuration whose pre-grasps and
    lifts it needs solved, is sent their solutions, and returns its answer. Pickups from
    many base poses then go through their grasps together (`_in_lockstep`), one IK solve
    per round for all of them: a numeric arm's IK costs per call far more than per target.
    """
    robot = scene.robot
    q_arm = robot.arm_stow if q_arm is None else q_arm
    base = np.asarray(base, dtype=float).reshape(3)
    free = scene.checker
    holding = ik.grasp_checker(scene, dish)
    tried: str | None = None
    got_lift = False
    for result in checker.free_grasps(base, dish, reach_offset):
        if result.reason == "base_collision":
            return PickupGeometry(False, "base_collision")
        if grasp is not None and result.grasp != grasp:
            continue
        tried = tried or result.grasp
        q_grasp = _grasp_start(result.q, np.asarray(q_arm), robot=robot)
        solutions = yield q_grasp
        configurations, lifted = _complete(base, result.grasp, q_grasp, solutions, free,
                                           holding, robot=robot)
        got_lift |= lifted
        if configurations is not None:
            return PickupGeometry(True, "ok", configurations, grasp=result.grasp)
    return PickupGeometry(False, "no_path" if got_lift else "no_ik", grasp=tried)


def _in_lockstep(pickups: list[_PickupSteps], *, robot: Robot) -> list[PickupGeometry]:
    """The answers of pickups' steps, run in rounds: each round solves the grasps that the
    pickups still open ask for in one `_arm_solutions`. Each pickup tries its grasps in its
    own order and stops at its answer, as alone."""
    answers: list[PickupGeometry | None] = [None] * len(pickups)
    asking: dict[int, np.ndarray] = {}

    def advance(i: int, solutions: tuple[list, list] | None) -> None:
        try:
            asking[i] = next(pickups[i]) if solutions is None else pickups[i].send(solutions)
        except StopIteration as stop:
            answers[i] = stop.value

    for i in range(len(pickups)):
        advance(i, None)
    while asking:
        round_ = sorted(asking)
        q_grasps = np.array([asking.pop(i) for i in round_])
        for i, solutions in zip(round_, _arm_solutions(q_grasps, robot=robot), strict=True):
            advance(i, solutions)
    return answers


def pickup_feasible_many(scene: FeasibilityScene, checker: FeasibilityChecker,
                         bases: np.ndarray, dish: str,
                         reach_offsets: np.ndarray | None = None) -> np.ndarray:
    """`pickup_geometry(...).ok` for base poses (n, 3) and reach offsets (n, 2 or 3), with
    the arm stowed: bool (n,).

    The same answers, faster: the first grasp of every pose comes from the checker's batch,
    the IK of all their pre-grasps and lifts from one vectorised solve; the poses whose first
    grasp does not complete go through `pickup_geometry`'s steps together (`_in_lockstep`:
    each goes on to its other grasps).
    """
    bases = np.asarray(bases, dtype=float).reshape(-1, 3)
    feasible, q, grasps = checker.first_grasps(bases, dish, reach_offsets)
    ok = np.zeros(len(bases), dtype=bool)
    rows = np.flatnonzero(feasible)
    if rows.size == 0:
        return ok
    robot = scene.robot
    free, holding = scene.checker, ik.grasp_checker(scene, dish)
    q_grasps = _grasp_start(q[rows], np.asarray(robot.arm_stow), robot=robot)
    again = []
    for row, q_grasp, solutions in zip(rows, q_grasps, _arm_solutions(q_grasps, robot=robot),
                                       strict=True):
        configurations, _ = _complete(bases[row], grasps[row], q_grasp, solutions, free,
                                      holding, robot=robot)
        if configurations is not None:
            ok[row] = True
        else:
            again.append(row)
    offsets = [None if reach_offsets is None else np.asarray(reach_offsets)[row]
               for row in again]
    answers = _in_lockstep([_pickup_steps(scene, checker, bases[row], dish, reach_offset=offset,
                                          q_arm=None, grasp=None)
                            for row, offset in zip(again, offsets, strict=True)], robot=robot)
    ok[again] = [answer.ok for answer in answers]
    return ok
