"""Grasp targets relative to the arm base A, for many base poses at once.

The feasibility check (s3o_drake/feasibility/check.py) needs, for every base pose of a
batch, where each of the dish's grasps puts the grasp point relative to A: its distance ρ
and height h, and its bearing relative to A's x axis, the indices of the reachability map.
`grasps.grasps_for` gives them for one pose; here a dish kind's grasps are read off it once
(`GraspSpec`) and the geometry is vectorised in numpy (`target_geometry`; a test holds the
two equal). `exhaustive_ik_seeds` gives the arm's closed-form solutions at or near such a
target, the seeds of the check's exhaustive IK.
"""

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from s3o_drake.feasibility import ik
from s3o_drake.feasibility import kinematics as kin
from s3o_drake.feasibility.grasps import grasps_for
from s3o_drake.feasibility.reachability.map import R_KIND, place
from s3o_drake.world.robot import Robot

#: Exhaustive IK: random seeds after the closed-form ones and the stow configuration.
RANDOM_SEEDS = 2
#: Reach probe of exhaustive IK (m): a target with no closed-form solution gets IK only if
#: some target this close (in ρ and h) has one; tilting within the angle tolerance moves the
#: wrist by about 1 cm, so 3 cm is safely beyond what IK could still reach.
PROBE_OFFSETS = np.array([0.0, -0.01, 0.01, -0.02, 0.02, -0.03, 0.03])


@dataclass(frozen=True)
class GraspSpec:
    """A dish kind's grasp, independent of where the robot stands (from `grasps_for`).

    The grasp point is `inset` nearer to A than the dish's centre, `z_offset` above the table
    top; the gripper is turned by `wrist_turn` about the approach axis.
    """

    kind: str
    wrist_turn: float
    inset: float
    z_offset: float


def grasp_specs(dish_kind: str, *, robot: Robot) -> list[GraspSpec]:
    """`robot`'s grasps of a dish kind, read off `grasps_for` (so both stay one
    definition)."""
    grasps = grasps_for(dish_kind, np.zeros(2), 0.0, np.array([-1.0, 0.0, 0.0]), robot=robot)
    return [GraspSpec(g.kind, g.wrist_turn, 1.0 - g.rho, g.height) for g in grasps]


def reach_offset_rows(offsets: np.ndarray, n: int) -> np.ndarray:
    """Reach offsets as (n, 3): rows of (dx, dy) or (dx, dy, dz)."""
    offsets = np.asarray(offsets, dtype=float)
    if offsets.size in (2 * n, 3 * n) and n > 0:
        offsets = offsets.reshape(n, -1)
    if offsets.shape != (n, 3) and offsets.shape != (n, 2):
        raise ValueError(f"reach offsets: expected {n} rows of 2 or 3 values, "
                         f"got shape {offsets.shape}")
    if offsets.shape[1] == 2:
        offsets = np.column_stack([offsets, np.zeros(n)])
    return offsets


def arm_base_positions(bases: np.ndarray, *, robot: Robot) -> np.ndarray:
    """p_WA (n, 3) of `robot` for base poses (n, 3): `FeasibilityScene.p_WA`, vectorised (as
    in `target_geometry`)."""
    x, y, yaw = bases[:, 0], bases[:, 1], bases[:, 2]
    c, s = np.cos(yaw), np.sin(yaw)
    mx, my, mz = robot.arm_mount_xyz
    return np.stack([x + c * mx - s * my, y + s * mx + c * my, np.full_like(x, mz)], axis=1)


def target_geometry(specs: Sequence[GraspSpec], p_WD: np.ndarray, table_height: float,
                    bases: np.ndarray, offsets: np.ndarray | None, *, robot: Robot
                    ) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Per grasp of `specs`: (ρ, h, bearing relative to A's x axis) arrays, each (n,), for
    `robot`'s base poses (n, 3), a dish at p_WD on a table top at `table_height` and reach
    offsets (n, 3) or None: `grasps_for`'s geometry for many base poses at once."""
    x, y, yaw = bases[:, 0], bases[:, 1], bases[:, 2]
    c, s = np.cos(yaw), np.sin(yaw)
    mx, my, mz = robot.arm_mount_xyz
    dx = p_WD[0] - (x + c * mx - s * my)
    dy = p_WD[1] - (y + s * mx + c * my)
    h = np.full_like(dx, table_height - mz)
    if offsets is not None:
        dx, dy, h = dx + offsets[:, 0], dy + offsets[:, 1], h + offsets[:, 2]
    distance = np.hypot(dx, dy)
    relative = kin.wrap(np.arctan2(dy, dx) - yaw)
    return [(distance - spec.inset, h + spec.z_offset, relative) for spec in specs]


def exhaustive_ik_seeds(spec: GraspSpec, rho: float, h: float, bearing: float,
                        random_seeds: int = RANDOM_SEEDS, *, robot: Robot) -> np.ndarray | None:
    """Seeds of exhaustive IK for one grasp of `robot`, or None when the target is surely
    out of reach.

    The arm's closed-form solutions at the target (every branch), or, when it has none, at
    the nearest probe target within 3 cm that has some; then its stow configuration and
    random seeds.
    """
    arm = kin.arm_kinematics(robot)
    R = np.broadcast_to(R_KIND[spec.kind], (len(PROBE_OFFSETS) ** 2, 3, 3))
    d_rho, d_h = np.meshgrid(PROBE_OFFSETS, PROBE_OFFSETS, indexing="ij")
    order = np.argsort(np.hypot(d_rho, d_h).ravel(), kind="stable")
    p = np.stack([rho + d_rho.ravel(), np.zeros(d_rho.size), h + d_h.ravel()], axis=1)[order]
    solutions = arm.inverse(R, p)
    exact = arm.exact(solutions, R, p)
    hits = np.flatnonzero(exact.any(axis=1))
    if hits.size == 0:
        return None
    closed_form = place(solutions[hits[0]][exact[hits[0]]], bearing, spec.wrist_turn,
                        robot=robot)
    return np.vstack([closed_form, robot.arm_stow,
                      ik.random_arm_seeds(random_seeds, robot=robot)])
