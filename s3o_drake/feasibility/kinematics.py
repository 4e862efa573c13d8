"""The UR5e's kinematics from its arm base A to the grasp frame G, vectorised in numpy.

Drake's plant is the reference; these few lines repeat its arm chain (standard DH parameters,
as the URDF is built from them) so that thousands of configurations can be moved and verified
per call without a plant context: forward kinematics X_AG(q), the geometric Jacobian, a few
Newton steps that carry a stored configuration onto a nearby target (the reachability map's
refinement), and the closed-form inverse kinematics (all eight branches), which seeds the
map's Drake IK so that no branch is missed. Tests check all of it against the plant.

Configurations are arrays (..., 6) of arm joint angles in ``robot.ARM_JOINTS`` order; poses
are (R_AG (..., 3, 3), p_AG (..., 3)).
"""

import math

import numpy as np

from s3o_drake.feasibility.dh_chain import DHChain
from s3o_drake.world.angles import wrap
from s3o_drake.world.robot import GRASP_OFFSET, ROBOT

# The UR5e's standard DH parameters (m, rad), from its description, as the model is built.
DH_A = np.array(ROBOT.arm.dh_a)
DH_D = np.array(ROBOT.arm.dh_d)
DH_ALPHA = np.array(ROBOT.arm.dh_alpha)
#: The elbow's limit (rad); the other five arm joints turn ±2π, so any angle is in range.
ELBOW_LIMIT = math.pi
#: The grasp frame's offset from tool0 (DH frame 6) along its z axis (m).
TCP_OFFSET = GRASP_OFFSET
NUM_BRANCHES = 8


def _dh(q: np.ndarray, i: int) -> np.ndarray:
    """The DH transform of joint i for angles q (...,): (..., 4, 4)."""
    return _dh_all(np.asarray(q, dtype=float)[..., None], slice(i, i + 1))[..., 0, :, :]


CHAIN = DHChain(DH_A, DH_D, DH_ALPHA, modified=ROBOT.arm.dh_convention == "modified",
                tool_offset=TCP_OFFSET)
"""The arm chain from A to G."""
_dh_all = CHAIN.transforms
_frames = CHAIN.frames
forward = CHAIN.forward
"""X_AG of configurations q (..., 6): rotations (..., 3, 3), positions (..., 3)."""
jacobian = CHAIN.jacobian
"""R_AG, p_AG and the geometric Jacobian (..., 6, 6) of G in A: rows ω (3) then v (3)."""


