"""Building the arm's inverse reachability map with Drake IK (the map and its queries are in
s3o_drake/feasibility/reachability/map.py).

At each node of a (ρ, h) grid the arm's inverse kinematics (`kinematics.ArmKinematics`: for
the UR family all eight closed-form shoulder/wrist/elbow branches, for another arm damped
least squares from its default seeds) seeds `InverseKinematics` with the grasp-frame
constraints and a self-collision clearance of 1 cm (SNOPT, capped iterations); each
verified solution is kept in its branch's slot. `build_map` solves the rows of the grid of a
robot's map in worker processes, deterministically, for `s3o build reachability`.
"""

import datetime
import time
from collections.abc import Sequence

import numpy as np

from s3o_drake.feasibility import kinematics as kin
from s3o_drake.feasibility.grasps import GRASP_KINDS
from s3o_drake.feasibility.ik import (
    ANGLE_TOLERANCE,
    DISTANCE_MARGIN,
    MIN_DISTANCE,
    POSITION_TOLERANCE,
    solve_or_none,
)
from s3o_drake.feasibility.reachability.map import (
    FORMAT_VERSION,
    R_KIND,
    ReachabilityMap,
    grid_axis,
    robot_model_sha256,
)
from s3o_drake.world.robot import Robot
from s3o_drake.world.worker_processes import drake_parallelism, worker_pool

#: Grid ranges (m): ρ from A's z axis, h above A's origin. A at 0.75 m above the floor; the
#: heights cover grasp points on table tops from about 0.55 m to 1.20 m, the distances the
#: arm's reach with a side grasp (about 1.15 m) and more.
RHO_RANGE = (0.0, 1.20)
HEIGHT_RANGE = (-0.20, 0.45)
RESOLUTION = 0.01
#: SNOPT's major iteration cap of the build (the seeds are exact solutions; only those in
#: self-collision need iterations). Clearance and tolerances are the reference IK's.
MAX_MAJOR_ITERATIONS = 30


def max_per_node(robot: Robot) -> int:
    """At most this many configurations per node of `robot`'s map: one per branch (closed
    form) or seed."""
    return kin.arm_kinematics(robot).branches


class _NodeSolver:
    """Drake IK on a plant with the robot alone, base at the origin (one per worker)."""

    def __init__(self, min_distance: float, max_major_iterations: int, robot: Robot):
        from pydrake.multibody.inverse_kinematics import InverseKinematics
        from pydrake.planning import RobotDiagramBuilder, SceneGraphCollisionChecker
        from pydrake.solvers import SnoptSolver, SolverOptions

        self.robot = robot
        self.arm = kin.arm_kinematics(robot)
        builder = RobotDiagramBuilder(time_step=0.0)
        self.placed = robot.add_model_instances(builder.parser())
        builder.plant().Finalize()
        self.diagram = builder.Build()
        self.plant = self.diagram.plant()
        self.context = self.diagram.CreateDefaultContext()
        self.plant_context = self.plant.GetMyMutableContextFromRoot(self.context)
        self.grasp_frame = self.placed.frame(robot.grasp_frame)
        self.p_WA = self.placed.frame(robot.arm_base_link).CalcPoseInWorld(
            self.plant_context).translation()
        # The plant's positions hold the robot's (`Robot.joints` order) at these indices; a
        # robot of parts has its mimic joints among the rest.
        self.indices = self.placed.position_indices()
        self.checker = SceneGraphCollisionChecker(
            model=self.diagram, robot_model_instances=list(self.placed.instances),
            edge_step_size=0.05,
            implicit_context_parallelism=drake_parallelism())
        self.checker.SetPaddingAllRobotRobotPairs(min_distance)
        self.min_distance = min_distance
        self.InverseKinematics = InverseKinematics
        self.solver = SnoptSolver()
        self.options = SolverOptions()
        self.options.SetOption(self.solver.solver_id(), "Major iterations limit",
                               int(max_major_iterations))

    def _q(self, arm: np.ndarray) -> np.ndarray:
        """The plant's positions with the base at the origin, the arm at `arm` and the
        gripper open (the robot's positions for a single-instance robot)."""
        q = np.concatenate([np.zeros(self.robot.num_base_joints), arm,
                            self.robot.gripper_open])
        return q if self.placed.is_single else self.placed.plant_positions(q)

    def solve(self, R_AG: np.ndarray, p_AG: np.ndarray, seeds: np.ndarray) -> list[np.ndarray]:
        """Arm configurations found by IK from each seed (in seed order), verified."""
        from pydrake.math import RotationMatrix

        robot = self.robot
        ik = self.InverseKinematics(self.plant, self.plant_context, with_joint_limits=True)
        q = ik.q()
        prog = ik.get_mutable_prog()
        base = np.zeros(robot.num_base_joints)
        arm_indices = self.indices[robot.arm_positions]
        prog.AddBoundingBoxConstraint(base, base, q[self.indices[:robot.num_base_joints]])
        prog.AddBoundingBoxConstraint(robot.gripper_open, robot.gripper_open,
                                      q[self.indices[robot.gripper_positions]])
        # A robot of parts' other positions (mimic joints: IK knows no coupler
        # constraints) stay where the open gripper puts them.
        others = np.setdiff1d(np.arange(self.plant.num_positions()), self.indices)
        if others.size:
            q_open = self._q(self.robot.arm_stow)
            prog.AddBoundingBoxConstraint(q_open[others], q_open[others], q[others])
        p_WG = self.p_WA + p_AG
        ik.AddPositionConstraint(self.grasp_frame, np.zeros(3), self.plant.world_frame(),
                                 p_WG - POSITION_TOLERANCE, p_WG + POSITION_TOLERANCE)
        ik.AddOrientationConstraint(self.plant.world_frame(), RotationMatrix(R_AG),
                                    self.grasp_frame, RotationMatrix(), ANGLE_TOLERANCE)
        ik.AddMinimumDistanceLowerBoundConstraint(self.min_distance + DISTANCE_MARGIN)
        found = []
        for seed in seeds:
            result = solve_or_none(self.solver, prog, self._q(seed), self.options)
            if result is None or not result.is_success():
                found.append(None)
                continue
            arm = result.GetSolution(q)[arm_indices]
            R, p = self.arm.forward(arm)
            angle, distance = kin.pose_error(R, p, R_AG, p_AG)
            ok = (angle <= ANGLE_TOLERANCE + 1e-4 and distance <= POSITION_TOLERANCE + 1e-4
                  and self.arm.within_limits(arm)
                  and self.checker.CheckConfigCollisionFree(self._q(arm)))
            found.append(arm if ok else None)
        return found


