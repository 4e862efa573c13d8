"""Collision-free arm paths (OMPL's RRT-Connect on Drake's collision checker) and their timing.

`plan_arm_path` moves the arm's joints (`Robot.arm_positions` of the robot's positions) from
one configuration to another with the base and the fingers held where they are. Drake has no
sampling-based planner, so OMPL's RRT-Connect searches the arm's joint box (the plant's
position limits); Drake's `SceneGraphCollisionChecker` (the scene's `RobotChecker`, asked in
the robot's positions) answers its questions: a state is valid when
`CheckConfigCollisionFree` holds for all the robot's positions, a motion when
`CheckEdgeCollisionFree` does (straight line in the robot's positions, stepped at the checker's
edge step, 0.05 rad here), so the planner and the final verification use the very same test.
The found path is shortcut (OMPL's `PathSimplifier`, by step counts rather than a time budget
so that the result does not depend on the machine's speed) and every edge of what is
returned is checked again with the Drake checker.

`time_parameterize` times a path with Drake's TOPPRA (`Toppra` with `AddJointVelocityLimit`
and `AddJointAccelerationLimit`): the fastest motion along the path, from rest to rest, within
the joint limits. The limits are the robot model's (`joint_limits`, read from the plant: the
UR5e's 180 deg/s and 5 rad/s², whose sources the URDF states). Which path: at the waypoints
where an RRT path turns, a cubic B-spline rounds the corners (`rounded_corners`), so that the
arm need not stop there, which is what TOPPRA gains over stopping at each corner. The rounded
curve leaves the checked straight edges, so it is checked itself, densely
(`curve_collision_free`: samples at most the checker's edge step apart, `CheckEdgeCollisionFree`
between consecutive ones), from the largest rounding to the smallest; when every rounding
collides, the motion follows the straight edges and stops at each waypoint. TOPPRA enforces
the limits at its grid points only, so the timed motion is sampled between them and slowed
down uniformly when a sample exceeds a limit.

Determinism: OMPL draws every sampler's seed from one process-wide seed generator;
`ompl.util.RNG.setSeed` re-seeds it (it logs an error that determinism is lost after the
first draw, but re-seeding before each plan does give the same seeds to the planner's and the
simplifier's new generators, which is what a plan uses). Planning itself is not timed out
mid-way when a solution exists within `time_limit`, so the same seed gives the same path.
"""

import itertools
import logging
import math
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np
from ompl import base as ob
from ompl import geometric as og
from ompl import util as ou
from pydrake.math import BsplineBasis
from pydrake.multibody.optimization import CalcGridPointsOptions, Toppra
from pydrake.multibody.plant import MultibodyPlant
from pydrake.trajectories import (
    BsplineTrajectory,
    PathParameterizedTrajectory,
    PiecewisePolynomial,
    Trajectory,
)

from s3o_drake.feasibility.robot_checker import RobotChecker
from s3o_drake.world.robot import PositionMap, Robot

#: RRT-Connect's extension step (rad, joint-space distance). OMPL's default (a fifth of the
#: box's diagonal, ~6 rad for joints that turn ±2π) makes long edges that mostly collide
#: near tables; a 1 rad step keeps the trees growing.
RRT_RANGE = 1.0
#: Shortcutting effort, in attempts (not seconds, for determinism).
SHORTCUT_STEPS = 100
SIMPLIFY_ROUNDS = 3
#: TOPPRA's grid (`Toppra.CalcGridPoints`; the path parameter is joint-space arc length, rad):
#: points are added until the estimated interpolation error max|q''| Δs² / 2 is below
#: GRID_MAX_ERROR (rad; Drake's default 1e-3 let the acceleration overshoot its limit by up
#: to 20 % between grid points on rounded corners) and no interval is longer than
#: GRID_MAX_SEGMENT; at least GRID_MIN_POINTS. Where the path bends the error bound sets the
#: grid; on a straight edge (q'' = 0) the trapezoid comes out on few points (a 4 rad edge:
#: 1.9018 s on 20 points, 1.9016 s exact), and Drake's default 0.05 rad segments only cost
#: time (a fifth of a pickup's planning, the same durations to 10 ms in 30 pickups).
GRID_MAX_ERROR = 1e-4
GRID_MAX_SEGMENT = 0.5
GRID_MIN_POINTS = 20
GRID_MAX_ITERATIONS = 100
#: Corner roundings tried, largest first (`rounded_corners`: the fraction of the shorter
#: edge at a corner where the curve leaves the straight line).
CORNER_ROUNDINGS = (0.4, 0.15, 0.05)
#: Samples per TOPPRA grid interval when checking the timed motion against the limits.
SAMPLES_PER_INTERVAL = 4
#: Duration of a motion that moves nothing (s).
STILL_DURATION = 1e-3