def pose_error(R: np.ndarray, p: np.ndarray, R_target: np.ndarray,
               p_target: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotation angle (rad) and distance (m) between poses, elementwise."""
    R_err = R_target @ np.swapaxes(R, -1, -2)
    cos = np.clip((np.trace(R_err, axis1=-2, axis2=-1) - 1) / 2, -1.0, 1.0)
    return np.arccos(cos), np.linalg.norm(p_target - p, axis=-1)


def refine(q: np.ndarray, R_target: np.ndarray, p_target: np.ndarray, *,
           iterations: int = 3, rotation_weight: float = 1.0,
           damping: float = 1e-6) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Damped Newton steps carrying configurations q (m, 6) onto targets (m, 3, 3), (m, 3).

    A stored map configuration solves a grid node within millimetres of the query; three
    steps make it solve the query exactly when the query is reachable on that branch, so the
    map's answer does not depend on the grid's resolution. A small `rotation_weight` (m/rad)
    lets the orientation give way to the position, which is how a target just beyond the
    exact-orientation reach is reached within the angle tolerance (as IK does). Returns the
    configurations, their rotation errors (rad) and position errors (m) after the steps.
    """
    q = np.array(q, dtype=float)
    eye = damping * np.eye(len(DH_A))
    for _ in range(iterations):
        R, p, J = jacobian(q)
        R_err = R_target @ np.swapaxes(R, -1, -2)
        w = 0.5 * np.stack([R_err[..., 2, 1] - R_err[..., 1, 2],
                            R_err[..., 0, 2] - R_err[..., 2, 0],
                            R_err[..., 1, 0] - R_err[..., 0, 1]], axis=-1)
        e = np.concatenate([rotation_weight * w, p_target - p], axis=-1)
        J = np.concatenate([rotation_weight * J[..., :3, :], J[..., 3:, :]], axis=-2)
        Jt = np.swapaxes(J, -1, -2)
        dq = np.linalg.solve(Jt @ J + eye, (Jt @ e[..., None]))[..., 0]
        q += np.clip(dq, -0.5, 0.5)
    R, p = forward(q)
    angle, distance = pose_error(R, p, R_target, p_target)
    return q, angle, distance


def inverse(R_AG: np.ndarray, p_AG: np.ndarray) -> np.ndarray:
    """All closed-form IK solutions for targets (m, 3, 3), (m, 3): (m, 8, 6), NaN if none.

    Branch b = 4 s + 2 w + e picks the shoulder (s), wrist (w) and elbow (e) sign. Angles are
    wrapped into [-π, π); a singular wrist (q5 = 0) takes q6 = 0. Solutions are not checked
    for collisions; callers verify them with `forward` (numerical edge cases are NaN'd by
    that check, not here).
    """
    R_AG = np.asarray(R_AG, dtype=float).reshape(-1, 3, 3)
    p_AG = np.asarray(p_AG, dtype=float).reshape(-1, 3)
    m = len(p_AG)
    a2, a3, d4, d6 = DH_A[1], DH_A[2], DH_D[3], DH_D[5]
    p06 = p_AG - TCP_OFFSET * R_AG[:, :, 2]  # tool0, DH frame 6
    p05 = p06 - d6 * R_AG[:, :, 2]
    out = np.full((m, NUM_BRANCHES, 6), np.nan)
    r05 = np.hypot(p05[:, 0], p05[:, 1])
    with np.errstate(invalid="ignore", divide="ignore"):
        phi = np.arccos(d4 / r05)
        psi = np.arctan2(p05[:, 1], p05[:, 0])
        for s, s_sign in enumerate((1.0, -1.0)):
            q1 = psi + s_sign * phi + np.pi / 2
            s1, c1 = np.sin(q1), np.cos(q1)
            c5 = (p06[:, 0] * s1 - p06[:, 1] * c1 - d4) / d6
            for w, w_sign in enumerate((1.0, -1.0)):
                q5 = w_sign * np.arccos(np.clip(c5, -1.0, 1.0))
                q5 = np.where(np.abs(c5) > 1.0 + 1e-9, np.nan, q5)
                s5 = np.sin(q5)
                # Rows of R_AG are the axes of A seen from frame 6.
                X60, Y60 = R_AG[:, 0, :], R_AG[:, 1, :]
                q6 = np.arctan2((-X60[:, 1] * s1 + Y60[:, 1] * c1) / s5,
                                (X60[:, 0] * s1 - Y60[:, 0] * c1) / s5)
                q6 = np.where(np.abs(s5) < 1e-9, 0.0, q6)
                T06 = np.zeros((m, 4, 4))
                T06[:, :3, :3], T06[:, :3, 3], T06[:, 3, 3] = R_AG, p06, 1.0
                T01, T45, T56 = _dh(q1, 0), _dh(q5, 4), _dh(q6, 5)
                T14 = np.linalg.inv(T01) @ T06 @ np.linalg.inv(T45 @ T56)
                p13 = (T14 @ np.array([0.0, -d4, 0.0, 1.0]))[:, :3]
                r13 = np.hypot(p13[:, 0], p13[:, 1])
                c3 = (r13**2 - a2**2 - a3**2) / (2 * a2 * a3)
                for e, e_sign in enumerate((1.0, -1.0)):
                    q3 = e_sign * np.arccos(c3)
                    q2 = -np.arctan2(p13[:, 1], -p13[:, 0]) + np.arcsin(a3 * np.sin(q3) / r13)
                    T13 = _dh(q2, 1) @ _dh(q3, 2)
                    T34 = np.linalg.inv(T13) @ T14
                    q4 = np.arctan2(T34[:, 1, 0], T34[:, 0, 0])
                    q = np.stack([q1, q2, q3, q4, q5, q6], axis=-1)
                    out[:, 4 * s + 2 * w + e] = wrap(q)
    # Elbow at exactly ±π wraps to -π: still within the limit.
    return out
