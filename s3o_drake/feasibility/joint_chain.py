"""A serial arm's kinematics read from its model, vectorised in numpy.

A maker's model (URDF, SDFormat, MJCF) gives each joint as a pose on its parent and an axis;
nobody types a Denavit-Hartenberg table. `JointChain.of_plant` walks a parsed plant from the
arm's base frame A to its tool frame G and keeps, for the arm's n revolute joints, the
fixed transforms between them (welds and link offsets folded in) and their unit axes:

    X_AG(q) = C_0 Rot(a_1, q_1) C_1 Rot(a_2, q_2) ... Rot(a_n, q_n) C_n

so that thousands of configurations can be moved per call without a plant context. Drake's
plant stays the reference, and the chain agrees with it to the model's own precision.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from pydrake.math import RigidTransform
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import Frame, Joint, RevoluteJoint, WeldJoint


@dataclass(frozen=True, eq=False)
class JointChain:
    """`fixed` (n + 1, 4, 4): C_0 .. C_n of the module docstring; `axes` (n, 3): each
    revolute joint's unit axis, in the frame C_{i-1} ends in."""

    fixed: np.ndarray
    axes: np.ndarray

    def __post_init__(self) -> None:
        fixed = np.asarray(self.fixed, dtype=float)
        axes = np.asarray(self.axes, dtype=float)
        if fixed.shape[1:] != (4, 4) or axes.shape != (len(fixed) - 1, 3):
            raise ValueError(f"expected n + 1 transforms and n axes, got {fixed.shape} and "
                             f"{axes.shape}")
        object.__setattr__(self, "fixed", fixed)
        object.__setattr__(self, "axes", axes / np.linalg.norm(axes, axis=1, keepdims=True))

    @classmethod
    def of_plant(cls, plant: MultibodyPlant, *, base: Frame, tool: Frame,
                 joints: Sequence[Joint]) -> JointChain:
        """The chain of `joints` (revolute, in order from `base`) from frame `base` to frame
        `tool` in a finalized `plant` (the robot's model instances may be several: the
        frames and joints are the plant's own). Raises ValueError when the way from one to
        the other holds another moving joint, or not these joints in this order."""
        A, G = base, tool
        # The way from G's body down to A's body, through each body's inboard joint.
        steps = []
        body = G.body()
        while body.index() != A.body().index():
            joint = _inboard_joint(plant, body)
            if joint is None:
                raise ValueError(f"{G.name()!r} is not outboard of {A.name()!r}")
            steps.append(joint)
            body = joint.parent_body()
        steps.reverse()
        moving = [j for j in steps if not isinstance(j, WeldJoint)]
        if [j.index() for j in moving] != [j.index() for j in joints]:
            raise ValueError(f"the joints from {A.name()!r} to {G.name()!r} are "
                             f"{[j.name() for j in moving]}, not {[j.name() for j in joints]}")
        fixed, axes = [], []
        # From A to the first joint's frame on its parent.
        current = _in_body(A).inverse()
        for joint in steps:
            current = current @ _in_body(joint.frame_on_parent())
            if isinstance(joint, WeldJoint):
                current = current @ joint.X_FM()
            elif isinstance(joint, RevoluteJoint):
                fixed.append(current.GetAsMatrix4())
                axes.append(np.asarray(joint.revolute_axis(), dtype=float))
                current = RigidTransform()
            else:
                raise ValueError(f"joint {joint.name()!r} is a {joint.type_name()} joint; a "
                                 "chain holds revolute and weld joints")
            current = current @ _in_body(joint.frame_on_child()).inverse()
        fixed.append((current @ _in_body(G)).GetAsMatrix4())
        return cls(np.array(fixed), np.array(axes))

    @property
    def joints(self) -> int:
        return len(self.axes)

    def frames(self, q: np.ndarray) -> list[np.ndarray]:
        """X_A of each joint's frame for angles q (..., n), turned by its angle: the
        transform up to and including joint i's rotation, i = 1..n, then the tool's; each
        (..., 4, 4). The first n are where each joint's axis `axes[i]` is expressed."""
        q = np.asarray(q, dtype=float)
        rotations = _rotations(self.axes, q)
        T = np.broadcast_to(self.fixed[0], (*q.shape[:-1], 4, 4))
        out = []
        for i in range(self.joints):
            T = T @ rotations[..., i, :, :]
            out.append(T)
            T = T @ self.fixed[i + 1]
        out.append(T)
        return out

    def forward(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The tool's pose for configurations q (..., n): rotations (..., 3, 3), positions
        (..., 3), in A."""
        T = self.frames(q)[-1]
        return T[..., :3, :3], T[..., :3, 3]

    def jacobian(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The tool's rotation, position and geometric Jacobian (..., 6, n) in A: rows ω
        (3) then v (3), a column per joint."""
        frames = self.frames(q)
        T = frames[-1]
        R, p = T[..., :3, :3], T[..., :3, 3]
        J = np.empty((*p.shape[:-1], 6, self.joints))
        for i in range(self.joints):
            # A rotation about the joint's axis through its frame's origin.
            z = frames[i][..., :3, :3] @ self.axes[i]
            o = frames[i][..., :3, 3]
            J[..., :3, i] = z
            J[..., 3:, i] = cross(z, p - o)
        return R, p, J


def _in_body(frame: Frame) -> RigidTransform:
    """X_BF of `frame` F in its body B (fixed for the frames a parsed model has)."""
    return frame.GetFixedPoseInBodyFrame()


def _inboard_joint(plant: MultibodyPlant, body):
    for index in plant.GetJointIndices(body.model_instance()):
        joint = plant.get_joint(index)
        if joint.child_body().index() == body.index():
            return joint
    for index in plant.GetJointIndices():  # a weld to another model instance
        joint = plant.get_joint(index)
        if joint.child_body().index() == body.index():
            return joint
    return None


def _rotations(axes: np.ndarray, q: np.ndarray) -> np.ndarray:
    """(..., n, 4, 4): the rotation by q_i about axes[i] (Rodrigues), as transforms."""
    c, s = np.cos(q)[..., None, None], np.sin(q)[..., None, None]
    K = np.zeros((len(axes), 3, 3))
    K[:, 0, 1], K[:, 0, 2], K[:, 1, 2] = -axes[:, 2], axes[:, 1], -axes[:, 0]
    K = K - np.swapaxes(K, -1, -2)
    R = np.eye(3) + s * K + (1.0 - c) * (K @ K)
    T = np.zeros((*q.shape, 4, 4))
    T[..., :3, :3] = R
    T[..., 3, 3] = 1.0
    return T


def cross(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """u x v over the last axis: `np.cross` without its per-call axis handling, which
    dominated Newton steps on a few configurations."""
    return np.stack([u[..., 1] * v[..., 2] - u[..., 2] * v[..., 1],
                     u[..., 2] * v[..., 0] - u[..., 0] * v[..., 2],
                     u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]], axis=-1)