def arm_bounds(checker: RobotChecker, *, robot: Robot) -> tuple[np.ndarray, np.ndarray]:
    """`robot`'s arm joint limits (rad), lower and upper, from the checker's plant."""
    lower, upper = checker.position_limits()
    arm = robot.arm_positions
    return lower[arm].copy(), upper[arm].copy()


@contextmanager
def _quiet_ompl() -> Iterator[None]:
    """OMPL's log at warnings and above while planning (its info lines come per query)."""
    level = ou.getLogLevel()
    ou.setLogLevel(ou.LOG_WARN)
    try:
        yield
    finally:
        ou.setLogLevel(level)


def _seed_ompl(seed: int) -> None:
    """Re-seeds OMPL's seed generator (see the module docstring), without its error line."""
    level = ou.getLogLevel()
    ou.setLogLevel(ou.LOG_NONE)
    try:
        # OMPL treats seed 0 as "pick one at random"; keep every user seed positive.
        ou.RNG.setSeed(int(seed) % (2**31 - 1) + 1)
    finally:
        ou.setLogLevel(level)


class _EdgeValidator(ob.MotionValidator):
    """OMPL motion validity = Drake's `CheckEdgeCollisionFree` on all the robot's positions."""

    def __init__(self, si: ob.SpaceInformation, to_q, checker: RobotChecker):
        super().__init__(si)
        self._to_q = to_q
        self._checker = checker

    def checkMotion(self, s1, s2, *_) -> bool:
        return bool(self._checker.CheckEdgeCollisionFree(self._to_q(s1), self._to_q(s2)))


def _validate_endpoints(checker: RobotChecker, q_start: np.ndarray,
                        q_goal: np.ndarray, robot: Robot) -> None:
    lower, upper = arm_bounds(checker, robot=robot)
    arm, n = robot.arm_positions, robot.num_positions
    for name, q in (("q_start", q_start), ("q_goal", q_goal)):
        if q.shape != (n,):
            raise ValueError(f"{name}: expected {n} positions, got shape {q.shape}")
        if np.any(q[arm] < lower - 1e-9) or np.any(q[arm] > upper + 1e-9):
            raise ValueError(f"{name}: arm joints {q[arm]} outside the limits")
        if not checker.CheckConfigCollisionFree(q):
            raise ValueError(f"{name} is in collision")


def edges_free(checker: RobotChecker, path: np.ndarray) -> bool:
    """Whether every straight edge of `path` (n, the robot's positions) is collision-free by
    `checker`."""
    return all(checker.CheckEdgeCollisionFree(a, b)
               for a, b in itertools.pairwise(path))


