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

That is the paper's motion, `stop_and_go`. With `smooth` (`BaseProfile.motion`) the base
does not stop at the inner corners of its path: it turns while it drives (`smooth_segments`,
`smooth_chain_time`).

- Differential drive (the default): the start (the turn to the first leg's heading, or
  away from it to back it), a cusp after a backed first leg, and the final turn to the
  landing yaw stay turns in place at rest. The first leg is backed where that turns the
  base less in place than driving it forwards (`fewer_turns_backing`), not by
  `backs_away`'s rule alone. At every other corner the base keeps moving at a corner
  speed u and turns through the corner's angle θ with the yaw profile of a turn in place
  (the same yaw rate and yaw acceleration, so the same duration): a *moving turn*. At
  constant speed under that yaw profile the base follows a curve (clothoid, arc, clothoid)
  that leaves the first leg u·D(θ) before the corner and joins the second u·D(θ) after it,
  and passes u·C(θ) inside the corner (`moving_turn_shape`, computed once per yaw limits).
  u is the cruise speed or less, so that the curve cuts at most CORNER_CUT inside the
  corner, takes at most a quarter of either leg, and the speed is reachable on half of
  either leg at the linear acceleration; below MIN_CORNER_SPEED, or for corners sharper
  than MAX_MOVING_TURN, the base stops and turns in place as in `stop_and_go`. Each
  straight between two corners runs from the first one's speed to the second's, cruising
  where it can (`leg_profile`). The lateral acceleration on a curve is at most u times the
  yaw rate.
- Holonomic (`BaseProfile.holonomic`): the base never turns to drive. Its direction of
  travel turns at the corners as a differential base's heading would (the same moving
  turns, so that the lateral acceleration stays as low), stopping where a differential
  base would turn in place, but without turning there; its yaw turns from the start's to
  the landing's with the profile of a turn in place, from the start of the motion, while
  it translates. The motion lasts as long as the longer of the two.

A moving turn's curve is checked like every pose of a motion: by the navigator, along the
motion, against the world (the map's clearance alone does not guarantee it: the path
hugs the inflated corners, and the curve runs inside them).
"""

from __future__ import annotations

import bisect
import dataclasses
import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from s3o_drake.world.angles import wrap
from s3o_drake.world.choices import MOTIONS, Motion

#: Segments shorter than this (m or rad) are left out: nothing to drive or turn.
TINY = 1e-9
#: The navigator's defaults (what the robot does): acceleration (m/s²), yaw rate (rad/s),
#: yaw acceleration (rad/s²) and the wait after a motion before it reports done (s).
ACCELERATION = 1.0
YAW_RATE = 0.8
YAW_ACCELERATION = 2.0
SETTLE_TIME = 0.3
STOP_AND_GO = Motion.STOP_AND_GO.value
SMOOTH = Motion.SMOOTH.value
#: A moving turn's curve passes at most this far (m) inside its corner.
CORNER_CUT = 0.10
#: Corners sharper than this (rad) are turned in place: a moving turn through them would
#: have to crawl (at CORNER_CUT, about 0.09 m/s at 2 rad) and runs far along both legs.
MAX_MOVING_TURN = 2.0
#: A corner whose speed would be below this (m/s) is turned in place.
MIN_CORNER_SPEED = 0.05
#: Corners turning the same way with legs shorter than this (m) between them are one.
MERGE_LENGTH = 0.3


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
    motion: str = STOP_AND_GO
    """`STOP_AND_GO` or `SMOOTH` (module docstring)."""
    holonomic: bool = False
    """The base can move sideways: it turns while it translates (smooth motion only)."""

    def __post_init__(self) -> None:
        if self.motion not in MOTIONS:
            raise ValueError(f"motion: expected one of {', '.join(MOTIONS)}, got "
                             f"{self.motion!r}")

    @property
    def smooth(self) -> bool:
        return self.motion == SMOOTH

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
        if self.smooth:
            return float(sum(self.turn_time(s.length) if isinstance(s, SegmentSpec)
                             else s.duration
                             for s in smooth_segments(self, waypoints, yaw0, yaw1)))
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


# ---------------------------------------------------------------------------- smooth motion
_SHAPE_ANGLES = 513
"""Corner angles in the table of moving-turn shapes, denser towards 0 (where the shape
grows as the square root of the angle)."""
_SHAPE_STEPS = 1024
"""Integration steps of one moving turn's curve."""
_CURVE_SAMPLES = 65
"""Points a played moving turn keeps of its curve (linear in between: under 0.1 mm off)."""


