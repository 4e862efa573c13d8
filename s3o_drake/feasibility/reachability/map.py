"""The arm's inverse reachability map: stored grasp configurations, looked up in microseconds.

A grasp's frame depends only on its kind ("top", "side"), the bearing from the arm base A to
the dish and a wrist turn about the approach axis (see `grasps`). Turning the shoulder-pan
joint by Δ turns the whole arm about A's z axis, and turning wrist 3 turns the gripper about
the approach axis, so one arm configuration that grasps at bearing 0 with wrist turn 0 serves
every bearing and turn. The map therefore stores, for each kind, configurations on a grid
over the grasp point's horizontal distance ρ from A and its height h above A.

Built once with Drake IK on a plant that holds the robot alone (the build is in
s3o_drake/feasibility/reachability/build.py): at each grid node the arm's inverse kinematics
(the UR family: all eight closed-form shoulder/wrist/elbow branches; another arm: damped
least squares from its default seeds) seeds `InverseKinematics` with the grasp-frame
constraints and a self-collision clearance of 1 cm (SNOPT, capped iterations), and each
verified solution is kept in its branch's slot (at most K per node: 8 for the UR5e, 16 for
the Panda). The
environment is left to query time, where the configurations are moved to the query's
bearing and checked against the scene with the collision checker
(`s3o_drake.feasibility.check`).

A query between nodes takes each branch from the grid cell's corners (bilinear interpolation
of the joint angles), verifies it by forward kinematics and, where it is not yet within
tolerance, moves it onto the target with a few Newton steps; so the answer does not depend on
the grid's resolution, and a target beyond the arm's reach has no candidates.

`s3o build reachability` builds the map deterministically
with worker processes (a few minutes on two cores) and writes it atomically, with its
settings, as a compressed .npz; `ReachabilityMap.load(robot=...)` reads a robot's
(`Robot.files.reachability_map`).
"""

import functools
import hashlib
import io
import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from s3o_drake.feasibility import kinematics as kin
from s3o_drake.feasibility.grasps import R_BEARING_SIDE, R_BEARING_TOP
from s3o_drake.feasibility.ik import ANGLE_TOLERANCE, POSITION_TOLERANCE
from s3o_drake.world.robot import Robot

BUILD_COMMAND = "s3o build reachability"
FORMAT_VERSION = 1

#: A query's candidate is accepted without Newton steps within these errors.
ACCEPT_POSITION = POSITION_TOLERANCE
ACCEPT_ANGLE = ANGLE_TOLERANCE
#: Newton steps go on until within these errors (else the candidate is dropped).
NEWTON_POSITION = 1e-4
NEWTON_ANGLE = 1e-3
#: A grid cell's interpolation is used without verification where it stays this close to
#: the target at the cell's centre and edge midpoints (else forward kinematics checks it).
TRUST_POSITION = 0.0005
TRUST_ANGLE = math.radians(0.5)
#: Steps that let the orientation give way (weight in m/rad): a 2° tilt then weighs as much
#: as 0.35 mm of position error.
TILT_WEIGHT = 0.01
TILT_ITERATIONS = 12

#: Rotation R_AG of each kind's grasp at bearing 0, wrist turn 0.
R_KIND = {"top": R_BEARING_TOP.matrix(), "side": R_BEARING_SIDE.matrix()}


class ReachabilityMapError(RuntimeError):
    """The map file is missing, unreadable or was built for another robot model."""


def robot_model_sha256(robot: Robot) -> str:
    """SHA-256 of `robot`'s model file (a robot of parts: of its parts' files' digests in
    order), recorded in the map so that a stale map is noticed."""
    files = robot.model_files
    if len(files) == 1:
        return hashlib.sha256(files[0].read_bytes()).hexdigest()
    return hashlib.sha256("".join(hashlib.sha256(f.read_bytes()).hexdigest()
                                  for f in files).encode()).hexdigest()


def grid_axis(lo: float, hi: float, step: float) -> np.ndarray:
    """Nodes from lo to hi (inclusive, rounded to whole steps)."""
    n = round((hi - lo) / step) + 1
    return lo + step * np.arange(n)