def plan_arm_path(checker: RobotChecker, q_start: np.ndarray, q_goal: np.ndarray,
                  *, robot: Robot, time_limit: float = 5.0, seed: int = 0,
                  max_step: float = RRT_RANGE, turned_goal: bool = False) -> np.ndarray | None:
    """A collision-free path (n, robot.num_positions) from q_start to q_goal moving only the
    arm of `robot` (the checker's robot), or None.

    q_start and q_goal are the robot's positions; the path holds base and fingers at
    q_start's values (q_goal's are ignored there) and its consecutive waypoints are joined
    by straight lines, each verified with `checker.CheckEdgeCollisionFree`. The straight
    line is returned as is when it is free (no planner). Otherwise RRT-Connect searches for
    up to `time_limit` seconds (None when it finds nothing), with OMPL's RNG seeded from
    `seed`. Raises ValueError when the start or the goal collides or is out of the limits.

    `turned_goal`: the goal is a pose, whatever the angles that reach it (a stow, which
    nothing follows). The arm's first joint swings the whole arm about the vertical, and
    where its limits span more than a turn it reaches the same pose a whole turn away: an
    arm swung round past an obstacle at its side may be stowed only the other way round.
    Where no path reaches the goal's own angles, the goal a turn away is searched for too
    (within the limits, the one nearer the start first); the path then ends there.
    """
    q_start = np.asarray(q_start, dtype=float).reshape(-1)
    q_goal = np.asarray(q_goal, dtype=float).reshape(-1).copy()
    if q_goal.shape == q_start.shape == (robot.num_positions,):
        base, gripper = slice(0, robot.num_base_joints), robot.gripper_positions
        q_goal[base], q_goal[gripper] = q_start[base], q_start[gripper]
    path = _plan_arm_path(checker, q_start, q_goal, robot=robot, time_limit=time_limit,
                          seed=seed, max_step=max_step)
    if path is not None or not turned_goal:
        return path
    first = np.arange(robot.num_positions)[robot.arm_positions][0]
    lower, upper = arm_bounds(checker, robot=robot)
    turned = [q_goal[first] + turn for turn in (-2 * math.pi, 2 * math.pi)
              if lower[0] - 1e-9 <= q_goal[first] + turn <= upper[0] + 1e-9]
    for angle in sorted(turned, key=lambda a: abs(a - q_start[first])):
        q_turned = q_goal.copy()
        q_turned[first] = angle
        path = _plan_arm_path(checker, q_start, q_turned, robot=robot,
                              time_limit=time_limit, seed=seed, max_step=max_step)
        if path is not None:
            return path
    return None


def _plan_arm_path(checker: RobotChecker, q_start: np.ndarray, q_goal: np.ndarray, *,
                   robot: Robot, time_limit: float, seed: int,
                   max_step: float) -> np.ndarray | None:
    """`plan_arm_path` to the goal's own angles."""
    arm, num_arm = robot.arm_positions, robot.num_arm_joints
    _validate_endpoints(checker, q_start, q_goal, robot)
    if checker.CheckEdgeCollisionFree(q_start, q_goal):
        return np.stack([q_start, q_goal])

    template = q_start.copy()

    def to_q(state) -> np.ndarray:
        q = template.copy()
        q[arm] = [state[i] for i in range(num_arm)]
        return q

    _seed_ompl(seed)
    lower, upper = arm_bounds(checker, robot=robot)
    space = ob.RealVectorStateSpace(num_arm)
    bounds = ob.RealVectorBounds(num_arm)
    for i in range(num_arm):
        bounds.setLow(i, float(lower[i]))
        bounds.setHigh(i, float(upper[i]))
    space.setBounds(bounds)
    si = ob.SpaceInformation(space)
    si.setStateValidityChecker(lambda state: bool(checker.CheckConfigCollisionFree(to_q(state))))
    si.setMotionValidator(_EdgeValidator(si, to_q, checker))
    si.setup()
    start, goal = si.allocState(), si.allocState()
    for i in range(num_arm):
        start[i], goal[i] = float(q_start[arm][i]), float(q_goal[arm][i])
    problem = ob.ProblemDefinition(si)
    problem.setStartAndGoalStates(start, goal)
    planner = og.RRTConnect(si)
    planner.setRange(max_step)
    planner.setProblemDefinition(problem)
    with _quiet_ompl():
        planner.setup()
        planner.solve(float(time_limit))
        if not problem.hasExactSolution():
            return None
        ompl_path = problem.getSolutionPath()
        raw = np.stack([to_q(s) for s in ompl_path.getStates()])
        simplifier = og.PathSimplifier(si)
        for _ in range(SIMPLIFY_ROUNDS):
            changed = simplifier.reduceVertices(ompl_path, SHORTCUT_STEPS)
            changed |= simplifier.partialShortcutPath(ompl_path, SHORTCUT_STEPS)
            changed |= simplifier.collapseCloseVertices(ompl_path)
            if not changed:
                break
    path = np.stack([to_q(s) for s in ompl_path.getStates()])
    path = _greedy_shortcut(checker, path)
    path[0], path[-1] = q_start, q_goal  # exact endpoints, not float round trips
    for candidate in (path, raw):
        if edges_free(checker, candidate):
            return candidate
    return None


