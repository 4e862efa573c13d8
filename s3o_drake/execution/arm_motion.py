"""Collision-free arm paths (OMPL's RRT-Connect on Drake's collision checker) and their timing.

`plan_arm_path` moves the UR5e's six joints (positions 3..8 of the robot's 11) from one
configuration to another with the base and the fingers held where they are. Drake has no
sampling-based planner, so OMPL's RRT-Connect searches the arm's joint box (the plant's
position limits); Drake's `SceneGraphCollisionChecker` answers its questions: a state is
valid when `CheckConfigCollisionFree` holds for the full 11-vector, a motion when
`CheckEdgeCollisionFree` does (straight line in the 11 positions, stepped at the checker's
edge step, 0.05 rad here), so the planner and the final verification use the very same test.
The found path is shortcut (OMPL's `PathSimplifier`, by step counts rather than a time budget
so that the result does not depend on the machine's speed) and every edge of what is
returned is checked again with the Drake checker.

`time_parameterize` turns a piecewise-linear joint path into a timed trajectory that stays
exactly on that path: each segment is a rest-to-rest trapezoidal velocity profile, the
time-optimal one within per-joint speed and acceleration limits. Stopping at each waypoint
costs a little time but keeps the timed motion inside what the checker verified (a smoothing
spline through the waypoints would cut corners that nobody checked).

Determinism: OMPL draws every sampler's seed from one process-wide seed generator;
`ompl.util.RNG.setSeed` re-seeds it (it logs an error that determinism is lost after the
first draw, but re-seeding before each plan does give the same seeds to the planner's and the
simplifier's new generators, which is what a plan uses). Planning itself is not timed out
mid-way when a solution exists within `time_limit`, so the same seed gives the same path.
"""

import itertools
import math
from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np
from ompl import base as ob
from ompl import geometric as og
from ompl import util as ou
from pydrake.planning import SceneGraphCollisionChecker
from pydrake.trajectories import PiecewisePolynomial

from s3o_drake.robot import NUM_POSITIONS

#: The arm's joints among the robot's 11 positions.
ARM = slice(3, 9)
NUM_ARM = 6
#: RRT-Connect's extension step (rad, joint-space distance). OMPL's default (a fifth of the
#: box's diagonal, ~6 rad for joints that turn ±2π) makes long edges that mostly collide
#: near tables; a 1 rad step keeps the trees growing.
RRT_RANGE = 1.0
#: Shortcutting effort, in attempts (not seconds, for determinism).
SHORTCUT_STEPS = 100
SIMPLIFY_ROUNDS = 3
#: Default timing limits for the arm (rad/s, rad/s²): a third of the UR5e's joint speed
#: limit (π rad/s), a gentle acceleration: a waiter's pace, not a race.
ARM_MAX_VELOCITY = 1.0
ARM_MAX_ACCELERATION = 2.0


def arm_bounds(checker: SceneGraphCollisionChecker) -> tuple[np.ndarray, np.ndarray]:
    """The arm's joint limits (rad), lower and upper, from the checker's plant."""
    plant = checker.plant()
    return (plant.GetPositionLowerLimits()[ARM].copy(),
            plant.GetPositionUpperLimits()[ARM].copy())


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
    """OMPL motion validity = Drake's `CheckEdgeCollisionFree` on the full 11 positions."""

    def __init__(self, si: ob.SpaceInformation, to_q, checker: SceneGraphCollisionChecker):
        super().__init__(si)
        self._to_q = to_q
        self._checker = checker

    def checkMotion(self, s1, s2, *_) -> bool:
        return bool(self._checker.CheckEdgeCollisionFree(self._to_q(s1), self._to_q(s2)))


def _validate_endpoints(checker: SceneGraphCollisionChecker, q_start: np.ndarray,
                        q_goal: np.ndarray) -> None:
    lower, upper = arm_bounds(checker)
    for name, q in (("q_start", q_start), ("q_goal", q_goal)):
        if q.shape != (NUM_POSITIONS,):
            raise ValueError(f"{name}: expected {NUM_POSITIONS} positions, got shape {q.shape}")
        if np.any(q[ARM] < lower - 1e-9) or np.any(q[ARM] > upper + 1e-9):
            raise ValueError(f"{name}: arm joints {q[ARM]} outside the limits")
        if not checker.CheckConfigCollisionFree(q):
            raise ValueError(f"{name} is in collision")


def edges_free(checker: SceneGraphCollisionChecker, path: np.ndarray) -> bool:
    """Whether every straight edge of `path` (n, 11) is collision-free by `checker`."""
    return all(checker.CheckEdgeCollisionFree(a, b)
               for a, b in itertools.pairwise(path))


