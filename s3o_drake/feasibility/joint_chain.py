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
from dataclasses import dataclass, field

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
    _skew: np.ndarray = field(init=False, repr=False)
    _skew_squared: np.ndarray = field(init=False, repr=False)
    _axis_columns: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        fixed = np.asarray(self.fixed, dtype=float)
        axes = np.asarray(self.axes, dtype=float)
        if fixed.shape[1:] != (4, 4) or axes.shape != (len(fixed) - 1, 3):
            raise ValueError(f"expected n + 1 transforms and n axes, got {fixed.shape} and "
                             f"{axes.shape}")
        object.__setattr__(self, "fixed", fixed)
        axes = axes / np.linalg.norm(axes, axis=1, keepdims=True)
        object.__setattr__(self, "axes", axes)
        # Constants of every evaluation: the axes' cross-product matrices K, K @ K, and the
        # axes as columns.
        skew = np.zeros((len(axes), 3, 3))
        skew[:, 0, 1], skew[:, 0, 2], skew[:, 1, 2] = -axes[:, 2], axes[:, 1], -axes[:, 0]
        skew = skew - np.swapaxes(skew, -1, -2)
        object.__setattr__(self, "_skew", skew)
        object.__setattr__(self, "_skew_squared", skew @ skew)
        object.__setattr__(self, "_axis_columns", axes[:, :, None])

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
        stacked = self._stacked_frames(np.asarray(q, dtype=float))
        return [stacked[..., i, :, :] for i in range(self.joints + 1)]

    def forward(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The tool's pose for configurations q (..., n): rotations (..., 3, 3), positions
        (..., 3), in A."""
        T = self._stacked_frames(np.asarray(q, dtype=float))[..., -1, :, :]
        return T[..., :3, :3], T[..., :3, 3]

    def jacobian(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The tool's rotation, position and geometric Jacobian (..., 6, n) in A: rows ω
        (3) then v (3), a column per joint."""
        frames = self._stacked_frames(np.asarray(q, dtype=float))
        T = frames[..., -1, :, :]
        R, p = T[..., :3, :3], T[..., :3, 3]
        # A rotation about each joint's axis z through its frame's origin o; all joints at
        # once (damped least squares evaluates a few configurations at a time, thousands of
        # times, where numpy's per-call cost is most of the work).
        z = (frames[..., :-1, :3, :3] @ self._axis_columns)[..., 0]
        o = frames[..., :-1, :3, 3]
        J = np.empty((*p.shape[:-1], 6, self.joints))
        J[..., :3, :] = np.swapaxes(z, -1, -2)
        J[..., 3:, :] = np.swapaxes(cross(z, p[..., None, :] - o), -1, -2)
        return R, p, J

    def _stacked_frames(self, q: np.ndarray) -> np.ndarray:
        """`frames` as one array (..., n + 1, 4, 4)."""
        rotations = _rotations(self._skew, self._skew_squared, q)
        frames = np.empty((*q.shape[:-1], self.joints + 1, 4, 4))
        between = np.empty((*q.shape[:-1], 4, 4))  # a frame times the next fixed transform
        T = np.broadcast_to(self.fixed[0], between.shape)
        for i in range(self.joints):
            T = np.matmul(T, rotations[..., i, :, :], out=frames[..., i, :, :])
            T = np.matmul(T, self.fixed[i + 1],
                          out=frames[..., i + 1, :, :] if i + 1 == self.joints else between)
        return frames


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


def _rotations(skew: np.ndarray, skew_squared: np.ndarray, q: np.ndarray) -> np.ndarray:
    """(..., n, 4, 4): the rotation by q_i about the axis whose cross-product matrix is
    skew[i] (Rodrigues; skew_squared[i] = skew[i] @ skew[i]), as transforms."""
    c, s = np.cos(q)[..., None, None], np.sin(q)[..., None, None]
    T = np.zeros((*q.shape, 4, 4))
    T[..., :3, :3] = np.eye(3) + s * skew + (1.0 - c) * skew_squared
    T[..., 3, 3] = 1.0
    return T


#: Component i of u x v is u[j] v[k] - u[k] v[j] with (i, j, k) cyclic.
_NEXT, _AFTER = (1, 2, 0), (2, 0, 1)


def cross(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """u x v over the last axis: `np.cross` without its per-call axis handling, which
    dominated Newton steps on a few configurations; the three components in two products
    of gathered components and a difference, not nine operations and a stack (the same
    arithmetic, component by component)."""
    return u[..., _NEXT] * v[..., _AFTER] - u[..., _AFTER] * v[..., _NEXT]