def _greedy_shortcut(checker: RobotChecker, path: np.ndarray) -> np.ndarray:
    """From each kept waypoint, jump to the farthest later one the straight line reaches.

    Deterministic and cheap on the few waypoints left after OMPL's shortcutting; it removes
    the detours that random shortcutting happened to miss.
    """
    keep = [0]
    while keep[-1] < len(path) - 1:
        i = keep[-1]
        j = len(path) - 1
        while j > i + 1 and not checker.CheckEdgeCollisionFree(path[i], path[j]):
            j -= 1
        keep.append(j)
    return path[keep]


# ------------------------------------------------------------------------------ timing


@dataclass(frozen=True)
class TimedPath:
    """A timed motion along a checked path: `trajectory` gives the positions over
    [0, duration], at rest at both ends; `smoothed` says whether it rounds the path's corners
    (on a curve that was checked densely) or stops at every waypoint."""

    trajectory: PathParameterizedTrajectory
    smoothed: bool

    @property
    def duration(self) -> float:
        return self.trajectory.end_time() - self.trajectory.start_time()


def joint_limits(plant: MultibodyPlant,
                 positions: PositionMap | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The model's speed and acceleration limits of each position (rad/s and rad/s², or m/s
    and m/s²; +inf where the model gives none), from the robot's URDF via the plant: of the
    plant's positions, or of the robot's among them (`positions`)."""
    v, a = plant.GetVelocityUpperLimits(), plant.GetAccelerationUpperLimits()
    if positions is not None:
        v, a = positions.to_robot(v), positions.to_robot(a)
    return v.copy(), a.copy()


#: Waypoints nearer than this (rad, in the positions' space) are one. TOPPRA times a
#: straight edge on a grid of at least GRID_MIN_POINTS points, and the time scaling it
#: returns is a trajectory whose breaks Drake requires 1e-10 s apart (a failed requirement
#: ends the process): an edge 1e-8 rad long (two planner waypoints that differ by rounding)
#: broke that and ended the time benchmark. At 1e-5 rad the shortest edge takes about 2 ms
#: at the arm's accelerations, its grid steps are microseconds, and the merged waypoint moves
#: the gripper by at most 10 µm.
MIN_STEP = 1e-5


def _distinct(path: np.ndarray) -> np.ndarray:
    """The waypoints without consecutive repeats (closer than MIN_STEP); the first and the
    last waypoint are kept exactly (a repeat of the last replaces the one before it)."""
    keep = [0]
    for i in range(1, len(path)):
        if np.linalg.norm(path[i] - path[keep[-1]]) > MIN_STEP:
            keep.append(i)
        elif i == len(path) - 1 and len(keep) > 1:
            keep[-1] = i
    return path[keep]


def _arc_length(points: np.ndarray) -> np.ndarray:
    """Cumulative straight-line length along `points` (rad, in the positions' space)."""
    return np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])