def branch_of(arm: np.ndarray, *, robot: Robot) -> int:
    """The branch (slot) a configuration of `robot`'s arm belongs to: the nearest of the
    arm's inverse kinematics solutions at its pose."""
    kinematics = kin.arm_kinematics(robot)
    R, p = kinematics.forward(arm)
    solutions = kinematics.inverse(R[None], p[None])[0]
    gap = np.abs(kin.wrap(solutions - arm)).max(axis=1)
    return int(np.nanargmin(np.where(np.isnan(gap), np.inf, gap)))


def solve_node(solver: _NodeSolver, kind: str, rho: float, h: float) -> np.ndarray:
    """The configurations (K, n) of one node (NaN rows for branches without one)."""
    R_AG = R_KIND[kind]
    p_AG = np.array([rho, 0.0, h])
    arm = solver.arm
    slots = np.full((arm.branches, arm.joints), np.nan)
    seeds = arm.inverse(R_AG[None], p_AG[None])[0]
    exact = arm.exact(seeds[None], R_AG[None], p_AG[None])[0]
    branches = np.flatnonzero(exact)
    if branches.size == 0:
        return slots
    # Seeds already clear of self-collision first: IK confirms them at once; the others may
    # then be moved by IK into a branch that is already filled.
    free = [solver.checker.CheckConfigCollisionFree(solver._q(seeds[b])) for b in branches]
    branches = [b for _, b in sorted(zip([not f for f in free], branches, strict=True))]
    results = solver.solve(R_AG, p_AG, seeds[branches])
    for b, q in zip(branches, results, strict=True):
        if q is None:
            continue
        slot = b if np.abs(kin.wrap(q - seeds[b])).max() < 0.3 else branch_of(q, robot=solver.robot)
        if np.isnan(slots[slot, 0]):
            slots[slot] = kin.wrap(q)
    return slots


_worker: _NodeSolver | None = None


def _init_worker(min_distance: float, max_major_iterations: int, robot: Robot) -> None:
    global _worker
    _worker = _NodeSolver(min_distance, max_major_iterations, robot)


