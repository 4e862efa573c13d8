"""The arm's kinematics from its arm base A to the grasp frame G, vectorised in numpy.

Drake's plant is the reference; `ArmKinematics` holds the arm's chain as its model has it
(`JointChain`: the joints' poses and axes, read from the parsed model) so that thousands of
configurations can be moved and verified per call without a plant context: forward
kinematics X_AG(q), the geometric Jacobian, a few Newton steps that carry a stored
configuration onto a nearby target (the reachability map's refinement), the joint limits
(the model's), and inverse kinematics by the arm's family (`robot_description.IK_FAMILIES`):

- "ur": the closed-form solutions of all eight branches (`ur_inverse`), with the lengths
  read from the model and checked against it when the kinematics are made;
- "numeric": damped least squares from seed configurations, one solution per seed (the
  one the seed's own branch leads to), for any serial arm, a redundant one too.

Either way, inverse kinematics returns candidate slots that callers verify (`exact`);
Drake's InverseKinematics, seeded from them, stays the reference of the feasibility checks.

Configurations are arrays (..., n) of arm joint angles in ``Robot.arm_joints`` order; poses
are (R_AG (..., 3, 3), p_AG (..., 3)). `arm_kinematics(robot)` gives a robot's arm, made
once per robot.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import numpy as np
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant

from s3o_drake.feasibility.joint_chain import JointChain
from s3o_drake.feasibility.ur_inverse import NUM_BRANCHES as UR_BRANCHES
from s3o_drake.feasibility.ur_inverse import URGeometry, ur_inverse
from s3o_drake.world.angles import wrap
from s3o_drake.world.robot import Robot
from s3o_drake.world.robot_description import RobotDescriptionError

#: A verified inverse-kinematics solution is this close to its target (rad and m).
EXACT_TOLERANCE = 1e-6
#: Damped least squares: at most this many steps, each at most this long (rad, largest
#: joint), with this damping (rad² of the 6 x 6 system; small: near a solution the steps
#: are Newton's).
NUMERIC_ITERATIONS = 60
NUMERIC_STEP = 0.4
NUMERIC_DAMPING = 1e-6
#: Seeds of the numeric family when the caller gives none: the stow configuration and this
#: many deterministic configurations within the joint limits.
NUMERIC_RANDOM_SEEDS = 15
#: Random seeds keep this far from a limited joint's ends and from ±π (rad): an arm folded
#: on itself, or at a stop, starts nowhere useful.
FOLD_LIMIT = 2.8
#: How closely (m, and entries of unit vectors and rotations) the model's arm must do what
#: its description's use of it needs: its first and last joints turn about A's and G's z
#: axes, and the UR family's closed form reproduces its forward kinematics over
#: `UR_CHECK_CONFIGURATIONS` configurations spread within the limits.
MODEL_TOLERANCE = 1e-9
UR_CHECK_CONFIGURATIONS = 200
#: How far (rad) the first joint's axis may lean from A's z (up or down) and the last
#: one's from G's z, for the reachability map's turns of a stored configuration. Makers
#: write a joint flipped by pi to a few digits (Kinova's Gen3 turns its joint 1 by 3.1416:
#: 7.3e-6 rad off -z). Turning about an axis off by e rad moves a point r metres from it by
#: at most 2 r e: 2.6e-5 m at 1.3 m (the map's reach) for 1e-5 rad, below the map's Newton
#: tolerance (1e-4 m, reachability/map.py) and far below a grasp's (2 mm), so the map's
#: turned configurations are what it says they are.
TURNING_AXIS_TOLERANCE = 1e-5


class ArmModelError(ValueError):
    """The arm's model does not have what its description's use of it needs; `path` names
    the description's field."""

    def __init__(self, path: str, message: str):
        super().__init__(message)
        self.path = path