def rounded_corners(path: np.ndarray, rounding: float) -> BsplineTrajectory:
    """A cubic B-spline along the waypoints `path` (n >= 3 distinct, (n, d)) that rounds
    every inner corner and follows the straight edges elsewhere.

    Control points: the ends, and each inner waypoint W with one point on either edge at
    distance d = `rounding` x (the shorter of the two edges) from W (0 < rounding < 0.5), so
    every control point lies on the path. Where four consecutive control points are collinear
    (between two inner corners) the curve follows the edge exactly; elsewhere it stays in the
    triangle of four consecutive ones, within d of the path near a corner. The curve starts at
    path[0] and ends at path[-1] (clamped knots) and is parameterised nearly by arc length
    (averaging knots over the control polygon's chord lengths, de Boor's choice), which suits
    TOPPRA's grid.
    """
    if not 0.0 < rounding < 0.5:
        raise ValueError(f"rounding: expected a fraction in (0, 0.5), got {rounding}")
    if len(path) < 3:
        raise ValueError(f"path: expected at least 3 waypoints, got {len(path)}")
    points = [path[0]]
    for previous, corner, following in zip(path, path[1:], path[2:], strict=False):
        e_in, e_out = corner - previous, following - corner
        l_in, l_out = float(np.linalg.norm(e_in)), float(np.linalg.norm(e_out))
        d = rounding * min(l_in, l_out)
        points += [corner - d / l_in * e_in, corner, corner + d / l_out * e_out]
    points.append(path[-1])
    points = np.array(points)
    order = 4
    chord = _arc_length(points)
    interior = [float(np.mean(chord[j:j + order - 1])) for j in range(1, len(points) - order + 1)]
    knots = [0.0] * order + interior + [float(chord[-1])] * order
    return BsplineTrajectory(BsplineBasis(order, knots), [p.reshape(-1, 1) for p in points])


def curve_collision_free(checker: RobotChecker, curve: Trajectory) -> bool:
    """Whether `curve` (a path over the robot's positions) is collision-free by `checker`.

    The curve is sampled so that consecutive samples are at most the checker's edge step
    apart (by the checker's own distance), and `CheckEdgeCollisionFree` checks the straight
    edge between each pair: the same resolution as every straight edge the planner checks.
    """
    step = checker.edge_step_size()
    start, end = curve.start_time(), curve.end_time()
    params = list(np.linspace(start, end, max(2, math.ceil((end - start) / step) + 1)))
    samples = list(curve.vector_values(params).T)
    i = 0
    while i < len(params) - 1:
        if checker.ComputeConfigurationDistance(samples[i], samples[i + 1]) > step:
            middle = 0.5 * (params[i] + params[i + 1])
            params.insert(i + 1, middle)
            samples.insert(i + 1, curve.value(middle).ravel())
        else:
            i += 1
    return all(checker.CheckEdgeCollisionFree(a, b) for a, b in itertools.pairwise(samples))


@contextmanager
def _quiet_drake() -> Iterator[None]:
    """Drake's log without its error line when TOPPRA finds no parameterisation (the caller
    falls back and says so in its result)."""
    logger = logging.getLogger("drake")
    level = logger.level
    logger.setLevel(logging.CRITICAL)
    try:
        yield
    finally:
        logger.setLevel(level)


def _grid_options() -> CalcGridPointsOptions:
    options = CalcGridPointsOptions()
    options.max_err = GRID_MAX_ERROR
    options.max_seg_length = GRID_MAX_SEGMENT
    options.min_points = GRID_MIN_POINTS
    options.max_iter = GRID_MAX_ITERATIONS
    return options


def _peak_ratio(trajectory: PathParameterizedTrajectory, times: np.ndarray,
                limits: np.ndarray, derivative: int) -> float:
    """The largest |d^k q_j/dt^k| / limit_j over the sample `times` (0 for no limit)."""
    values = np.abs(trajectory.MakeDerivative(derivative).vector_values(times))
    finite = np.isfinite(limits)
    return float(np.max(values[finite] / limits[finite, None], initial=0.0))


