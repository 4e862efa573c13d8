"""The closed-form inverse kinematics of the UR family: all eight branches at once.

Arms of this family (UR3/5/10/16/20, their e-series, and others of the same geometry) have a
shoulder offset, three parallel axes (shoulder lift, elbow, wrist 1) and a wrist whose axes
do not meet in a point, in standard DH. Their inverse kinematics has eight solutions, picked by the
shoulder's, the wrist's and the elbow's sign.
"""

import numpy as np

from s3o_drake.feasibility.dh_chain import DHChain
from s3o_drake.world.angles import wrap

NUM_BRANCHES = 8


def ur_inverse(chain: DHChain, R_AG: np.ndarray, p_AG: np.ndarray) -> np.ndarray:
    """All closed-form IK solutions of a UR-family `chain` for targets (m, 3, 3), (m, 3):
    (m, 8, 6), NaN if none.

    Branch b = 4 s + 2 w + e picks the shoulder (s), wrist (w) and elbow (e) sign. Angles are
    wrapped into [-π, π); a singular wrist (q5 = 0) takes q6 = 0. Solutions are not checked
    for collisions; callers verify them with the chain's forward kinematics (numerical edge
    cases are NaN'd by that check, not here).
    """
    if chain.modified or chain.joints != 6 or chain.tool_yaw:
        raise ValueError("the UR family's closed form needs a standard DH chain of 6 joints "
                         "whose tool frame is along the flange")

    def dh(q: np.ndarray, i: int) -> np.ndarray:
        return chain.transforms(np.asarray(q, dtype=float)[..., None], slice(i, i + 1))[
            ..., 0, :, :]

    R_AG = np.asarray(R_AG, dtype=float).reshape(-1, 3, 3)
    p_AG = np.asarray(p_AG, dtype=float).reshape(-1, 3)
    m = len(p_AG)
    a2, a3, d4, d6 = chain.a[1], chain.a[2], chain.d[3], chain.d[5]
    p06 = p_AG - chain.tool_offset * R_AG[:, :, 2]  # tool0, DH frame 6
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
                T01, T45, T56 = dh(q1, 0), dh(q5, 4), dh(q6, 5)
                T14 = np.linalg.inv(T01) @ T06 @ np.linalg.inv(T45 @ T56)
                p13 = (T14 @ np.array([0.0, -d4, 0.0, 1.0]))[:, :3]
                r13 = np.hypot(p13[:, 0], p13[:, 1])
                c3 = (r13**2 - a2**2 - a3**2) / (2 * a2 * a3)
                for e, e_sign in enumerate((1.0, -1.0)):
                    q3 = e_sign * np.arccos(c3)
                    q2 = -np.arctan2(p13[:, 1], -p13[:, 0]) + np.arcsin(a3 * np.sin(q3) / r13)
                    T13 = dh(q2, 1) @ dh(q3, 2)
                    T34 = np.linalg.inv(T13) @ T14
                    q4 = np.arctan2(T34[:, 1, 0], T34[:, 0, 0])
                    q = np.stack([q1, q2, q3, q4, q5, q6], axis=-1)
                    out[:, 4 * s + 2 * w + e] = wrap(q)
    # Elbow at exactly ±π wraps to -π: still within the limit.
    return out