def unwrap_to(q: np.ndarray, q_ref: np.ndarray) -> np.ndarray:
    """q with each angle moved by whole turns to lie within π of q_ref."""
    return q_ref + kin.wrap(q - q_ref)


_SHARED: dict[tuple, "ReachabilityMap"] = {}


@dataclass
class ReachabilityMap:
    """Stored configurations of `robot`'s arm (bearing 0, wrist turn 0) per grasp kind on a
    (ρ, h) grid.

    `configs[kind]` is (n_rho, n_h, K, n) float32, NaN where a branch has no solution;
    `branch_order[kind]` lists the slots in the order in which query candidates are tried
    (most often collision-free near tables first); `settings` records how it was built.
    """

    rho: np.ndarray
    height: np.ndarray
    configs: dict[str, np.ndarray]
    branch_order: dict[str, np.ndarray]
    settings: dict
    robot: Robot

    # ----------------------------------------------------------------------------- file
    @classmethod
    def shared(cls, path: str | Path | None = None, *, robot: Robot) -> "ReachabilityMap":
        """`load(path, robot=robot)`, read once per process, robot and file version: the map
        is never modified, and its lookups, prepared on first use, then serve every scene and
        planning problem of the process."""
        path = Path(path) if path is not None else robot.files.reachability_map
        key = (robot.name, str(path.resolve()),
               path.stat().st_mtime_ns if path.is_file() else None)
        if key not in _SHARED:
            _SHARED[key] = cls.load(path, robot=robot)
        return _SHARED[key]

    @classmethod
    def load(cls, path: str | Path | None = None, *, robot: Robot,
             check_robot: bool = True) -> "ReachabilityMap":
        """Reads `robot`'s map file (default: the one shipped in its folder,
        `robot.files.reachability_map`).

        Raises ReachabilityMapError naming the build command when the file is missing, or
        when it was built for a different robot model (`check_robot=False` skips that test).
        """
        path = Path(path) if path is not None else robot.files.reachability_map
        if not path.is_file():
            raise ReachabilityMapError(
                f"reachability map {path} not found; build it with `{BUILD_COMMAND} --out {path}`")
        try:
            with np.load(path, allow_pickle=False) as data:
                settings = json.loads(str(data["settings"]))
                if settings.get("format") != FORMAT_VERSION:
                    raise ReachabilityMapError(
                        f"reachability map {path} has format {settings.get('format')}, expected "
                        f"{FORMAT_VERSION}; rebuild it with `{BUILD_COMMAND} --out {path}`")
                configs = {k: data[f"configs_{k}"].astype(np.float32) for k in settings["kinds"]}
                order = {k: data[f"order_{k}"].astype(np.int64) for k in settings["kinds"]}
        except (OSError, KeyError, ValueError) as e:
            raise ReachabilityMapError(
                f"reachability map {path} is unreadable ({e}); rebuild it with "
                f"`{BUILD_COMMAND} --out {path}`") from e
        if check_robot and settings.get("robot_urdf_sha256") != robot_model_sha256(robot):
            raise ReachabilityMapError(
                f"reachability map {path} was built for another version of the robot model; "
                f"rebuild it with `{BUILD_COMMAND} --out {path}`")
        rho = grid_axis(*settings["rho_range"], settings["resolution"])
        height = grid_axis(*settings["height_range"], settings["resolution"])
        return cls(rho=rho, height=height, configs=configs, branch_order=order,
                   settings=settings, robot=robot)

    @functools.cached_property
    def fingerprint(self) -> str:
        """SHA-256 of the map's contents (settings, configurations, try orders)."""
        digest = hashlib.sha256(json.dumps(self.settings, sort_keys=True).encode())
        for kind in sorted(self.configs):
            digest.update(np.ascontiguousarray(self.configs[kind]).tobytes())
            digest.update(np.ascontiguousarray(self.branch_order[kind]).tobytes())
        return digest.hexdigest()

    def to_bytes(self) -> bytes:
        """The map as a compressed .npz file's bytes."""
        buffer = io.BytesIO()
        arrays = {"settings": np.array(json.dumps(self.settings, sort_keys=True))}
        for kind, q in self.configs.items():
            arrays[f"configs_{kind}"] = q.astype(np.float32)
            arrays[f"order_{kind}"] = np.asarray(self.branch_order[kind], dtype=np.int8)
        np.savez_compressed(buffer, **arrays)
        return buffer.getvalue()

    # ---------------------------------------------------------------------------- query
    @property
    def arm(self) -> kin.ArmKinematics:
        """The kinematics of the robot's arm the map was built for."""
        return kin.arm_kinematics(self.robot)

    @property
    def kinds(self) -> tuple[str, ...]:
        return tuple(self.configs)

    def candidates(self, kind: str, rho: float, h: float) -> np.ndarray:
        """Arm configurations (k, n) grasping (ρ, h) at bearing 0 with wrist turn 0.

        In the order to try them; empty when (ρ, h) is outside the map or out of reach.
        """
        q, valid = self.candidates_many(kind, np.array([rho]), np.array([h]))
        return q[0][valid[0]]

    def candidates_many(self, kind: str, rho: np.ndarray, h: np.ndarray, *,
                        pitch: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """Vectorised `candidates`: (m, K, n) configurations and an (m, K) validity mask.

        Slots are in the try order (`branch_order`); invalid slots hold NaN. A `pitch`
        (rad) tilts the grasp frame about the bearing frame's y axis (positive: the approach
        axis dips, the wrist behind the grasp point rises); the configurations then solve
        that tilted target exactly.
        """
        rho = np.asarray(rho, dtype=float).reshape(-1)
        h = np.asarray(h, dtype=float).reshape(-1)
        cells = self._cells(kind)
        arm = self.arm
        n_i, n_j, k = cells.full.shape
        out = np.full((len(rho), k, arm.joints), np.nan)
        valid = np.zeros((len(rho), k), dtype=bool)
        u = (rho - self.rho[0]) / self.settings["resolution"]
        v = (h - self.height[0]) / self.settings["resolution"]
        rows = np.flatnonzero((u >= 0) & (u <= n_i) & (v >= 0) & (v <= n_j))
        if rows.size == 0:
            return out, valid
        u, v = u[rows], v[rows]
        i, j = np.minimum(u.astype(int), n_i - 1), np.minimum(v.astype(int), n_j - 1)
        fu, fv = (u - i)[:, None, None], (v - j)[:, None, None]
        start = cells.nearest[i, j, np.rint(fu[:, 0, 0]).astype(int),
                              np.rint(fv[:, 0, 0]).astype(int)]  # (m, K): a corner, or -1
        has = start >= 0
        if not has.any():
            return out, valid
        # Cells whose four corners hold the branch: bilinear interpolation of the angles.
        a, b, c, d = (cells.coefficients[i, j, :, n] for n in range(4))
        q = a + b * fu + c * fv + d * (fu * fv)
        full = cells.full[i, j]
        # Elsewhere (at the edge of the reach): the nearest corner holding it.
        partial = has & ~full
        if partial.any():
            m_idx, b_idx = np.nonzero(partial)
            corner = start[m_idx, b_idx]
            q[m_idx, b_idx] = cells.table[i[m_idx] + corner // 2, j[m_idx] + corner % 2, b_idx]
        # Trusted cells interpolate within 0.5 mm and 0.5°; the others are verified and, if
        # need be, moved onto the target.
        check = has & ~(full & cells.trusted(i, j)) if not pitch else has
        m_idx, b_idx = np.nonzero(check)
        ok_all = has.copy()
        if m_idx.size:
            q_c = q[m_idx, b_idx]
            p_target = np.zeros((len(m_idx), 3))
            p_target[:, 0], p_target[:, 2] = rho[rows][m_idx], h[rows][m_idx]
            R_target = R_KIND[kind]
            if pitch:
                cp, sp = math.cos(pitch), math.sin(pitch)
                R_target = np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]]) @ R_target
            R, p = arm.forward(q_c)
            angle, distance = kin.pose_error(R, p, R_target, p_target)
            ok = (angle <= (NEWTON_ANGLE if pitch else ACCEPT_ANGLE)) & (
                distance <= ACCEPT_POSITION)
            if not ok.all():
                # Newton steps onto the exact target; where that fails (a target just beyond
                # the reach with the exact orientation), steps that let the orientation give
                # way within its tolerance.
                R_target = np.broadcast_to(R_target, (len(m_idx), 3, 3))
                for weight, iterations, max_angle, max_distance in (
                        (1.0, 3, NEWTON_ANGLE, NEWTON_POSITION),
                        (TILT_WEIGHT, TILT_ITERATIONS, ACCEPT_ANGLE, ACCEPT_POSITION)):
                    redo = np.flatnonzero(~ok)
                    if redo.size == 0:
                        break
                    q_new, angle, distance = arm.refine(
                        q_c[redo], R_target[redo], p_target[redo], iterations=iterations,
                        rotation_weight=weight)
                    good = (angle <= max_angle) & (distance <= max_distance)
                    q_c[redo[good]] = q_new[good]
                    ok[redo] = good
            q[m_idx, b_idx] = q_c
            ok_all[m_idx, b_idx] = ok
        # Wrapped into [-π, π), or a turn from there into the joint's limits.
        q = arm.into_limits(q)
        ok_all &= arm.within_limits(q)
        rank = self._rank[kind]
        out[rows[:, None], rank] = np.where(ok_all[..., None], q, np.nan)
        valid[rows[:, None], rank] = ok_all
        return out, valid

    def prepare_all(self) -> None:
        """Readies the lookups of every grasp kind of the map."""
        for kind in self.configs:
            self.prepare(kind)

    def prepare(self, kind: str) -> None:
        """Readies the lookups of a grasp kind now rather than at its first query."""
        self._cells(kind)

    def _cells(self, kind: str) -> "_Cells":
        """The grid cells of a kind, prepared for lookups on first use."""
        if kind not in self._cache:
            self._cache[kind] = _Cells.of(self.configs[kind], self.rho, self.height,
                                          self.settings["resolution"], R_KIND[kind], self.arm)
            self._rank[kind] = np.argsort(self.branch_order[kind])
        return self._cache[kind]

    def __post_init__(self) -> None:
        self._cache: dict[str, _Cells] = {}
        self._rank: dict[str, np.ndarray] = {}