def plan_arm_path(checker: SceneGraphCollisionChecker, q_start: np.ndarray, q_goal: np.ndarray,
                  *, time_limit: float = 5.0, seed: int = 0,
                  max_step: float = RRT_RANGE) -> np.ndarray | None:
    """A collision-free path (n, 11) from q_start to q_goal moving only the arm, or None.

    q_start and q_goal are the robot's 11 positions; the path holds base and fingers at
    q_start's values (q_goal's are ignored there) and its consecutive waypoints are joined
    by straight lines, each verified with `checker.CheckEdgeCollisionFree`. The straight
    line is returned as is when it is free (no planner). Otherwise RRT-Connect searches for
    up to `time_limit` seconds (None when it finds nothing), with OMPL's RNG seeded from
    `seed`. Raises ValueError when the start or the goal collides or is out of the limits.
    """
    q_start = np.asarray(q_start, dtype=float).reshape(-1)
    q_goal = np.asarray(q_goal, dtype=float).reshape(-1).copy()
    if q_goal.shape == q_start.shape == (NUM_POSITIONS,):
        q_goal[:3], q_goal[9:] = q_start[:3], q_start[9:]
    _validate_endpoints(checker, q_start, q_goal)
    if checker.CheckEdgeCollisionFree(q_start, q_goal):
        return np.stack([q_start, q_goal])

    template = q_start.copy()

    def to_q(state) -> np.ndarray:
        q = template.copy()
        q[ARM] = [state[i] for i in range(NUM_ARM)]
        return q

    _seed_ompl(seed)
    lower, upper = arm_bounds(checker)
    space = ob.RealVectorStateSpace(NUM_ARM)
    bounds = ob.RealVectorBounds(NUM_ARM)
    for i in range(NUM_ARM):
        bounds.setLow(i, float(lower[i]))
        bounds.setHigh(i, float(upper[i]))
    space.setBounds(bounds)
    si = ob.SpaceInformation(space)
    si.setStateValidityChecker(lambda state: bool(checker.CheckConfigCollisionFree(to_q(state))))
    si.setMotionValidator(_EdgeValidator(si, to_q, checker))
    si.setup()
    start, goal = si.allocState(), si.allocState()
    for i in range(NUM_ARM):
        start[i], goal[i] = float(q_start[ARM][i]), float(q_goal[ARM][i])
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


def _greedy_shortcut(checker: SceneGraphCollisionChecker, path: np.ndarray) -> np.ndarray:
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


def _limits(value, dimension: int, name: str) -> np.ndarray:
    limits = np.broadcast_to(np.asarray(value, dtype=float), (dimension,)).copy()
    if np.any(limits <= 0) or not np.all(np.isfinite(limits)):
        raise ValueError(f"{name}: expected positive finite limits, got {value}")
    return limits


def segment_duration(delta: np.ndarray, max_velocity: np.ndarray,
                     max_acceleration: np.ndarray) -> tuple[float, float]:
    """(duration, acceleration time) of the rest-to-rest trapezoid along one straight segment.

    The segment is run by a path parameter s in [0, 1]; q = q0 + s Δ. The limits on s' and
    s'' are the tightest over the joints that move (|Δ_j| s' <= v_j, |Δ_j| s'' <= a_j).
    """
    moving = np.abs(delta) > 1e-12
    if not moving.any():
        return 0.0, 0.0
    v = float(np.min(max_velocity[moving] / np.abs(delta[moving])))
    a = float(np.min(max_acceleration[moving] / np.abs(delta[moving])))
    if v * v / a >= 1.0:  # never reaches cruise speed: a triangle
        t_acc = math.sqrt(1.0 / a)
        return 2 * t_acc, t_acc
    t_acc = v / a
    return 1.0 / v + t_acc, t_acc


def time_parameterize(path: np.ndarray, *, max_velocity=ARM_MAX_VELOCITY,
                      max_acceleration=ARM_MAX_ACCELERATION,
                      min_duration: float = 0.0) -> PiecewisePolynomial:
    """A timed trajectory that runs the waypoints `path` (n, d) along straight lines.

    Each segment is a rest-to-rest trapezoid (constant acceleration, cruise, constant
    deceleration), so the trajectory starts and ends at rest, stays on the straight lines
    (and so inside what was collision-checked) and keeps |q̇_j| <= max_velocity_j and
    |q̈_j| <= max_acceleration_j (scalars or d-vectors). It is exact: a quadratic piece is a
    cubic Hermite piece whose ends carry the right values and slopes. A path of one point (or
    of repeated points) gives a constant trajectory lasting `min_duration` (at least 1 ms).
    """
    path = np.asarray(path, dtype=float)
    if path.ndim != 2 or len(path) == 0:
        raise ValueError(f"path: expected (n, d) waypoints, got shape {path.shape}")
    d = path.shape[1]
    v_max = _limits(max_velocity, d, "max_velocity")
    a_max = _limits(max_acceleration, d, "max_acceleration")
    times, positions, velocities = [0.0], [path[0]], [np.zeros(d)]
    for q0, q1 in itertools.pairwise(path):
        delta = q1 - q0
        duration, t_acc = segment_duration(delta, v_max, a_max)
        if duration == 0.0:
            continue
        t0 = times[-1]
        # Path parameter at the end of acceleration, and the cruise rate.
        rate = 1.0 / (duration - t_acc)
        s1 = 0.5 * rate * t_acc
        knots = [(t0 + t_acc, s1, rate)]
        if duration - 2 * t_acc > 1e-12:
            knots.append((t0 + duration - t_acc, 1.0 - s1, rate))
        knots.append((t0 + duration, 1.0, 0.0))
        for t, s, s_dot in knots:
            times.append(t)
            positions.append(q0 + s * delta)
            velocities.append(s_dot * delta)
    if len(times) == 1:
        end = max(min_duration, 1e-3)
        return PiecewisePolynomial.ZeroOrderHold([0.0, end], np.column_stack([path[0], path[0]]))
    return PiecewisePolynomial.CubicHermite(
        np.array(times), np.column_stack(positions), np.column_stack(velocities))
