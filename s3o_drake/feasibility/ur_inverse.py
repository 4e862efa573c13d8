"""The closed-form inverse kinematics of the UR family: all eight branches at once.

Arms of this family (UR3/5/10/16/20, their e-series, and others of the same geometry) have a
shoulder offset, three parallel axes (shoulder lift, elbow, wrist 1) and a wrist whose axes
do not meet in a point. In standard DH their twists are fixed (`UR_ALPHA`) and six lengths
differ from arm to arm (`URGeometry`); their inverse kinematics has eight solutions, picked
by the shoulder's, the wrist's and the elbow's sign.

The lengths are read from the arm's model (`URGeometry.fit`): the flange's position is
linear in them, so least squares over the model's forward kinematics gives them, to
`LENGTH_RESOLUTION`. The closed form assumes that the model's arm base frame is DH frame 0,
that its zero angles are the DH table's, and that the grasp frame has DH frame 6's axes;
whoever uses it checks that it reproduces the model (`kinematics.ArmKinematics`).
"""

import math
from dataclasses import dataclass

import numpy as np

from s3o_drake.world.angles import wrap

NUM_BRANCHES = 8
#: Fitted lengths are rounded to this (m). Least squares leaves a few units in the last
#: place of each; a model gives its lengths as decimals far coarser than this, so rounding
#: gives the model's own numbers, whatever the arithmetic of the fit (and of composing the
#: model's transforms). The check against the model (1e-9) is far above the rounding.
LENGTH_RESOLUTION = 1e-12
#: The family's DH twists (rad), joint by joint.
UR_ALPHA = (math.pi / 2, 0.0, 0.0, math.pi / 2, -math.pi / 2, 0.0)
_COS_ALPHA = np.cos(UR_ALPHA)
_SIN_ALPHA = np.sin(UR_ALPHA)


@dataclass(frozen=True)
class URGeometry:
    """The lengths (m) of a UR-family arm's standard DH table from its base frame A to its
    flange (the table's other lengths are zero), and the grasp frame G's offset beyond
    it."""

    d1: float
    """The shoulder-lift axis above A."""
    a2: float
    """Shoulder lift to elbow (negative: the UR's convention)."""
    a3: float
    """Elbow to wrist 1."""
    d4: float
    """The shoulder offset: wrist 1's common normal with wrist 2, along the parallel axes."""
    d5: float
    """Wrist 1's axis to wrist 3's, along wrist 2's."""
    d6: float
    """Wrist 2's axis to the flange, along wrist 3's."""
    tool_offset: float = 0.0
    """The flange to G, along wrist 3's axis."""

    @classmethod
    def fit(cls, R_AG: np.ndarray, p_AG: np.ndarray, q: np.ndarray,
            tool_offset: float) -> "URGeometry":
        """The lengths that best explain the grasp frame's poses (m, 3, 3), (m, 3) at
        configurations q (m, 6), G `tool_offset` beyond the flange along its z, by least
        squares: with the twists fixed, each length moves the flange along one axis of one
        DH frame, whatever the lengths."""
        frames = _rotations(np.asarray(q, dtype=float))
        x = [frame[..., :, 0] for frame in frames]
        z = [frame[..., :, 2] for frame in frames]
        M = np.stack([z[0], x[2], x[3], z[3], z[4], z[5]], axis=-1).reshape(-1, 6)
        p_AT = np.asarray(p_AG, dtype=float) - tool_offset * np.asarray(R_AG)[..., :, 2]
        lengths, *_ = np.linalg.lstsq(M, p_AT.reshape(-1), rcond=None)
        digits = round(-math.log10(LENGTH_RESOLUTION))
        return cls(*(round(float(v), digits) for v in (*lengths, tool_offset)))

    def transform(self, q: np.ndarray, i: int) -> np.ndarray:
        """Row i of the DH table at angles q (...): T_{i,i+1} (..., 4, 4)."""
        a = (0.0, self.a2, self.a3, 0.0, 0.0, 0.0)[i]
        d = (self.d1, 0.0, 0.0, self.d4, self.d5, self.d6)[i]
        return _dh(np.asarray(q, dtype=float), a, d, _COS_ALPHA[i], _SIN_ALPHA[i])