def turned(tau, angle, peak: float, acceleration: float, duration: float):
    """The angle turned (0 to `angle` >= 0) and its rate, `tau` s into a rest-to-rest turn
    through `angle` with the profile `trapezoid` gives (`peak`, `duration`); arrays or
    scalars."""
    tau = np.clip(np.asarray(tau, dtype=float), 0.0, duration)
    ramp = peak / acceleration
    down = duration - tau
    angle_at = np.where(tau < ramp, 0.5 * acceleration * tau**2,
                        np.where(down < ramp, angle - 0.5 * acceleration * down**2,
                                 0.5 * peak * ramp + peak * (tau - ramp)))
    rate = np.where(tau < ramp, acceleration * tau,
                    np.where(down < ramp, acceleration * down, peak))
    return angle_at, rate


def _unit_curves(angles: np.ndarray, yaw_rate: float, yaw_acceleration: float,
                 steps: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For each angle (k,) >= 0: the times (k, steps + 1) of a moving turn through it at
    1 m/s, and its curve's points (k, steps + 1, 2) in the first leg's frame (from the
    origin along x, turning left)."""
    peak, duration = trapezoid(angles, yaw_rate, yaw_acceleration)
    peak, duration = np.atleast_1d(peak), np.atleast_1d(duration)
    t = duration[:, None] * np.linspace(0.0, 1.0, steps + 1)[None, :]
    psi, _ = turned(t, angles[:, None], peak[:, None], yaw_acceleration, duration[:, None])
    dt = np.diff(t, axis=1)
    c, s = np.cos(psi), np.sin(psi)
    x = np.concatenate([np.zeros((len(angles), 1)),
                        np.cumsum(0.5 * (c[:, 1:] + c[:, :-1]) * dt, axis=1)], axis=1)
    y = np.concatenate([np.zeros((len(angles), 1)),
                        np.cumsum(0.5 * (s[:, 1:] + s[:, :-1]) * dt, axis=1)], axis=1)
    return t, np.stack([x, y], axis=-1)


@functools.lru_cache(maxsize=8)
def moving_turn_shape(yaw_rate: float, yaw_acceleration: float
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The table of moving turns at 1 m/s under these yaw limits: corner angles (k,) from 0
    to MAX_MOVING_TURN, how far before and after the corner the curve leaves and joins the
    legs (D, m per m/s) and how far inside the corner it passes (C, m per m/s). The curve
    is symmetric about the corner's bisector: its chord runs along it."""
    angles = MAX_MOVING_TURN * np.linspace(0.0, 1.0, _SHAPE_ANGLES) ** 2
    _, points = _unit_curves(angles, yaw_rate, yaw_acceleration, _SHAPE_STEPS)
    chord = np.linalg.norm(points[:, -1], axis=1)
    tangent = chord / (2.0 * np.cos(angles / 2.0))
    apex = points[:, _SHAPE_STEPS // 2]
    cut = np.hypot(tangent - apex[:, 0], apex[:, 1])
    return angles, tangent, cut


def corner_speeds(profile: BaseProfile, angle, before, after, room=CORNER_CUT):
    """The speed (m/s) at which the base turns through corners of |`angle`| rad between
    legs `before` and `after` m long, and how far (m) from the corner its curve meets
    each leg (module docstring); 0 and 0 where it turns in place. Its curve passes at most
    `room` (m) inside the corner, and takes at most a quarter of either leg. Arrays or
    scalars."""
    angle = np.abs(np.asarray(angle, dtype=float))
    angles, tangent, cut = moving_turn_shape(profile.yaw_rate, profile.yaw_acceleration)
    reach = np.interp(angle, angles, tangent)
    inside = np.interp(angle, angles, cut)
    shortest = np.minimum(before, after)
    with np.errstate(divide="ignore"):
        speed = np.minimum.reduce([
            np.full(np.shape(angle), profile.speed),
            np.where(inside > 0, room / np.where(inside > 0, inside, 1.0), np.inf),
            np.where(reach > 0, shortest / (4.0 * np.where(reach > 0, reach, 1.0)), np.inf),
            np.sqrt(profile.acceleration * np.maximum(shortest, 0.0) / 2.0)])
    speed = np.where((angle > MAX_MOVING_TURN) | (speed < MIN_CORNER_SPEED), 0.0, speed)
    return speed, speed * reach


def leg_profile(length, u0, u1, max_speed: float, acceleration: float):
    """(peak speed, duration) of straight drives of `length` m that start at speed `u0` and
    end at `u1` (m/s), accelerating and braking at `acceleration`, cruising at `max_speed`
    where there is room (the caller keeps u0 and u1 reachable from each other). Rest to
    rest, this is `trapezoid`. Arrays or scalars."""
    length = np.maximum(np.asarray(length, dtype=float), 0.0)
    u0, u1 = np.asarray(u0, dtype=float), np.asarray(u1, dtype=float)
    peak = np.sqrt(np.minimum(max_speed**2,
                              acceleration * length + 0.5 * (u0**2 + u1**2)))
    peak = np.maximum(peak, np.maximum(u0, u1))
    moving = peak > TINY
    safe = np.where(moving, peak, 1.0)
    cruise = length - (2.0 * peak**2 - u0**2 - u1**2) / (2.0 * acceleration)
    duration = np.where(moving, (2.0 * peak - u0 - u1) / acceleration
                        + np.maximum(cruise, 0.0) / safe, 0.0)
    if duration.ndim == 0:
        return float(peak), float(duration)
    return peak, duration


@dataclass(frozen=True)
class MovingDrive:
    """A straight drive from pose `start` to `end` (x, y, yaw; the yaw is the base's, which
    faces along it, or away from it when backing) that starts at speed `u0` and ends at
    `u1` (m/s), with the profile `leg_profile` gives."""

    start: tuple[float, float, float]
    end: tuple[float, float, float]
    length: float
    u0: float
    u1: float
    peak: float
    acceleration: float
    duration: float
    turn = False

    @staticmethod
    def make(start: Sequence[float], end: Sequence[float], *, u0: float, u1: float,
             profile: BaseProfile) -> MovingDrive:
        length = float(math.dist(start[:2], end[:2]))
        peak, duration = leg_profile(length, u0, u1, profile.speed, profile.acceleration)
        return MovingDrive(_pose(np.asarray(start, float)), _pose(np.asarray(end, float)),
                           length, float(u0), float(u1), peak, profile.acceleration,
                           duration)

    def at(self, tau: float) -> tuple[float, float]:
        """Distance travelled and speed, `tau` s after the drive began."""
        tau = min(max(tau, 0.0), self.duration)
        a, peak = self.acceleration, self.peak
        t_up = (peak - self.u0) / a
        t_down = (peak - self.u1) / a
        if tau < t_up:
            return self.u0 * tau + 0.5 * a * tau**2, self.u0 + a * tau
        remaining = self.duration - tau
        if remaining < t_down:
            return self.length - self.u1 * remaining - 0.5 * a * remaining**2, \
                self.u1 + a * remaining
        return (peak**2 - self.u0**2) / (2 * a) + peak * (tau - t_up), peak

    def pose(self, s: float) -> np.ndarray:
        a, b = np.asarray(self.start), np.asarray(self.end)
        return a + (b - a) * (s / self.length if self.length > TINY else 0.0)

    def state(self, tau: float) -> list[float]:
        """[x, y, yaw, xdot, ydot, yawdot] `tau` s after the drive began."""
        s, rate = self.at(tau)
        if self.length <= TINY:
            return [*self.start, 0.0, 0.0, 0.0]
        d = [(b - a) / self.length for a, b in zip(self.start[:2], self.end[:2], strict=True)]
        return [self.start[0] + d[0] * s, self.start[1] + d[1] * s, self.start[2],
                d[0] * rate, d[1] * rate, 0.0]


@dataclass(frozen=True)
class MovingTurn:
    """A corner taken at constant `speed` (m/s) while the heading turns through `angle`
    (rad, signed) with the yaw profile of a turn in place: from pose `start`, along the
    curve `points` (x, y at `times`). The base faces along the curve; for a holonomic base
    the curve is its direction of travel and the yaw is not played here."""

    start: tuple[float, float, float]
    end: tuple[float, float, float]
    angle: float
    speed: float
    yaw_peak: float
    yaw_acceleration: float
    duration: float
    times: tuple[float, ...]
    points: tuple[tuple[float, float], ...]
    turn = False

    @staticmethod
    def make(start: Sequence[float], angle: float, speed: float,
             profile: BaseProfile) -> MovingTurn:
        sign = 1.0 if angle >= 0 else -1.0
        t, unit = _unit_curves(np.array([abs(angle)]), profile.yaw_rate,
                               profile.yaw_acceleration, _SHAPE_STEPS)
        keep = np.linspace(0, _SHAPE_STEPS, _CURVE_SAMPLES).round().astype(int)
        local = unit[0, keep] * [1.0, sign] * speed
        c, s = math.cos(start[2]), math.sin(start[2])
        world = np.column_stack([start[0] + c * local[:, 0] - s * local[:, 1],
                                 start[1] + s * local[:, 0] + c * local[:, 1]])
        peak, duration = trapezoid(abs(angle), profile.yaw_rate, profile.yaw_acceleration)
        end = (float(world[-1, 0]), float(world[-1, 1]), float(start[2] + angle))
        return MovingTurn(_pose(np.asarray(start, float)), end, float(angle), float(speed),
                          peak, profile.yaw_acceleration, duration,
                          tuple(float(x) for x in t[0, keep]),
                          tuple((float(x), float(y)) for x, y in world))

    @property
    def length(self) -> float:
        """The curve's length (m)."""
        return self.speed * self.duration

    def heading(self, tau: float) -> tuple[float, float]:
        """The heading (rad) and its rate `tau` s into the turn."""
        angle, rate = turned(tau, abs(self.angle), self.yaw_peak, self.yaw_acceleration,
                             self.duration)
        sign = 1.0 if self.angle >= 0 else -1.0
        return self.start[2] + sign * float(angle), sign * float(rate)

    def position(self, tau: float) -> tuple[float, float]:
        tau = min(max(tau, 0.0), self.duration)
        k = min(max(bisect.bisect_right(self.times, tau) - 1, 0), len(self.times) - 2)
        t0, t1 = self.times[k], self.times[k + 1]
        w = (tau - t0) / (t1 - t0) if t1 > t0 else 0.0
        (x0, y0), (x1, y1) = self.points[k], self.points[k + 1]
        return x0 + w * (x1 - x0), y0 + w * (y1 - y0)

    def pose(self, s: float) -> np.ndarray:
        tau = s / self.speed if self.speed > 0 else 0.0
        return np.array([*self.position(tau), self.heading(tau)[0]])

    def state(self, tau: float) -> list[float]:
        yaw, rate = self.heading(tau)
        x, y = self.position(tau)
        moving = 0.0 <= tau <= self.duration
        v = self.speed if moving else 0.0
        return [x, y, yaw, v * math.cos(yaw), v * math.sin(yaw), rate]


SmoothSegment = SegmentSpec | MovingDrive | MovingTurn
"""A piece of a smooth motion: a turn in place (a `SegmentSpec` with `turn`, timed as in
`stop_and_go`), a straight drive, or a moving turn."""


@dataclass(frozen=True)
class Corners:
    """The corners of m paths as a smooth motion takes them (`path_corners`), J at most per
    path: `count` (m,) corners, each at `point` (m, J, 2) turning by `angle` (m, J; signed),
    taken at `speed` (m/s; 0: in place) with its curve meeting the legs `reach` (m) from
    it; the legs between the start, the corners and the end: `heading`, `length` (m, J + 1)
    and `legs` (m,) of them (0 for a path that stays where it is); `backed` (m,): the first
    leg is backed (a cusp after it, turned in place)."""

    start: np.ndarray
    count: np.ndarray
    point: np.ndarray
    angle: np.ndarray
    speed: np.ndarray
    reach: np.ndarray
    heading: np.ndarray
    length: np.ndarray
    legs: np.ndarray
    backed: np.ndarray


def _compressed(points: np.ndarray, count: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The points (m, P, 2) of each path without those at most TINY from the one before,
    moved to the front, and how many each keeps (a path of one point keeps it)."""
    d = np.diff(points, axis=1)
    live = (np.hypot(d[..., 0], d[..., 1]) > TINY) \
        & (np.arange(points.shape[1] - 1)[None, :] < (count[:, None] - 1))
    order = np.argsort(~live, axis=1, kind="stable")
    keep = np.concatenate([np.zeros((len(points), 1), dtype=int), order + 1], axis=1)
    return np.take_along_axis(points, keep[..., None], axis=1), 1 + live.sum(axis=1)


def fewer_turns_backing(profile: BaseProfile, heading: np.ndarray, length: np.ndarray,
                        legs: np.ndarray, yaw0: np.ndarray, yaw1: np.ndarray) -> np.ndarray:
    """Whether a differential base leaving yaw `yaw0` (m,) backs the first leg of each of m
    paths (`heading`, `length` (m, L) of their legs, `legs` (m,) of them; at least one):
    when that turns it in place for less time than driving it forwards. Backing turns at
    the start to face away from the leg and at the cusp after it (towards the second leg,
    or for a path of one leg to the landing yaw `yaw1`); driving forwards turns at the
    start to face along it, and at its end where the corner is too sharp or its legs too
    short to take moving (`corner_speeds`), or to `yaw1`. A NaN `yaw1` is "facing along
    the last leg", as in `chain_time`. Ties keep `backs_away`'s rule.

    A stop faces its table: the leg straight away from it is backed (no turn at the start),
    and a leg across it goes whichever way turns the base less: backing it, then turning
    the other way round at the cusp, turned up to 4.4 rad where 1.5 would have done."""
    h0 = heading[:, 0]
    h1 = heading[:, 1] if heading.shape[1] > 1 else h0
    theta = np.asarray(wrap(h1 - h0))
    second = length[:, 1] if length.shape[1] > 1 else np.zeros(len(h0))
    corner_speed, _ = corner_speeds(profile, theta, length[:, 0], second)
    known = np.isfinite(yaw1)
    end = np.where(known, yaw1, h0)
    one = legs < 2
    forwards = profile.turn_time(wrap(h0 - yaw0)) + np.where(
        one, profile.turn_time(wrap(end - h0)),
        np.where(corner_speed > 0, 0.0, profile.turn_time(theta)))
    backwards = profile.turn_time(wrap(h0 + math.pi - yaw0)) + np.where(
        one, profile.turn_time(wrap(end - h0 - math.pi)), profile.turn_time(wrap(theta - math.pi)))
    tie = np.abs(backwards - forwards) <= 1e-9
    return np.where(tie, backs_away(h0, yaw0), backwards < forwards)


def path_corners(profile: BaseProfile, points: np.ndarray, count: np.ndarray,
                 yaw0: np.ndarray, yaw1: np.ndarray | None = None, *,
                 other_way: bool = False) -> Corners:
    """The corners of m paths through `points` (m, P, 2; the first `count` (m,) of each
    row), for a base starting at yaw `yaw0` (m,) and landing at `yaw1` (m,; NaN or None:
    facing along the last leg).

    Consecutive inner corners that turn the same way, joined by legs shorter than
    MERGE_LENGTH (the navigation map rounds an obstacle's corner with several short
    legs), are one corner: at the point where the legs before and after them would meet,
    turning by their sum (at most MAX_MOVING_TURN), and its curve may pass CORNER_CUT
    inside the path they make (their polyline's distance from that point more than
    CORNER_CUT inside it). A differential base backs its first leg where that turns it
    less in place (`fewer_turns_backing`; with `other_way`, where it does not: the
    navigator's fallback when that first turn is blocked), and its cusp after a backed
    first leg stays a corner of its own, turned in place."""
    points = np.asarray(points, dtype=float)
    m = len(points)
    p, n_points = _compressed(points, np.asarray(count, dtype=int).reshape(m))
    n_legs = n_points - 1
    d = np.diff(p, axis=1)
    h = np.arctan2(d[..., 1], d[..., 0])
    ell = np.hypot(d[..., 0], d[..., 1])
    rows = np.arange(m)
    yaw0 = np.asarray(yaw0, dtype=float).reshape(m)
    yaw1 = np.full(m, np.nan) if yaw1 is None else np.asarray(yaw1, dtype=float).reshape(m)
    backed = np.zeros(m, dtype=bool)
    if h.size and not profile.holonomic:
        backed = (n_legs > 0) & (fewer_turns_backing(profile, h, ell, n_legs, yaw0, yaw1)
                                 != other_way)
    width = max(p.shape[1] - 2, 0)
    point = np.zeros((m, max(width, 1), 2))
    angle = np.zeros((m, max(width, 1)))
    depth = np.zeros((m, max(width, 1)))
    found = np.zeros(m, dtype=int)
    open_ = np.zeros(m, dtype=bool)
    first = np.zeros(m, dtype=int)
    turned_so_far = np.zeros(m)

    def close(which: np.ndarray, last: int) -> None:
        """Ends the chains of rows `which`, from vertex `first` to `last`."""
        r = np.flatnonzero(which)
        if r.size == 0:
            return
        a = first[r]
        e_in = np.stack([np.cos(h[r, a - 1]), np.sin(h[r, a - 1])], axis=1)
        e_out = np.stack([np.cos(h[r, last]), np.sin(h[r, last])], axis=1)
        pa, pb = p[r, a], p[r, last]
        det = e_in[:, 0] * e_out[:, 1] - e_in[:, 1] * e_out[:, 0]
        gap = pb - pa
        single = (a == last) | (np.abs(det) < 1e-9)
        t = np.where(single, 0.0, (gap[:, 0] * e_out[:, 1] - gap[:, 1] * e_out[:, 0])
                     / np.where(single, 1.0, det))
        v = pa + t[:, None] * e_in
        # How far inside the meeting point the path already passes: its distance to the
        # chain's legs.
        nearest = np.full(len(r), np.inf)
        for offset in range(int((last - a).max(initial=0))):
            i = np.minimum(a + offset, last - 1)
            live = (a + offset) < last
            q0, q1 = p[r, i], p[r, i + 1]
            seg = q1 - q0
            w = np.clip(np.einsum("ij,ij->i", v - q0, seg)
                        / np.maximum(np.einsum("ij,ij->i", seg, seg), 1e-18), 0.0, 1.0)
            dist = np.hypot(*(q0 + w[:, None] * seg - v).T)
            nearest = np.where(live, np.minimum(nearest, dist), nearest)
        point[r, found[r]] = v
        angle[r, found[r]] = turned_so_far[r]
        depth[r, found[r]] = np.where(single, 0.0, nearest)
        found[r] += 1
        open_[r] = False

    for k in range(1, p.shape[1] - 1):
        valid = k < n_legs
        theta = np.asarray(wrap(h[:, k] - h[:, k - 1]))
        joins = (open_ & valid & (ell[:, k - 1] < MERGE_LENGTH)
                 & (np.sign(theta) == np.sign(turned_so_far))
                 & (np.abs(turned_so_far + theta) <= MAX_MOVING_TURN)
                 & ~(backed & (first == 1)))
        close(open_ & ~joins, k - 1)
        starts = valid & ~joins
        first = np.where(starts, k, first)
        turned_so_far = np.where(starts, theta, np.where(joins, turned_so_far + theta,
                                                         turned_so_far))
        open_ |= starts
    close(open_, p.shape[1] - 2)
    # The cusp: the turn from the backed leg's facing to the next leg's heading.
    cusp = backed & (found > 0)
    angle[:, 0] = np.where(cusp, wrap(h[:, 1 % max(h.shape[1], 1)] - (h[:, 0] + math.pi))
                           if h.shape[1] > 1 else angle[:, 0], angle[:, 0])
    # The legs between the start, the corners and the end.
    ends = p[rows, np.maximum(n_points - 1, 0)]
    j = np.arange(point.shape[1])[None, :]
    inner = j < found[:, None]
    chain = np.concatenate([p[:, :1], np.where(inner[..., None], point, ends[:, None]),
                            ends[:, None]], axis=1)
    legs_d = np.diff(chain, axis=1)
    heading = np.arctan2(legs_d[..., 1], legs_d[..., 0])
    length = np.hypot(legs_d[..., 0], legs_d[..., 1])
    # A leg's heading where it has no length: the path's own (the last corner's exit).
    k_out = np.minimum(np.arange(heading.shape[1])[None, :], np.maximum(found, 0)[:, None])
    heading = np.where(length > TINY, heading, np.take_along_axis(
        np.concatenate([heading[:, :1], heading], axis=1), k_out, axis=1))
    speed, reach = corner_speeds(profile, angle, length[:, :-1], length[:, 1:],
                                 room=CORNER_CUT + depth)
    stopped = ~inner | (cusp[:, None] & (j == 0))
    speed = np.where(stopped, 0.0, speed)
    reach = np.where(stopped, 0.0, reach)
    return Corners(p[:, 0], found, point, angle, speed, reach, heading, length,
                   np.where(n_legs > 0, found + 1, 0), backed)


def smooth_segments(profile: BaseProfile, waypoints: Sequence[Sequence[float]], yaw: float,
                    target_yaw: float, *, other_way: bool = False) -> list[SmoothSegment]:
    """The pieces of the smooth motion through `waypoints` (x, y), starting at `yaw` and
    landing at `target_yaw` (module docstring); legs of at most TINY are left out. Yaw
    stays continuous. A holonomic base's motion is one `HolonomicMotion`. `other_way`:
    the first leg driven the other way than `path_corners` chooses."""
    points = np.asarray([np.asarray(w, dtype=float)[:2] for w in waypoints])
    c = path_corners(profile, points[None], np.array([len(points)]), np.array([yaw]),
                     np.array([target_yaw]), other_way=other_way)
    count, legs = int(c.count[0]), int(c.legs[0])
    pieces: list[MovingDrive | MovingTurn] = []
    turns: list[tuple[int, float]] = []  # (piece index before which, angle): in place
    here = np.array([points[0][0], points[0][1], c.heading[0, 0]])
    for k in range(legs):
        e = np.array([math.cos(c.heading[0, k]), math.sin(c.heading[0, k])])
        # Each leg ends where its corner's curve begins (at the corner when turning in
        # place), the last one at the path's end.
        end_xy = c.point[0, k] - c.reach[0, k] * e if k < count else points[-1]
        pieces.append(MovingDrive.make(here, (*end_xy, here[2]),
                                       u0=c.speed[0, k - 1] if k > 0 else 0.0,
                                       u1=c.speed[0, k] if k < count else 0.0,
                                       profile=profile))
        if k == count:
            break
        # The direction of travel (a differential base backing its first leg faces away).
        if c.speed[0, k] > 0:
            curve = MovingTurn.make((*end_xy, c.heading[0, k]), float(c.angle[0, k]),
                                    float(c.speed[0, k]), profile)
            pieces.append(curve)
            here = np.array([curve.end[0], curve.end[1], c.heading[0, k + 1]])
        else:
            turns.append((len(pieces), float(c.angle[0, k])))
            here = np.array([end_xy[0], end_xy[1], c.heading[0, k + 1]])
    if profile.holonomic:
        return [HolonomicMotion.make(points, pieces, yaw, target_yaw, profile)]
    # A differential base faces along its legs (against the first one when backing it),
    # turning in place where it stops.
    pose = np.array([points[0][0], points[0][1], float(yaw)])
    out: list[SmoothSegment] = []

    def turn_by(delta: float) -> None:
        nonlocal pose
        if abs(delta) > TINY:
            end = np.array([pose[0], pose[1], pose[2] + delta])
            out.append(SegmentSpec(_pose(pose), _pose(end), True, abs(delta)))
            pose = end

    if legs:
        flip = math.pi if c.backed[0] else 0.0
        turn_by(float(wrap(c.heading[0, 0] + flip - pose[2])))
        in_place = dict(turns)
        for i, piece in enumerate(pieces):
            if i in in_place:
                turn_by(in_place[i])
            shift = pose[2] - piece.start[2]
            if isinstance(piece, MovingDrive):
                piece = dataclasses.replace(piece, start=(*piece.start[:2], pose[2]),
                                            end=(*piece.end[:2], pose[2]))
            elif abs(shift) > 1e-12:
                piece = MovingTurn.make((*piece.start[:2], pose[2]), piece.angle,
                                        piece.speed, profile)
            out.append(piece)
            pose = np.array([piece.end[0], piece.end[1], piece.end[2]])
    turn_by(float(wrap(target_yaw - pose[2])))
    return out


def smooth_chain_time(profile: BaseProfile, points: np.ndarray, count: np.ndarray,
                      yaw0: np.ndarray, yaw1: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Smooth motion durations (s) of m paths at once, and the yaw each ends at (rad): the
    vectorised `smooth_segments`, each path given by its `points` (m, P, 2), the first
    `count` (m,) of each row (legs of at most TINY are left out); yaw0, yaw1 (m,), a NaN
    `yaw1` standing for "facing along the last leg" (no final turn unless the only leg was
    backed), as in `chain_time`."""
    m = len(points)
    yaw0 = np.asarray(yaw0, dtype=float).reshape(m)
    yaw1 = np.asarray(yaw1, dtype=float).reshape(m)
    c = path_corners(profile, points, count, yaw0, yaw1)
    rows = np.arange(m)
    j = np.arange(c.length.shape[1])[None, :]
    zero = np.zeros((m, 1))
    u_in = np.concatenate([zero, c.speed], axis=1)
    u_out = np.concatenate([c.speed, zero], axis=1)
    d_in = np.concatenate([zero, c.reach], axis=1)
    d_out = np.concatenate([c.reach, zero], axis=1)
    _, legs = leg_profile(c.length - d_in - d_out, u_in, u_out, profile.speed,
                          profile.acceleration)
    total = np.where(j < c.legs[:, None], legs, 0.0).sum(axis=1)
    inner = np.arange(c.angle.shape[1])[None, :] < c.count[:, None]
    moving = inner if not profile.holonomic else inner & (c.speed > 0)
    total += np.where(moving, profile.turn_time(c.angle), 0.0).sum(axis=1)
    travel_end = np.where(c.legs > 0, c.heading[rows, np.maximum(c.legs - 1, 0)], yaw0)
    if profile.holonomic:
        target = np.where(np.isnan(yaw1), travel_end, yaw1)
        return np.maximum(total, profile.turn_time(wrap(target - yaw0))), target
    flip = np.where(c.backed, math.pi, 0.0)
    start_turn = np.where(c.legs > 0, profile.turn_time(wrap(c.heading[:, 0] + flip - yaw0)),
                          0.0)
    heading_end = travel_end + np.where(c.backed & (c.legs == 1), math.pi, 0.0)
    target = np.where(np.isnan(yaw1), travel_end, yaw1)
    return total + start_turn + profile.turn_time(wrap(target - heading_end)), target


@dataclass(frozen=True)
class HolonomicMotion:
    """A holonomic base's whole motion (module docstring): its translation `pieces` (drives
    and moving turns of the direction of travel, whose own yaws are that direction), and
    its yaw turning from `start`'s through `angle` (rad) from the motion's start, with the
    profile of a turn in place (`yaw_peak`, `yaw_duration`)."""

    start: tuple[float, float, float]
    end: tuple[float, float, float]
    pieces: tuple[MovingDrive | MovingTurn, ...]
    angle: float
    yaw_peak: float
    yaw_acceleration: float
    yaw_duration: float
    duration: float
    turn = False

    @staticmethod
    def make(points: np.ndarray, pieces: Sequence[MovingDrive | MovingTurn], yaw: float,
             target_yaw: float, profile: BaseProfile) -> HolonomicMotion:
        delta = float(wrap(target_yaw - yaw))
        peak, yaw_duration = trapezoid(abs(delta), profile.yaw_rate, profile.yaw_acceleration)
        translate = sum(p.duration for p in pieces)
        last = points[-1]
        return HolonomicMotion((float(points[0][0]), float(points[0][1]), float(yaw)),
                               (float(last[0]), float(last[1]), float(yaw) + delta),
                               tuple(pieces), delta, peak, profile.yaw_acceleration,
                               yaw_duration, max(translate, yaw_duration))

    @property
    def length(self) -> float:
        return float(sum(p.length for p in self.pieces))

    def _yaw(self, tau: float) -> tuple[float, float]:
        if self.yaw_duration <= 0.0:
            return self.start[2], 0.0
        angle, rate = turned(tau, abs(self.angle), self.yaw_peak, self.yaw_acceleration,
                             self.yaw_duration)
        sign = 1.0 if self.angle >= 0 else -1.0
        return self.start[2] + sign * float(angle), sign * float(rate)

    def state(self, tau: float) -> list[float]:
        x, y, vx, vy = self.start[0], self.start[1], 0.0, 0.0
        rest = tau
        for piece in self.pieces:
            if rest < piece.duration:
                px, py, _, vx, vy, _ = piece.state(rest)
                x, y = px, py
                break
            rest -= piece.duration
        else:
            if self.pieces:
                x, y = self.pieces[-1].state(self.pieces[-1].duration)[:2]
            vx = vy = 0.0
        yaw, rate = self._yaw(tau)
        return [x, y, yaw, vx, vy, rate]

    def poses(self, step_xy: float, step_yaw: float) -> np.ndarray:
        """Poses (n, 3) along the motion, at most `step_xy` m and `step_yaw` rad apart."""
        n = max(1, math.ceil(max(self.length / step_xy, abs(self.angle) / step_yaw)))
        return np.array([self.state(self.duration * k / n)[:3] for k in range(n + 1)])
