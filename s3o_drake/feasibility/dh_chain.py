"""A serial arm's kinematics from its Denavit-Hartenberg parameters, vectorised in numpy.

Any number of revolute joints, in either convention that manufacturers publish:

- standard (classic) DH: joint i turns about z of frame i-1, and
  T_{i-1,i} = Rz(q_i) Tz(d_i) Tx(a_i) Rx(alpha_i) (the UR family);
- modified (Craig's) DH: joint i turns about z of frame i, and
  T_{i-1,i} = Rx(alpha_i) Tx(a_i) Rz(q_i) Tz(d_i), with alpha_i and a_i from row i of the
  table (the Franka family's published table).

The tool frame is the last frame moved `tool_offset` along its z and turned `tool_yaw` about
it (a hand mounted at an angle to the flange). Drake's plant stays the reference:
the chain is what lets thousands of configurations be moved per call without a context.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class DHChain:
    a: np.ndarray
    d: np.ndarray
    alpha: np.ndarray
    modified: bool = False
    """Craig's convention (see the module docstring); standard DH otherwise."""
    tool_offset: float = 0.0
    """The tool frame along z of the last frame (m)."""
    tool_yaw: float = 0.0
    """The tool frame turned about that z (rad)."""
    _ca: np.ndarray = field(init=False, repr=False)
    _sa: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        for name in ("a", "d", "alpha"):
            object.__setattr__(self, name, np.asarray(getattr(self, name), dtype=float))
        if not len(self.a) == len(self.d) == len(self.alpha):
            raise ValueError(f"a, d and alpha differ in length: {len(self.a)}, {len(self.d)}, "
                             f"{len(self.alpha)}")
        object.__setattr__(self, "_ca", np.cos(self.alpha))
        object.__setattr__(self, "_sa", np.sin(self.alpha))

    @property
    def joints(self) -> int:
        return len(self.a)

    def transforms(self, q: np.ndarray, joints: slice = slice(None)) -> np.ndarray:
        """The joints' transforms T_{i-1,i} for angles q (..., j): (..., j, 4, 4), all at
        once (one array operation per matrix entry for all joints and configurations)."""
        c, s = np.cos(q), np.sin(q)
        ca, sa, a, d = self._ca[joints], self._sa[joints], self.a[joints], self.d[joints]
        T = np.zeros((*q.shape, 4, 4))
        if self.modified:
            T[..., 0, 0], T[..., 0, 1], T[..., 0, 3] = c, -s, a
            T[..., 1, 0], T[..., 1, 1], T[..., 1, 2], T[..., 1, 3] = s * ca, c * ca, -sa, -d * sa
            T[..., 2, 0], T[..., 2, 1], T[..., 2, 2], T[..., 2, 3] = s * sa, c * sa, ca, d * ca
        else:
            T[..., 0, 0], T[..., 0, 1], T[..., 0, 2], T[..., 0, 3] = c, -s * ca, s * sa, a * c
            T[..., 1, 0], T[..., 1, 1], T[..., 1, 2], T[..., 1, 3] = s, c * ca, -c * sa, a * s
            T[..., 2, 1], T[..., 2, 2], T[..., 2, 3] = sa, ca, d
        T[..., 3, 3] = 1.0
        return T

    def frames(self, q: np.ndarray) -> list[np.ndarray]:
        """X_0,i for i = 0..n (frame 0 is the chain's base), each (..., 4, 4)."""
        T_all = self.transforms(np.asarray(q, dtype=float))
        T = T_all[..., 0, :, :]
        frames = [np.broadcast_to(np.eye(4), T.shape), T]
        for i in range(1, self.joints):
            T = T @ T_all[..., i, :, :]
            frames.append(T)
        return frames

    def forward(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The tool's pose for configurations q (..., n): rotations (..., 3, 3), positions
        (..., 3)."""
        return self._tool(self.frames(q)[-1])

    def _tool(self, last: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The tool's rotation and position from the last frame's transforms."""
        R = last[..., :3, :3]
        p = last[..., :3, 3] + self.tool_offset * R[..., :, 2]
        if self.tool_yaw:
            c, s = np.cos(self.tool_yaw), np.sin(self.tool_yaw)
            R = R @ np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        return R, p

    def jacobian(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The tool's rotation, position and geometric Jacobian (..., 6, n) in the base
        frame: rows ω (3) then v (3), a column per joint."""
        frames = self.frames(q)
        R, p = self._tool(frames[-1])
        J = np.empty((*p.shape[:-1], 6, self.joints))
        # Joint i turns about z of frame i-1 (standard) or of frame i (modified).
        first = 1 if self.modified else 0
        for i in range(self.joints):
            z = frames[i + first][..., :3, 2]
            o = frames[i + first][..., :3, 3]
            J[..., :3, i] = z
            J[..., 3:, i] = cross(z, p - o)
        return R, p, J


def cross(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """u x v over the last axis: `np.cross` without its per-call axis handling, which
    dominated Newton steps on a few configurations."""
    return np.stack([u[..., 1] * v[..., 2] - u[..., 2] * v[..., 1],
                     u[..., 2] * v[..., 0] - u[..., 0] * v[..., 2],
                     u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]], axis=-1)