def _solve_row(task: tuple[str, float, Sequence[float]]) -> np.ndarray:
    kind, rho, heights = task
    assert _worker is not None
    return np.stack([solve_node(_worker, kind, rho, h) for h in heights])


def branch_preference(configs: np.ndarray, *, robot: Robot) -> np.ndarray:
    """Slots (branches) of `robot`'s map ordered by how high the elbow stands, on average
    over the nodes.

    An elbow held high stays clear of the table a dish stands on, so those branches are
    tried first and most queries need a single collision check.
    """
    arm = kin.arm_kinematics(robot)
    present = ~np.isnan(configs[..., 0])  # (..., K)
    elbow_z = arm.chain.frames(np.nan_to_num(configs))[arm.elbow_joint][..., 2, 3]
    total = np.where(present, elbow_z, 0.0).reshape(-1, configs.shape[-2]).sum(axis=0)
    count = present.reshape(-1, configs.shape[-2]).sum(axis=0)
    mean = np.where(count > 0, total / np.maximum(count, 1), -np.inf)
    return np.argsort(-mean, kind="stable")


def build_map(*, robot: Robot, resolution: float = RESOLUTION,
              rho_range: tuple[float, float] = RHO_RANGE,
              height_range: tuple[float, float] = HEIGHT_RANGE, workers: int = 2,
              kinds: Sequence[str] = GRASP_KINDS, progress: bool = True,
              max_major_iterations: int = MAX_MAJOR_ITERATIONS,
              min_distance: float = MIN_DISTANCE) -> ReachabilityMap:
    """Solves every node of `robot`'s map with Drake IK (in `workers` processes) and returns
    the map.

    Deterministic: every node is solved from its own closed-form seeds, whichever worker
    takes it.
    """
    from tqdm import tqdm

    start = time.perf_counter()
    rho = grid_axis(*rho_range, resolution)
    height = grid_axis(*height_range, resolution)
    tasks = [(kind, float(r), [float(x) for x in height]) for kind in kinds for r in rho]
    rows: list[np.ndarray] = []
    bar = tqdm(total=len(tasks) * len(height), desc="reachability map", unit="node",
               disable=not progress, smoothing=0.05)
    init_args = (min_distance, max_major_iterations, robot)
    if workers <= 1:
        _init_worker(*init_args)
        for task in tasks:
            rows.append(_solve_row(task))
            bar.update(len(height))
    else:
        with worker_pool(workers, preload=(__name__,), initializer=_init_worker,
                         initargs=init_args) as pool:
            for row in pool.imap(_solve_row, tasks, chunksize=1):
                rows.append(row)
                bar.update(len(height))
    bar.close()
    configs = {}
    order = {}
    for i, kind in enumerate(kinds):
        table = np.stack(rows[i * len(rho):(i + 1) * len(rho)]).astype(np.float32)
        configs[kind] = table
        order[kind] = branch_preference(table.astype(float), robot=robot)
    import importlib.metadata

    per_node = max_per_node(robot)
    settings = {
        "format": FORMAT_VERSION,
        "kinds": list(kinds),
        "rho_range": [float(rho[0]), float(rho[-1])],
        "height_range": [float(height[0]), float(height[-1])],
        "resolution": float(resolution),
        "max_per_node": per_node,
        "seeds": (f"closed-form solutions of all {per_node} branches at the node"
                  if kin.arm_kinematics(robot).family == "ur" else
                  f"damped least squares from {per_node} seeds (stow first) at the node"),
        "frame": f"grasp point relative to the arm base A ({robot.arm_base_link}): rho "
                 "horizontal, "
                 "height vertical, bearing 0, wrist turn 0",
        "min_distance": min_distance,
        "distance_margin": DISTANCE_MARGIN,
        "position_tolerance": POSITION_TOLERANCE,
        "angle_tolerance": ANGLE_TOLERANCE,
        "max_major_iterations": int(max_major_iterations),
        "robot_urdf_sha256": robot_model_sha256(robot),
        "drake_version": importlib.metadata.version("drake"),
        "built": datetime.date.today().isoformat(),
        "build_seconds": round(time.perf_counter() - start, 1),
        "workers": int(workers),
        "nodes": {k: int((~np.isnan(configs[k][..., 0])).any(axis=-1).sum()) for k in kinds},
        "configurations": {k: int((~np.isnan(configs[k][..., 0])).sum()) for k in kinds},
    }
    return ReachabilityMap(rho=rho, height=height, configs=configs, branch_order=order,
                           settings=settings, robot=robot)