def _dh(q: np.ndarray, a: float, d: float, ca: float, sa: float) -> np.ndarray:
    """Standard DH: Rz(q) Tz(d) Tx(a) Rx(alpha), for angles q (...): (..., 4, 4)."""
    c, s = np.cos(q), np.sin(q)
    T = np.zeros((*q.shape, 4, 4))
    T[..., 0, 0], T[..., 0, 1], T[..., 0, 2], T[..., 0, 3] = c, -s * ca, s * sa, a * c
    T[..., 1, 0], T[..., 1, 1], T[..., 1, 2], T[..., 1, 3] = s, c * ca, -c * sa, a * s
    T[..., 2, 1], T[..., 2, 2], T[..., 2, 3] = sa, ca, d
    T[..., 3, 3] = 1.0
    return T


def _rotations(q: np.ndarray) -> list[np.ndarray]:
    """The DH frames' rotations R_A0 .. R_A6 at angles q (..., 6)."""
    R = np.broadcast_to(np.eye(3), (*q.shape[:-1], 3, 3))
    frames = [R]
    for i in range(6):
        R = R @ _dh(q[..., i], 0.0, 0.0, _COS_ALPHA[i], _SIN_ALPHA[i])[..., :3, :3]
        frames.append(R)
    return frames


def ur_inverse(geometry: URGeometry, R_AG: np.ndarray, p_AG: np.ndarray) -> np.ndarray:
    """All closed-form IK solutions of a UR-family arm for targets (m, 3, 3), (m, 3):
    (m, 8, 6), NaN if none.

    Branch b = 4 s + 2 w + e picks the shoulder (s), wrist (w) and elbow (e) sign. Angles are
    wrapped into [-π, π); a singular wrist (q5 = 0) takes q6 = 0. Solutions are not checked
    for collisions; callers verify them with the arm's forward kinematics (numerical edge
    cases are NaN'd by that check, not here).
    """
    R_AG = np.asarray(R_AG, dtype=float).reshape(-1, 3, 3)
    p_AG = np.asarray(p_AG, dtype=float).reshape(-1, 3)
    m = len(p_AG)
    a2, a3, d4, d6 = geometry.a2, geometry.a3, geometry.d4, geometry.d6
    p06 = p_AG - geometry.tool_offset * R_AG[:, :, 2]  # the flange, DH frame 6
    p05 = p06 - d6 * R_AG[:, :, 2]
    out = np.full((m, NUM_BRANCHES, 6), np.nan)
    r05 = np.hypot(p05[:, 0], p05[:, 1])
    T06 = np.zeros((m, 4, 4))
    T06[:, :3, :3], T06[:, :3, 3], T06[:, 3, 3] = R_AG, p06, 1.0
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
                T01 = geometry.transform(q1, 0)
                T45, T56 = geometry.transform(q5, 4), geometry.transform(q6, 5)
                T14 = np.linalg.inv(T01) @ T06 @ np.linalg.inv(T45 @ T56)
                p13 = (T14 @ np.array([0.0, -d4, 0.0, 1.0]))[:, :3]
                r13 = np.hypot(p13[:, 0], p13[:, 1])
                c3 = (r13**2 - a2**2 - a3**2) / (2 * a2 * a3)
                for e, e_sign in enumerate((1.0, -1.0)):
                    q3 = e_sign * np.arccos(c3)
                    q2 = -np.arctan2(p13[:, 1], -p13[:, 0]) + np.arcsin(a3 * np.sin(q3) / r13)
                    T13 = geometry.transform(q2, 1) @ geometry.transform(q3, 2)
                    T34 = np.linalg.inv(T13) @ T14
                    q4 = np.arctan2(T34[:, 1, 0], T34[:, 0, 0])
                    q = np.stack([q1, q2, q3, q4, q5, q6], axis=-1)
                    out[:, 4 * s + 2 * w + e] = wrap(q)
    # Elbow at exactly ±π wraps to -π: still within the limit.
    return out