def pose_error(R: np.ndarray, p: np.ndarray, R_target: np.ndarray,
               p_target: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotation angle (rad) and distance (m) between poses, elementwise."""
    R_err = R_target @ np.swapaxes(R, -1, -2)
    cos = np.clip((np.trace(R_err, axis1=-2, axis2=-1) - 1) / 2, -1.0, 1.0)
    return np.arccos(cos), np.linalg.norm(p_target - p, axis=-1)


#: Entries (2, 1), (0, 2), (1, 0) of a 3 x 3 matrix: its skew part's, as a vector.
_SKEW_ROWS, _SKEW_COLUMNS = (2, 0, 1), (1, 2, 0)


def _rotation_error(R: np.ndarray, R_target: np.ndarray) -> np.ndarray:
    """The small-angle rotation vector (..., 3) from R to R_target, in A."""
    R_err = R_target @ np.swapaxes(R, -1, -2)
    # The skew part's entries minus their transposes', gathered in one indexing each:
    # fewer numpy calls than a stack of three differences, the same arithmetic.
    return 0.5 * (R_err[..., _SKEW_ROWS, _SKEW_COLUMNS] - R_err[..., _SKEW_COLUMNS, _SKEW_ROWS])


@dataclass(frozen=True, eq=False)
class ArmKinematics:
    """One arm's chain from A to G, its joint limits and its inverse kinematics family
    (compared by identity: it holds arrays)."""

    chain: JointChain
    lower: np.ndarray
    upper: np.ndarray
    family: str = "numeric"
    stow: np.ndarray | None = None
    """The arm's stow configuration: the numeric family's first default seed."""
    grasp_offset: float = 0.0
    """G along the flange's z (m): the UR family's closed form takes it apart from its d6."""
    ur: URGeometry | None = field(init=False, repr=False)
    """The UR family's lengths, read from the chain (None for another family)."""
    turn_signs: tuple[float, float] = field(init=False)
    """+1 or -1: whether the first joint turns about A's +z or -z, and the last about G's
    +z or -z (the bearing and the wrist turn of a grasp then go with that sign)."""
    _seeds: np.ndarray = field(init=False, repr=False)

    @classmethod
    def of(cls, robot: Robot) -> ArmKinematics:
        """The kinematics of `robot`'s model: its chain from the arm's base frame to the
        grasp frame, its joint limits, and the grasp frame's offset from the flange. Raises
        `RobotDescriptionError` when the model's arm is not what the description's use of
        it needs."""
        plant = MultibodyPlant(0.0)
        placed = robot.add_model_instances(Parser(plant))
        plant.Finalize()
        arm = [placed.joint(name) for name in robot.arm_joints]
        chain = JointChain.of_plant(plant, base=placed.frame(robot.arm_base_link),
                                    tool=placed.frame(robot.grasp_frame), joints=arm)
        positions = [joint.position_start() for joint in arm]
        lower = plant.GetPositionLowerLimits()[positions]
        upper = plant.GetPositionUpperLimits()[positions]
        X_TG = plant.CalcRelativeTransform(plant.CreateDefaultContext(),
                                           placed.frame(robot.tool_frame),
                                           placed.frame(robot.grasp_frame))
        try:
            return cls(chain, lower, upper, robot.description.arm.inverse_kinematics,
                       np.array(robot.arm_stow), grasp_offset=float(X_TG.translation()[2]))
        except ArmModelError as e:
            raise RobotDescriptionError(e.path, f"robot {robot.name!r}: {e}") from None

    def __post_init__(self) -> None:
        for name in ("lower", "upper"):
            object.__setattr__(self, name, np.asarray(getattr(self, name), dtype=float))
        self._check_turning_axes()
        stow = [] if self.stow is None else [np.asarray(self.stow, dtype=float)]
        seeds = np.vstack([*stow, self.random_configurations(NUMERIC_RANDOM_SEEDS)])
        object.__setattr__(self, "_seeds", seeds)
        object.__setattr__(self, "ur", self._ur_geometry() if self.family == "ur" else None)

    def _check_turning_axes(self) -> None:
        """The reachability map turns one stored configuration to every bearing with the
        first joint and to every wrist turn with the last: the first must turn about A's
        vertical z axis, the last about G's approach axis z, either way (`turn_signs`),
        within `TURNING_AXIS_TOLERANCE`, through the axis (within `MODEL_TOLERANCE`).
        Raises ArmModelError."""
        C_0, C_n = self.chain.fixed[0], self.chain.fixed[-1]
        # The first joint's axis and a point of it in A; the last one's in G.
        axis_A, point_A = C_0[:3, :3] @ self.chain.axes[0], C_0[:3, 3]
        R_JG, p_JG = C_n[:3, :3], C_n[:3, 3]
        axis_G, point_G = R_JG.T @ self.chain.axes[-1], -R_JG.T @ p_JG
        signs = []
        for index, axis, point, frame, why in (
                (0, axis_A, point_A, "A", "turn the arm about the arm base's vertical axis"),
                (self.joints - 1, axis_G, point_G, "G",
                 "turn the gripper about its approach axis")):
            lean = math.atan2(math.hypot(axis[0], axis[1]), abs(axis[2]))
            if lean > TURNING_AXIS_TOLERANCE or np.abs(point[:2]).max() > MODEL_TOLERANCE:
                raise ArmModelError(f"arm.joints[{index}]", (
                    f"the joint must {why} (z of {frame}, either way, within "
                    f"{TURNING_AXIS_TOLERANCE:g} rad); in the model it turns about "
                    f"{np.round(axis, 6).tolist()} through {np.round(point, 6).tolist()} m "
                    f"in {frame}"))
            signs.append(1.0 if axis[2] > 0 else -1.0)
        object.__setattr__(self, "turn_signs", tuple(signs))

    def _ur_geometry(self) -> URGeometry:
        """The UR family's lengths read from the chain, checked: the closed form must put G
        where the chain does over configurations spread within the limits. Raises
        ArmModelError."""
        if self.joints != 6:
            raise ArmModelError("arm.inverse_kinematics",
                                f"the UR family's closed form is for 6 joints, not {self.joints}")
        q = self.random_configurations(UR_CHECK_CONFIGURATIONS, seed=1)
        R, p = self.forward(q)
        geometry = URGeometry.fit(R, p, q, self.grasp_offset)
        candidates = ur_inverse(geometry, R, p)
        R_c, p_c = self.forward(np.nan_to_num(candidates))
        # Entries of the rotations, not an angle: arccos cannot resolve 1e-9 rad.
        error = np.maximum(np.abs(R_c - R[:, None]).max(axis=(-2, -1)),
                           np.abs(p_c - p[:, None]).max(axis=-1))
        error = np.where(np.isnan(candidates).any(axis=-1), np.inf, error).min(axis=1)
        worst = int(np.argmax(error))
        if not error[worst] <= MODEL_TOLERANCE:
            raise ArmModelError("arm.inverse_kinematics", (
                f"the UR family's closed form misses the model's grasp frame by up to "
                f"{error[worst]:.3g} (m, or rotation entries) at q = "
                f"{np.round(q[worst], 3).tolist()}: the arm is not UR-shaped, or its zero "
                "angles or frames are not those of the UR's DH table"))
        return geometry

    # ------------------------------------------------------------------------ the chain
    @property
    def joints(self) -> int:
        return self.chain.joints

    def forward(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """X_AG of configurations q (..., n): rotations (..., 3, 3), positions (..., 3)."""
        return self.chain.forward(q)

    def jacobian(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """R_AG, p_AG and the geometric Jacobian (..., 6, n) of G in A: rows ω (3) then
        v (3)."""
        return self.chain.jacobian(q)

    @property
    def elbow_joint(self) -> int:
        """The joint halfway along the chain, whose frame (`JointChain.frames`) stands
        where the arm bends: the UR family's elbow, a 7-joint arm's fourth joint."""
        return (self.joints - 1) // 2

    # ----------------------------------------------------------------------- the limits
    @property
    def wrapping(self) -> np.ndarray:
        """Joints that turn two full turns (±2π): any angle may be shifted a whole turn."""
        return self.upper - self.lower >= 4 * math.pi - 1e-9

    def within_limits(self, q: np.ndarray) -> np.ndarray:
        """Whether configurations (..., n) are within every joint's limits: (...)."""
        q = np.asarray(q, dtype=float)
        return np.all((q >= self.lower - 1e-9) & (q <= self.upper + 1e-9), axis=-1)

    def into_limits(self, q: np.ndarray) -> np.ndarray:
        """Angles (..., n) wrapped into [-π, π), or shifted by a whole turn where that leaves
        a joint's limits and the shift brings it back: the same geometry. NaN angles stay
        NaN; callers test `within_limits` (an angle no turn brings in stays out)."""
        q = wrap(q)
        above, below = q > self.upper + 1e-9, q < self.lower - 1e-9
        if above.any() or below.any():
            q = np.where(above & (q - 2 * math.pi >= self.lower), q - 2 * math.pi, q)
            q = np.where(below & (q + 2 * math.pi <= self.upper), q + 2 * math.pi, q)
        return q

    def nearest_turn(self, q: np.ndarray, reference: np.ndarray) -> np.ndarray:
        """Arm angles q (..., n) with their two-turn joints shifted by whole turns towards
        `reference` (broadcast), inside their limits: the same geometry (so just as
        collision-free), less to turn."""
        q = np.asarray(q, dtype=float)
        wrapping = self.wrapping
        turns = np.where(wrapping, np.round((reference - q) / (2 * math.pi)), 0.0)
        shifted = q + 2 * math.pi * turns
        return np.where(wrapping & (shifted > self.upper), shifted - 2 * math.pi,
                        np.where(wrapping & (shifted < self.lower), shifted + 2 * math.pi,
                                 shifted))

    def random_configurations(self, count: int, seed: int = 0) -> np.ndarray:
        """`count` deterministic configurations spread over the joints' working ranges:
        uniform in [-π, π); a joint limited to one turn or less then drawn again within
        its limits and `FOLD_LIMIT`, away from folding on itself or a stop."""
        rng = np.random.default_rng(seed)
        q = rng.uniform(-np.pi, np.pi, size=(count, self.joints))
        for j in np.flatnonzero(self.upper - self.lower <= 2 * math.pi + 1e-9):
            q[:, j] = rng.uniform(max(self.lower[j], -FOLD_LIMIT), min(self.upper[j], FOLD_LIMIT),
                                  size=count)
        return q

    # ------------------------------------------------------------- inverse kinematics
    @property
    def seeds(self) -> np.ndarray:
        """The numeric family's default seeds (the stow configuration first)."""
        return self._seeds

    @property
    def branches(self) -> int:
        """Slots of `inverse` without seeds: one per closed-form branch or default seed."""
        return UR_BRANCHES if self.family == "ur" else len(self._seeds)

    def inverse(self, R_AG: np.ndarray, p_AG: np.ndarray,
                seeds: np.ndarray | None = None) -> np.ndarray:
        """Inverse kinematics for targets (m, 3, 3), (m, 3): candidates (m, B, n), NaN where
        a slot has none.

        The UR family: every closed-form branch (B = 8; `seeds` are not needed). The
        numeric family: damped least squares from each seed ((S, n) or (m, S, n); default:
        `seeds`), B = S, each a solution within the joint limits or NaN. Callers verify
        candidates with `exact`.
        """
        if self.family == "ur":
            return ur_inverse(self.ur, R_AG, p_AG)
        return self.numeric_inverse(R_AG, p_AG, self._seeds if seeds is None else seeds)

    def exact(self, candidates: np.ndarray, R_AG: np.ndarray, p_AG: np.ndarray,
              tolerance: float = EXACT_TOLERANCE) -> np.ndarray:
        """Which candidates (m, B, n) put G at the targets (m, 3, 3), (m, 3) within
        `tolerance` (rad and m): (m, B)."""
        R, p = self.forward(np.nan_to_num(candidates))
        angle, distance = pose_error(R, p, np.asarray(R_AG)[:, None], np.asarray(p_AG)[:, None])
        return ~np.isnan(candidates).any(axis=-1) & (angle < tolerance) & (distance < tolerance)

    def numeric_inverse(self, R_AG: np.ndarray, p_AG: np.ndarray, seeds: np.ndarray, *,
                        iterations: int = NUMERIC_ITERATIONS) -> np.ndarray:
        """Damped least squares from every seed to every target: (m, S, n), NaN where a
        seed's steps do not reach its target within EXACT_TOLERANCE inside the limits.

        Each step is the least-norm change of the angles that removes the pose error (with
        a little damping) and keeps to the limits, so a solution stays on its seed's side
        of every choice the arm has (elbow, wrist, and for a redundant arm its self-motion).
        """
        R_AG = np.asarray(R_AG, dtype=float).reshape(-1, 3, 3)
        p_AG = np.asarray(p_AG, dtype=float).reshape(-1, 3)
        m, n = len(p_AG), self.joints
        seeds = np.asarray(seeds, dtype=float)
        seeds = np.broadcast_to(seeds if seeds.ndim == 3 else seeds[None], (m, seeds.shape[-2], n))
        s = seeds.shape[1]
        q = np.clip(seeds.reshape(-1, n), self.lower, self.upper)
        # The rows still stepping, and their angles and targets, kept packed (rows leave
        # when they converge): the calls are many and small, so each step is as few numpy
        # calls as it can be; the arithmetic per row is the same in any batch.
        rows = np.arange(len(q))
        q_rows = q.copy()
        R_t, p_t = np.repeat(R_AG, s, axis=0), np.repeat(p_AG, s, axis=0)
        eye = NUMERIC_DAMPING * np.eye(6)
        e = np.empty((len(q), 6))
        for _ in range(iterations):
            R, p, J = self.jacobian(q_rows)
            e[:, :3] = _rotation_error(R, R_t)
            np.subtract(p_t, p, out=e[:, 3:])
            small = np.abs(e).max(axis=-1) < 0.1 * EXACT_TOLERANCE
            if small.any():
                q[rows[small]] = q_rows[small]
                stepping = ~small
                rows, q_rows, J, e = rows[stepping], q_rows[stepping], J[stepping], e[stepping]
                R_t, p_t = R_t[stepping], p_t[stepping]
                if rows.size == 0:
                    break
            Jt = np.swapaxes(J, -1, -2)
            dq = (Jt @ np.linalg.solve(J @ Jt + eye, e[..., None]))[..., 0]
            longest = np.abs(dq).max(axis=-1, keepdims=True)
            dq *= np.minimum(1.0, NUMERIC_STEP / np.maximum(longest, 1e-12))
            q_rows = np.clip(q_rows + dq, self.lower, self.upper)
        q[rows] = q_rows
        q = q.reshape(m, s, n)
        ok = self.exact(q, R_AG, p_AG)
        return np.where(ok[..., None], q, np.nan)

    def refine(self, q: np.ndarray, R_target: np.ndarray, p_target: np.ndarray, *,
               iterations: int = 3, rotation_weight: float = 1.0,
               damping: float = 1e-6) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Damped Newton steps carrying configurations q (m, n) onto targets (m, 3, 3),
        (m, 3).

        A stored map configuration solves a grid node within millimetres of the query;
        three steps make it solve the query exactly when the query is reachable on that
        branch, so the map's answer does not depend on the grid's resolution. A small
        `rotation_weight` (m/rad) lets the orientation give way to the position, which is
        how a target just beyond the exact-orientation reach is reached within the angle
        tolerance (as IK does). Returns the configurations, their rotation errors (rad) and
        position errors (m) after the steps.
        """
        q = np.array(q, dtype=float)
        eye = damping * np.eye(self.joints)
        for _ in range(iterations):
            R, p, J = self.jacobian(q)
            w = _rotation_error(R, R_target)
            e = np.concatenate([rotation_weight * w, p_target - p], axis=-1)
            J = np.concatenate([rotation_weight * J[..., :3, :], J[..., 3:, :]], axis=-2)
            Jt = np.swapaxes(J, -1, -2)
            dq = np.linalg.solve(Jt @ J + eye, (Jt @ e[..., None]))[..., 0]
            q += np.clip(dq, -0.5, 0.5)
        R, p = self.forward(q)
        angle, distance = pose_error(R, p, R_target, p_target)
        return q, angle, distance


@functools.cache
def arm_kinematics(robot: Robot) -> ArmKinematics:
    """The kinematics of `robot`'s arm, made once per robot (parsing its model and its
    seeds cost a little, and a robot's arm never changes)."""
    return ArmKinematics.of(robot)