def _lifted(curve: Trajectory, positions: PositionMap | None) -> Trajectory:
    """`curve` over the robot's positions as a curve over the plant's (TOPPRA takes a path
    over all of the plant's positions), the same function of s: the lift is affine, so a
    B-spline's is the B-spline of its lifted control points and a first-order hold's the
    hold of its lifted breakpoints (the two kinds timed here)."""
    if positions is None or positions.is_identity:
        return curve
    if isinstance(curve, BsplineTrajectory):
        return BsplineTrajectory(curve.basis(), [positions.to_plant(p.ravel()).reshape(-1, 1)
                                                 for p in curve.control_points()])
    if isinstance(curve, PiecewisePolynomial) and curve.getSegmentPolynomialDegree(0) <= 1:
        breaks = curve.get_segment_times()
        return PiecewisePolynomial.FirstOrderHold(
            breaks, positions.to_plant(curve.vector_values(breaks).T).T)
    raise TypeError(f"cannot lift a {type(curve).__name__} to the plant's positions")


def time_optimal(curve: Trajectory, plant: MultibodyPlant, max_velocity: np.ndarray,
                 max_acceleration: np.ndarray, positions: PositionMap | None = None,
                 ) -> PathParameterizedTrajectory | None:
    """The fastest motion along `curve` from rest to rest within the joint limits (Drake's
    TOPPRA), or None when TOPPRA finds none.

    `curve` is a path q(s) over the plant's positions, or over the robot's among them
    (`positions`; the limits are then the robot's, and TOPPRA times the curve's lift with
    the lifted limits: a mimic joint's repeat its leader's, so the timing is the robot
    curve's); the result is q(s(t)) with s(t) from
    `Toppra.SolvePathParameterization` (ṡ = 0 at both ends), starting at t = 0. TOPPRA
    enforces the limits at its grid points only; between them the acceleration can exceed
    them by a few per cent where the path bends. The result is therefore sampled
    (`SAMPLES_PER_INTERVAL` per grid interval) and, if any sample exceeds a limit, slowed
    down uniformly in time by the smallest factor that brings every sample within (speeds
    scale with 1/k, accelerations with 1/k²).
    """
    grid = Toppra.CalcGridPoints(curve, _grid_options())
    # Toppra keeps a reference to its path, not a copy: the lift must outlive it.
    lifted = _lifted(curve, positions)
    toppra = Toppra(lifted, plant, grid)
    v, a = max_velocity, max_acceleration
    if positions is not None:
        v, a = positions.rate_limits_to_plant(v), positions.rate_limits_to_plant(a)
    toppra.AddJointVelocityLimit(-v, v)
    toppra.AddJointAccelerationLimit(-a, a)
    with _quiet_drake():
        time_scaling = toppra.SolvePathParameterization()
    if time_scaling is None:
        return None
    time_scaling.shiftRight(-time_scaling.start_time())
    trajectory = PathParameterizedTrajectory(curve, time_scaling)
    breaks = np.asarray(time_scaling.get_segment_times())
    fractions = np.arange(SAMPLES_PER_INTERVAL) / SAMPLES_PER_INTERVAL
    times = np.append((breaks[:-1, None] + np.diff(breaks)[:, None] * fractions).ravel(),
                      breaks[-1])
    slowdown = max(1.0, _peak_ratio(trajectory, times, max_velocity, 1),
                   math.sqrt(_peak_ratio(trajectory, times, max_acceleration, 2)))
    if slowdown > 1.0:
        time_scaling.ScaleTime(slowdown)
        trajectory = PathParameterizedTrajectory(curve, time_scaling)
    return trajectory


def _with_stops(points: np.ndarray, plant: MultibodyPlant, max_velocity: np.ndarray,
                max_acceleration: np.ndarray,
                positions: PositionMap | None = None) -> PathParameterizedTrajectory:
    """The time-optimal rest-to-rest motion along each straight edge in turn: the path is the
    polyline itself, parameterised by arc length, and the time scaling stops at each corner."""
    length = _arc_length(points)
    path = PiecewisePolynomial.FirstOrderHold(length, points.T)
    time_scaling = None
    for i in range(len(points) - 1):
        edge = PiecewisePolynomial.FirstOrderHold(length[i:i + 2], points[i:i + 2].T)
        timed = time_optimal(edge, plant, max_velocity, max_acceleration, positions)
        if timed is None:
            raise RuntimeError(f"TOPPRA found no timing for the straight edge {i} of a path")
        piece = timed.time_scaling().Clone()
        if time_scaling is None:
            time_scaling = piece
        else:
            piece.shiftRight(time_scaling.end_time())
            time_scaling.ConcatenateInTime(piece)
    return PathParameterizedTrajectory(path, time_scaling)


