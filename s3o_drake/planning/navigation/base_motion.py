"""How the base moves along a path, as arithmetic: the one source of the base's motion profile.

The BaseNavigator (systems/base_navigator.py) plays these segments and the planner's cost
model (planning/time_model.py) times them, so the two cannot drift apart. A motion from
yaw `yaw0` through waypoints p0, p1, ..., pn to the landing yaw `yaw1` is

- per leg p_k -> p_{k+1} (legs of at most TINY are left out): a turn in place, the short way
  round, to the leg's heading, then a straight drive along it. The first leg (k = 0) is
  driven backwards when its heading is more than π/2 off the base's yaw (`backs_away`): a
  stop faces a table, and backing away from it needs only the inscribed radius of clearance
  where swinging round needs the circumscribed one;
- then a turn in place to `yaw1`.

Each segment (a drive of `length` m or a turn of `length` rad) has a trapezoidal speed
profile that starts and ends at rest: it accelerates at `a`, cruises at `c` (the speed v or
the yaw rate), brakes at `a`; too short to reach `c`, it peaks at sqrt(length a) half way.
Its duration is length / peak + peak / a (`trapezoid`).

The navigator reports a command done `settle_time` after its motion ends (the PD-driven
plant catches up). All angles in radians, lengths in metres, times in seconds.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from s3o_drake.world.angles import wrap

#: Segments shorter than this (m or rad) are left out: nothing to drive or turn.
TINY = 1e-9
#: The navigator's defaults (what the robot does): acceleration (m/s²), yaw rate (rad/s),
#: yaw acceleration (rad/s²) and the wait after a motion before it reports done (s).
ACCELERATION = 1.0
YAW_RATE = 0.8
YAW_ACCELERATION = 2.0
SETTLE_TIME = 0.3


@dataclass(frozen=True)
class BaseProfile:
    """The base's motion limits: cruise `speed` (m/s, the planner's v), `acceleration`
    (m/s²), `yaw_rate` (rad/s), `yaw_acceleration` (rad/s²), and `settle_time` (s) from the
    end of a motion to its report."""

    speed: float
    acceleration: float = ACCELERATION
    yaw_rate: float = YAW_RATE
    yaw_acceleration: float = YAW_ACCELERATION
    settle_time: float = SETTLE_TIME

    def drive_time(self, length):
        """Duration (s) of straight drives of `length` m (scalar or array)."""
        return trapezoid(length, self.speed, self.acceleration)[1]

    def turn_time(self, angle):
        """Duration (s) of turns in place through |`angle`| rad (scalar or array)."""
        return trapezoid(np.abs(angle), self.yaw_rate, self.yaw_acceleration)[1]

    def motion_time(self, waypoints: Sequence[Sequence[float]], yaw0: float,
                    yaw1: float) -> float:
        """Duration (s) of the motion through `waypoints` from yaw0 to yaw1 (the
        navigator's segments, timed one by one)."""
        return float(sum(self.turn_time(s.length) if s.turn else self.drive_time(s.length)
                         for s in motion_segments(waypoints, yaw0, yaw1)))


def trapezoid(length, max_speed: float, acceleration: float):
    """(peak speed, duration) of rest-to-rest trapezoidal profiles over `length` (scalars or
    arrays); a length of at most TINY takes no time."""
    length = np.asarray(length, dtype=float)
    peak = np.minimum(max_speed, np.sqrt(np.maximum(length, 0.0) * acceleration))
    moving = length > TINY
    safe = np.where(moving, peak, 1.0)
    duration = np.where(moving, length / safe + peak / acceleration, 0.0)
    if duration.ndim == 0:
        return float(peak), float(duration)
    return peak, duration


def backs_away(heading, yaw):
    """Whether the base leaving a stop at `yaw` drives a first leg of `heading` backwards
    (scalars or arrays): when the leg points more than π/2 away from where it faces."""
    return np.abs(wrap(np.asarray(heading) - yaw)) > math.pi / 2


@dataclass(frozen=True)
class SegmentSpec:
    """One segment of a motion: from pose `start` to pose `end` (x, y, yaw), a turn in
    place (`turn`) or a straight drive, `length` rad or m long."""

    start: tuple[float, float, float]
    end: tuple[float, float, float]
    turn: bool
    length: float


def motion_segments(waypoints: Sequence[Sequence[float]], yaw: float, target_yaw: float, *,
                    long_way: bool = False) -> list[SegmentSpec]:
    """The turn and drive segments through `waypoints` (x, y), starting at `yaw` and ending
    with the turn to `target_yaw` (see the module docstring). Yaw stays continuous (no 2π
    jumps). With `long_way`, the first turn goes the other way round (the navigator's
    escape when the short way is blocked)."""
    segments: list[SegmentSpec] = []
    pose = np.array([float(waypoints[0][0]), float(waypoints[0][1]), float(yaw)])

    def turn_to(heading: float) -> None:
        nonlocal pose, long_way
        delta = float(wrap(heading - pose[2]))
        if long_way and abs(delta) > TINY:
            delta -= math.copysign(2 * math.pi, delta)
            long_way = False
        if abs(delta) > TINY:
            end = np.array([pose[0], pose[1], pose[2] + delta])
            segments.append(SegmentSpec(_pose(pose), _pose(end), True, abs(delta)))
            pose = end

    for k, p in enumerate(waypoints[1:]):
        d = np.asarray(p, dtype=float) - pose[:2]
        length = float(np.hypot(*d))
        if length <= TINY:
            continue
        heading = math.atan2(d[1], d[0])
        if k == 0 and backs_away(heading, pose[2]):
            heading = float(wrap(heading + math.pi))
        turn_to(heading)
        end = np.array([float(p[0]), float(p[1]), pose[2]])
        segments.append(SegmentSpec(_pose(pose), _pose(end), False, length))
        pose = end
    turn_to(target_yaw)
    return segments


def _pose(p: np.ndarray) -> tuple[float, float, float]:
    return float(p[0]), float(p[1]), float(p[2])


def chain_time(profile: BaseProfile, heading_in: np.ndarray, heading_out: np.ndarray,
               length: np.ndarray, own_time: np.ndarray, yaw0: np.ndarray,
               yaw1: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Motion durations (s) of m paths at once, and the yaw each ends at (rad): the
    vectorised form of `motion_segments` timed by `profile`, each path given as K items.

    Item k of path i is a straight leg (`heading_in` = `heading_out` = its heading,
    `own_time` its drive time) or a stretch of several legs whose inner turns are in
    `own_time` (`heading_in`: the heading of its first leg, `heading_out`: of its last);
    items with `length` <= TINY are left out. Each item is preceded by the turn from the
    current heading to its `heading_in`; the first item is backed along when `backs_away`
    says so (only legs can be first: a stretch always follows a leg to its first vertex).
    Then the turn to `yaw1`;
    a NaN `yaw1` stands for "facing along the last item", i.e. no final turn unless the
    path's only leg was backed. Arrays: heading_in, heading_out, length, own_time (m, K);
    yaw0, yaw1 (m,).
    """
    m, k_items = length.shape
    heading = np.asarray(yaw0, dtype=float).copy()
    travel = heading.copy()  # direction of travel of the last item (no backing flip)
    first = np.ones(m, dtype=bool)
    total = np.zeros(m)
    for k in range(k_items):
        live = length[:, k] > TINY
        e_in, e_out = heading_in[:, k], heading_out[:, k]
        back = live & first & backs_away(e_in, heading)
        flip = np.where(back, math.pi, 0.0)
        turn = np.where(live, profile.turn_time(wrap(e_in + flip - heading)), 0.0)
        total += turn + np.where(live, own_time[:, k], 0.0)
        heading = np.where(live, e_out + flip, heading)
        travel = np.where(live, e_out, travel)
        first &= ~live
    target = np.where(np.isnan(yaw1), travel, yaw1)
    return total + profile.turn_time(wrap(target - heading)), target