@dataclass
class _Cells:
    """Per grid cell and branch: bilinear coefficients of the angles (unwrapped to the
    cell's first corner), whether all four corners hold the branch (`full`), whether the
    interpolation stays within 0.5 mm and 0.5° of the targets at the cell's centre and edge
    midpoints (`trusted`), and for each quarter of the cell the nearest corner that holds
    the branch (0..3 as 2 di + dj, -1 for none).

    Whether a cell is trusted costs the arm's forward kinematics at five points of each of
    its branches, most of a kind's preparation if done for every cell, while a process
    looks up few of them (the cells at its dishes' distances and heights): it is worked out
    for a cell when a lookup first needs it, all its branches at once, with the same
    arithmetic row by row."""

    table: np.ndarray
    coefficients: np.ndarray  # (n_rho - 1, n_h - 1, K, 4, n)
    full: np.ndarray  # (n_rho - 1, n_h - 1, K)
    nearest: np.ndarray  # (n_rho - 1, n_h - 1, 2, 2, K)
    rho: np.ndarray
    height: np.ndarray
    step: float
    R_target: np.ndarray
    arm: kin.ArmKinematics

    def __post_init__(self) -> None:
        self._trusted = np.zeros_like(self.full)
        self._known = np.zeros(self.full.shape[:2], dtype=bool)

    @classmethod
    def of(cls, configs: np.ndarray, rho: np.ndarray, height: np.ndarray, step: float,
           R_target: np.ndarray, arm: kin.ArmKinematics) -> "_Cells":
        present = ~np.isnan(configs[..., 0])
        table = np.nan_to_num(configs.astype(float))
        c00 = table[:-1, :-1]
        c10 = c00 + kin.wrap(table[1:, :-1] - c00)
        c01 = c00 + kin.wrap(table[:-1, 1:] - c00)
        c11 = c00 + kin.wrap(table[1:, 1:] - c00)
        coefficients = np.stack([c00, c10 - c00, c01 - c00, c11 - c10 - c01 + c00], axis=-2)
        corners = np.stack([present[:-1, :-1], present[:-1, 1:], present[1:, :-1],
                            present[1:, 1:]], axis=-1)  # (..., K, 4), index 2 di + dj
        full = corners.all(axis=-1)
        # Nearest corner holding the branch, for each quarter (qi, qj) of the cell.
        nearest = np.full((*full.shape[:2], 2, 2, full.shape[2]), -1, dtype=np.int64)
        for qi in (0, 1):
            for qj in (0, 1):
                order = sorted(range(4), key=lambda n, qi=qi, qj=qj: (
                    abs(n // 2 - qi) + abs(n % 2 - qj), n))
                pick = np.full(full.shape, -1, dtype=np.int64)
                for n in reversed(order):
                    pick = np.where(corners[..., n], n, pick)
                nearest[:, :, qi, qj] = pick
        return cls(table=table, coefficients=coefficients, full=full, nearest=nearest,
                   rho=rho, height=height, step=step, R_target=R_target, arm=arm)

    def trusted(self, i: np.ndarray, j: np.ndarray) -> np.ndarray:
        """Whether each branch of the cells (i, j) (m,) is trusted: (m, K)."""
        fresh = ~self._known[i, j]
        if fresh.any():
            self._work_out(np.unique(np.stack([i[fresh], j[fresh]], axis=1), axis=0))
        return self._trusted[i, j]

    def _work_out(self, cells: np.ndarray) -> None:
        """Works out the trust of every branch of the cells (c, 2)."""
        self._known[cells[:, 0], cells[:, 1]] = True
        full = np.zeros_like(self.full)
        full[cells[:, 0], cells[:, 1]] = self.full[cells[:, 0], cells[:, 1]]
        rows = np.argwhere(full)
        if not len(rows):
            return
        worst = np.zeros(len(rows))
        c = self.coefficients[full]
        for fu, fv in ((0.5, 0.5), (0.5, 0.0), (0.0, 0.5), (1.0, 0.5), (0.5, 1.0)):
            q = c[:, 0] + c[:, 1] * fu + c[:, 2] * fv + c[:, 3] * fu * fv
            p_target = np.stack([self.rho[rows[:, 0]] + fu * self.step, np.zeros(len(rows)),
                                 self.height[rows[:, 1]] + fv * self.step], axis=1)
            R, p = self.arm.forward(q)
            angle, distance = kin.pose_error(R, p, self.R_target, p_target)
            worst = np.maximum(worst, np.maximum(distance / TRUST_POSITION,
                                                 angle / TRUST_ANGLE))
        self._trusted[full] = worst < 1.0


def place(q: np.ndarray, bearing: np.ndarray | float, wrist_turn: np.ndarray | float, *,
          robot: Robot) -> np.ndarray:
    """Configurations (..., n) of `robot`'s arm at bearing 0, turn 0 moved to `bearing` and
    `wrist_turn`.

    The first joint turns the arm about A's z axis and the last the gripper about the
    approach axis, each about +z or -z (`ArmKinematics.turn_signs`: a joint about -z turns
    by minus the bearing or the wrist turn; `ArmKinematics` checks both axes); the results are
    wrapped into [-π, π), or a turn from there into the joints' limits. A joint that cannot
    turn that far leaves the configuration outside its limits (`ArmKinematics.within_limits`).
    """
    arm = kin.arm_kinematics(robot)
    first, last = arm.turn_signs
    q = np.array(q, dtype=float)
    # Exact for a joint about +z (times 1.0): the UR5e's and the Panda's are.
    q[..., 0] = q[..., 0] + first * np.asarray(bearing)
    q[..., -1] = q[..., -1] + last * np.asarray(wrist_turn)
    return arm.into_limits(q)
