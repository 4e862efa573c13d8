"""Where the base really stands when it picks: the landing as the execution realises it.

The navigation noise T^n moves the landing target; the execution then decides where the base
stands, and Fea^m must model that, not the raw noisy target (a model that counts a
landing "into" a table as a failure is pessimistic next to tables):

1. The base drives towards the noisy target and, checking its poses every
   `CHECK_STEP_XY` along the way, stops at the last free pose short of a collision; a
   collision within `FINAL_APPROACH` of the end only shortens the landing, an earlier one
   blocks the drive (`stop_short`). The model's approach is straight in along the heading
   that faces the dish; where that way back is not free within `FINAL_APPROACH` (a chair
   behind the stop), the drive came in another way, through the stop it was sent to (free:
   the planner commands only free stops), and stops short on the way from there. The
   BaseNavigator lands short along its path's last leg, which comes in from the aisle, and
   escapes where it is caught; stepping back along the heading alone counts landings near
   chairs as blocked that the execution lands (docs/calibration.md).
2. It turns in place to the noisy target yaw, stopping at the last free yaw (`turn_until`,
   sampled every `CHECK_STEP_YAW`).
3. Before the pickup, a base that does not face the dish within `TURN_TOLERANCE` turns to
   face it from where it stands (Fea^m assumes the arm faces the dish; a stop that serves
   several dishes faces the first).

These constants are the execution's: the BaseNavigator and the Executive read them here.
A pose is "free" when it is inside the room and collision-free with the arm stowed
(`FeasibilityChecker.base_free`).
"""

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from s3o_drake.world.angles import facing_yaw, wrap

#: Sampling of a motion for the collision check: one pose per this much travel (m, rad).
CHECK_STEP_XY = 0.02
CHECK_STEP_YAW = 0.05
#: A collision this close to the end of the path (m of driving) only shortens the landing.
FINAL_APPROACH = 0.5
#: A pickup's dish further off the base's heading than this (rad) is faced first.
TURN_TOLERANCE = 0.03

_STEPS_PER_CALL = 5

#: Vectorised free-pose test: base poses (n, 3) -> bool (n,).
FreeTest = Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True)
class PaddedFree:
    """A FreeTest with a padding (`padded`, what it answers), and the same test without
    the padding (`untouched`): a base that stands inside the padding, where a noisy landing
    may leave it, may move out of it, but not into contact (`escape.cut_at_collision`)."""

    padded: FreeTest
    untouched: FreeTest

    def __call__(self, poses: np.ndarray) -> np.ndarray:
        return self.padded(poses)


def stop_short(free: FreeTest, targets: np.ndarray, sent: np.ndarray | None = None
               ) -> tuple[np.ndarray, np.ndarray]:
    """Where a base driving straight into each target pose (x, y, yaw), heading along its
    yaw, stops: the target when it is free, else the last free pose before it (stepping
    back against the heading by CHECK_STEP_XY, up to FINAL_APPROACH). With `sent` (n, 2),
    the positions the drives were sent to, a target with no free pose that way is
    approached from there instead (step 1 of the module docstring). Returns the poses
    (n, 3) and whether the drive landed (n,) (False: blocked further out).
    """
    targets = np.asarray(targets, dtype=float).reshape(-1, 3)
    back = -np.stack([np.cos(targets[:, 2]), np.sin(targets[:, 2])], axis=1)
    poses, landed = _step_back(free, targets, back)
    if sent is not None and not landed.all():
        open_ = np.flatnonzero(~landed)
        away = targets[open_, :2] - np.asarray(sent, dtype=float).reshape(-1, 2)[open_]
        length = np.linalg.norm(away, axis=1)
        ok = length > 1e-9
        rows = open_[ok]
        direction = -away[ok] / length[ok, None]
        again, made = _step_back(free, targets[rows], direction,
                                 limit=np.minimum(length[ok], FINAL_APPROACH))
        poses[rows[made]] = again[made]
        landed[rows[made]] = True
    return poses, landed


def _step_back(free: FreeTest, targets: np.ndarray, back: np.ndarray,
               limit: np.ndarray | float = FINAL_APPROACH) -> tuple[np.ndarray, np.ndarray]:
    """The target when free, else the first free pose stepping along `back` (n, 2, unit)
    by CHECK_STEP_XY, up to `limit` (m, per target); the yaw kept."""
    poses = targets.copy()
    landed = free(targets)
    limit = np.broadcast_to(np.asarray(limit, dtype=float), (len(targets),))
    steps = round(FINAL_APPROACH / CHECK_STEP_XY)
    open_ = np.flatnonzero(~landed)
    # A few steps per call: the free test's cost is mostly per call, and most colliding
    # targets lie deep in a table, where every step collides.
    for first in range(1, steps + 1, _STEPS_PER_CALL):
        if open_.size == 0:
            break
        k = np.arange(first, min(first + _STEPS_PER_CALL, steps + 1))
        candidates = np.repeat(targets[open_][:, None], len(k), axis=1)
        distance = np.minimum(k[None, :] * CHECK_STEP_XY, limit[open_][:, None])
        candidates[..., :2] += distance[..., None] * back[open_][:, None]
        ok = free(candidates.reshape(-1, 3)).reshape(len(open_), len(k))
        hit = ok.any(axis=1)
        nearest = np.argmax(ok, axis=1)
        rows = open_[hit]
        poses[rows] = candidates[hit, nearest[hit]]
        landed[rows] = True
        open_ = open_[~hit]
    return poses, landed


def turn_until(free: FreeTest, poses: np.ndarray, target_yaw: np.ndarray) -> np.ndarray:
    """The yaws (n,) where bases at `poses` (n, 3) end when turning in place the short way
    round to `target_yaw` (n,): the target, or the last free yaw before the first pose that
    collides (sampled every CHECK_STEP_YAW)."""
    poses = np.asarray(poses, dtype=float).reshape(-1, 3)
    delta = wrap(np.asarray(target_yaw, dtype=float) - poses[:, 2])
    steps = np.maximum(1, np.ceil(np.abs(delta) / CHECK_STEP_YAW)).astype(int)
    open_ = np.flatnonzero(np.abs(delta) > 1e-12)
    reached = poses[:, 2].copy()
    for k in range(1, int(steps.max(initial=0)) + 1):
        open_ = open_[steps[open_] >= k]
        if open_.size == 0:
            break
        candidates = poses[open_].copy()
        candidates[:, 2] += delta[open_] * k / steps[open_]
        ok = free(candidates)
        reached[open_[ok]] = candidates[ok, 2]
        open_ = open_[ok]
    return reached


def pickup_poses(free: FreeTest, nominal: np.ndarray, p_WD: np.ndarray,
                 noise: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Where the base stands when it picks the dish at p_WD, sent to `nominal` positions
    (n, 2) facing the dish and landing with navigation noise (dx, dy, dyaw) (n, 3): steps
    1-3 of the module docstring. Returns the poses (n, 3) and whether the drive landed."""
    nominal = np.asarray(nominal, dtype=float).reshape(-1, 2)
    noise = np.asarray(noise, dtype=float).reshape(-1, 3)
    heading = facing_yaw(nominal, p_WD)
    target = np.column_stack([nominal + noise[:, :2], heading])
    poses, landed = stop_short(free, target, sent=nominal)
    poses[:, 2] = turn_until(free, poses, heading + noise[:, 2])
    facing = facing_yaw(poses[:, :2], p_WD)
    turn = np.abs(wrap(facing - poses[:, 2])) > TURN_TOLERANCE
    if turn.any():
        poses[turn, 2] = turn_until(free, poses[turn], facing[turn])
    return poses, landed