def time_parameterize(path: np.ndarray, plant: MultibodyPlant, *,
                      max_velocity: np.ndarray | None = None,
                      max_acceleration: np.ndarray | None = None,
                      checker: RobotChecker | None = None,
                      roundings: tuple[float, ...] = CORNER_ROUNDINGS,
                      positions: PositionMap | None = None) -> TimedPath:
    """A timed motion through the waypoints `path` (n, plant's positions; or the robot's
    among them, `positions`), at rest at both ends, within the joint limits (default: the
    plant's, `joint_limits`).

    With a `checker` and at least three distinct waypoints, the corners are rounded
    (`rounded_corners`, the largest of `roundings` whose curve `checker` finds
    collision-free by `curve_collision_free`) and TOPPRA times the curve: no stop at the
    corners. Otherwise, when every rounding collides, or when the rounded motion is not the
    faster, the motion follows the straight edges, each timed by TOPPRA from rest to rest
    (straight edges are what the path planner checked). A path that does not move lasts
    `STILL_DURATION`.
    """
    path = np.asarray(path, dtype=float)
    dimension = plant.num_positions() if positions is None else positions.num_robot
    if path.ndim != 2 or len(path) == 0 or path.shape[1] != dimension:
        raise ValueError(f"path: expected (n, {dimension}) waypoints, got shape {path.shape}")
    v_default, a_default = joint_limits(plant, positions)
    v = v_default if max_velocity is None else np.broadcast_to(
        np.asarray(max_velocity, dtype=float), (dimension,)).copy()
    a = a_default if max_acceleration is None else np.broadcast_to(
        np.asarray(max_acceleration, dtype=float), (dimension,)).copy()
    points = _distinct(path)
    if len(points) == 1:
        still = PiecewisePolynomial.FirstOrderHold([0.0, 1.0], np.column_stack([path[0]] * 2))
        clock = PiecewisePolynomial.FirstOrderHold([0.0, STILL_DURATION], [[0.0, 1.0]])
        return TimedPath(PathParameterizedTrajectory(still, clock), smoothed=False)
    moving = np.ptp(points, axis=0) > 0
    for name, limits in (("max_velocity", v), ("max_acceleration", a)):
        bad = moving & ~(np.isfinite(limits) & (limits > 0))
        if bad.any():
            raise ValueError(f"{name}: positions {np.flatnonzero(bad).tolist()} move but have "
                             f"no positive finite limit ({limits[bad]})")
    stops = _with_stops(points, plant, v, a, positions)
    if checker is not None and len(points) >= 3:
        for rounding in roundings:
            curve = rounded_corners(points, rounding)
            if not curve_collision_free(checker, curve):
                continue
            trajectory = time_optimal(curve, plant, v, a, positions)
            if trajectory is None:
                continue
            # Rounder is faster except when a slowdown after TOPPRA ate the gain (1 motion in
            # 213 of the pickup benchmark, by 4 ms); a smaller rounding is nearer the stops.
            if trajectory.end_time() < stops.end_time():
                return TimedPath(trajectory, smoothed=True)
            break
    return TimedPath(stops, smoothed=False)


def shifted(trajectory: PathParameterizedTrajectory,
            offset: float) -> PathParameterizedTrajectory:
    """The same motion `offset` seconds later (for joining motions in time)."""
    time_scaling = trajectory.time_scaling().Clone()
    time_scaling.shiftRight(offset)
    return PathParameterizedTrajectory(trajectory.path().Clone(), time_scaling)
