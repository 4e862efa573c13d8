"""The base's motion to a landing, checked against a collision predicate, with the escapes
a blocked motion tries: what the BaseNavigator drives.

A motion is a chain of `BaseSegment`s, each a turn in place or a straight drive
(`base_motion.motion_segments`), timed with a trapezoidal speed profile (`MotionProfile`).
`cut_at_collision` samples its poses every CHECK_STEP_XY / CHECK_STEP_YAW and keeps it up
to the last free one: a collision within FINAL_APPROACH of the end of the driving, or in
the final turn, only shortens the landing; an earlier one, or one in the turn before any
driving, blocks the way. `plan_motion` makes the direct motion and, when it is blocked,
tries the escapes in turn (the first that is not blocked wins): the first turn the other
way round, keeping to the planned last leg, backing out or driving straight on
(ESCAPE_STEPS) before turning, and going back the way the base came (its trail). A
motion that lands short facing away from the stop's heading is replaced, where one fits,
by one that turns before the stop and drives the last APPROACH_STEPS straight in.

Nothing here knows the world: "free" is a `FreeTest` (base poses (n, 3) -> bool (n,)), so
that the search is tested on a predicate of a few lines.
"""

import dataclasses
import functools
import itertools
import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass

import numpy as np

from s3o_drake.feasibility.landing import (
    CHECK_STEP_XY,
    CHECK_STEP_YAW,
    FINAL_APPROACH,
    TURN_TOLERANCE,
    FreeTest,
    PaddedFree,
)
from s3o_drake.planning.navigation.base_motion import (
    ACCELERATION,
    STOP_AND_GO,
    TINY,
    YAW_ACCELERATION,
    YAW_RATE,
    BaseProfile,
    HolonomicMotion,
    MovingDrive,
    MovingTurn,
    SegmentSpec,
    motion_segments,
    smooth_segments,
    trapezoid,
)
from s3o_drake.world.angles import wrap

#: How far (m) the base may back straight out of a tight stop, or drive straight on, before
#: it turns, tried in turn (backing out first at each distance) when the direct motion is
#: blocked.
ESCAPE_STEPS = tuple(0.05 * k for k in range(1, 13))
#: A motion that drives at least this far (m) starts a new trail (`extend_trail`): the base
#: came from open floor.
RETRACE_RESET = 0.5
#: The base must stand within this (m, rad) of where its trail ends to retrace it.
RETRACE_TOLERANCE = 0.05
#: How far (m) before a stop the base may turn to the stop's heading and drive straight in,
#: tried in turn when the direct motion lands short.
APPROACH_STEPS = tuple(0.1 * k for k in range(1, 9))
#: The waypoints this close (m) to a stop are its lead in, moved with a smooth motion's
#: noisy landing (`shifted_lead`): two and a half standard deviations of the default noise.
LEAD = 0.25
#: A drive cut short of a collision ends at its last free sample only when the pose this
#: share of a check step beyond it (1 mm, 0.0025 rad) is free too, else a sample earlier:
#: the plant settles within a hair of its set point (0.00008 rad past a turn's end was
#: seen), and a sample that close to the collision left the base standing in it (a pickup
#: then failed "base_collision").
SETTLE_MARGIN = 0.05


@dataclass(frozen=True)
class BaseSegment:
    """A straight move from pose `start` to pose `end` (x, y, yaw): a drive (xy changes) or a
    turn (yaw changes), `length` m or rad long, run with a trapezoidal speed profile."""

    start: tuple[float, float, float]
    end: tuple[float, float, float]
    turn: bool
    length: float
    speed: float  # cruise speed actually reached (m/s or rad/s)
    accel: float
    duration: float

    @staticmethod
    def make(start: Sequence[float], end: Sequence[float], *, turn: bool, length: float,
             max_speed: float, accel: float) -> "BaseSegment":
        # The profile's arithmetic is the planner's too (planning/navigation/base_motion.py).
        speed, duration = trapezoid(length, max_speed, accel)
        return BaseSegment(tuple(map(float, start)), tuple(map(float, end)), turn, float(length),
                       speed, accel, duration)

    def at(self, tau: float) -> tuple[float, float]:
        """Distance travelled and its rate, `tau` s after the segment began."""
        tau = min(max(tau, 0.0), self.duration)
        t_ramp = self.speed / self.accel
        if tau < t_ramp:
            return 0.5 * self.accel * tau**2, self.accel * tau
        remaining = self.duration - tau
        if remaining < t_ramp:
            return self.length - 0.5 * self.accel * remaining**2, self.accel * remaining
        return 0.5 * self.speed * t_ramp + self.speed * (tau - t_ramp), self.speed

    def pose(self, s: float) -> np.ndarray:
        """The pose after travelling `s` along the segment."""
        a, b = np.asarray(self.start), np.asarray(self.end)
        return a + (b - a) * (s / self.length)

    def state(self, tau: float) -> list[float]:
        """[x, y, yaw, xdot, ydot, yawdot] `tau` s after the segment began."""
        # Plain floats: evaluated at every plant step, where numpy's per-call cost on
        # three-element arrays dominated.
        s, rate = self.at(tau)
        d = [(b - a) / self.length for a, b in zip(self.start, self.end, strict=True)]
        return [a + di * s for a, di in zip(self.start, d, strict=True)] + [di * rate
                                                                            for di in d]


Segment = BaseSegment | MovingDrive | MovingTurn | HolonomicMotion
"""A piece of a motion the navigator plays: a stop-and-go turn or drive (rest to rest), or
a smooth motion's drive, moving turn, or a holonomic base's whole motion
(`base_motion.smooth_segments`)."""


@dataclass(frozen=True)
class MotionProfile:
    """How fast the base moves: cruise `speed` (m/s) and `max_yaw_rate` (rad/s), reached and
    left at `acceleration` (m/s²) and `yaw_acceleration` (rad/s²)."""

    speed: float
    max_yaw_rate: float = YAW_RATE
    acceleration: float = ACCELERATION
    yaw_acceleration: float = YAW_ACCELERATION
    motion: str = STOP_AND_GO
    """`base_motion.STOP_AND_GO` or `SMOOTH`: how the base takes its path's corners."""
    holonomic: bool = False
    """The base can move sideways (smooth motion only)."""

    @property
    def base(self) -> BaseProfile:
        """The same limits as the planner's arithmetic names them."""
        return BaseProfile(speed=self.speed, acceleration=self.acceleration,
                           yaw_rate=self.max_yaw_rate,
                           yaw_acceleration=self.yaw_acceleration, motion=self.motion,
                           holonomic=self.holonomic)

    @property
    def smooth(self) -> bool:
        return self.motion != STOP_AND_GO

    def stop_and_go(self) -> "MotionProfile":
        """The same limits, stopping at every corner."""
        return dataclasses.replace(self, motion=STOP_AND_GO, holonomic=False)

    def segment(self, start: Sequence[float], end: Sequence[float], *, turn: bool,
                length: float) -> BaseSegment:
        if turn:
            return BaseSegment.make(start, end, turn=True, length=length,
                                max_speed=self.max_yaw_rate, accel=self.yaw_acceleration)
        return BaseSegment.make(start, end, turn=False, length=length, max_speed=self.speed,
                            accel=self.acceleration)

    def segments(self, waypoints: Sequence[np.ndarray], yaw: float, target_yaw: float, *,
                 long_way: bool = False, other_way: bool = False) -> list[Segment]:
        """The segments through the waypoints, then the turn to `target_yaw`: turn-then-
        drive (`base_motion.motion_segments`), or with smooth motion
        `base_motion.smooth_segments` (the rules the planner's cost model times; with
        `other_way`, the first leg driven the other way); with `long_way`, stop and go,
        the first turn the other way round."""
        if self.smooth and not long_way:
            return [self.segment(s.start, s.end, turn=True, length=s.length)
                    if isinstance(s, SegmentSpec) else s
                    for s in smooth_segments(self.base, waypoints, yaw, target_yaw,
                                             other_way=other_way)]
        return [self.segment(s.start, s.end, turn=s.turn, length=s.length)
                for s in motion_segments(waypoints, yaw, target_yaw, long_way=long_way)]


@dataclass(frozen=True)
class Cut:
    """A motion checked against the world: its `segments` up to the last free pose, whether
    the collision `blocked` the way (rather than shortening the landing), and the first
    colliding pose `hit` (None when none collides: the segments are the motion's own)."""

    segments: list[Segment]
    blocked: bool = False
    hit: np.ndarray | None = None


def facing(segments: Sequence[BaseSegment], yaw: float) -> bool:
    """Whether the motion ends facing `yaw` (within the landing model's TURN_TOLERANCE)."""
    return bool(segments) and abs(wrap(segments[-1].end[2] - yaw)) <= TURN_TOLERANCE


def plan_motion(base: np.ndarray, target: np.ndarray, *, path: Sequence[Sequence[float]],
                stop: Sequence[float], turn: bool, trail: tuple[BaseSegment, ...],
                free: FreeTest | None, profile: MotionProfile) -> Cut:
    """The motion from the true pose `base` (x, y, yaw) to the landing `target` (x, y, yaw)
    through the inner waypoints of `path` (its first and last stand for `base` and
    `target`), checked with `free` (None: everything is free), with the escapes of the
    module docstring when it is blocked. `stop`: the commanded stop (x, y), which the
    planned last leg runs to; `turn`: a turn in place where the base stands; `trail`: the
    way the base came (`extend_trail`)."""
    planned = [np.asarray(base[:2], float)]
    if not turn:
        planned += [np.asarray(p, float) for p in path[1:-1]]
        planned.append(target[:2])
    if not profile.smooth:
        return _escaped(base, target, planned, stop, turn, trail, free, profile)
    straight = profile.stop_and_go()
    # Caught where a smooth motion cannot stop within its limits, or landing short facing
    # away: the stop-and-go motion along the planned waypoints, and its escapes, which stop
    # anywhere.
    stop_and_go = functools.cache(
        lambda: _escaped(base, target, planned, stop, turn, trail, free, straight))
    cut = short = None
    for tried, taken in _smooth_motions(base, target, planned, stop=stop, turn=turn,
                                        trail=trail, free=free, profile=profile):
        if taken:
            cut = tried
            break
        short = short or tried
    if cut is None:
        # No smooth motion lands: the stop-and-go one, unless it does not land either (the
        # turn to the stop's heading is blocked at the stop, whichever way the base came)
        # and a smooth one that is not blocked ends as near: else a base that had to back
        # out of a tight stop would drive its whole way stopping at every corner.
        other = stop_and_go()
        if (short is not None and not _lands(other, target, turn)
                and (other.blocked or shortfall(short, base, target)
                     <= shortfall(other, base, target) + CHECK_STEP_XY)):
            return short
        return other
    if turn or cut.hit is None:
        return cut
    # A smooth motion that lands short (its curve, or its lead in moved with the noise,
    # meets the collision sooner than the planned leg, or an escape turned it round) gives
    # way to the stop-and-go motion where that lands nearer: Fea^m's landing model stops
    # short along the planned approach (`landing.stop_short`), and a base 0.4 m short
    # reaches nothing.
    other = stop_and_go()
    if (_lands(other, target, turn)
            and shortfall(other, base, target) < shortfall(cut, base, target) - CHECK_STEP_XY):
        return other
    return cut


def _lands(cut: Cut, target: np.ndarray, turn: bool) -> bool:
    """Whether the motion `cut` lands: not blocked, and free or short but facing the
    landing `target`'s heading (a turn in place: not blocked)."""
    return not cut.blocked and (turn or cut.hit is None or facing(cut.segments, target[2]))


def _smooth_motions(base: np.ndarray, target: np.ndarray, planned: list[np.ndarray], *,
                    stop: Sequence[float], turn: bool, trail: tuple[BaseSegment, ...],
                    free: FreeTest | None, profile: MotionProfile
                    ) -> Iterator[tuple[Cut, bool]]:
    """The smooth motions that are not blocked, in the order they are tried, each with
    whether it is taken: the first that lands (`_lands`) is, and ends the search. Tried:
    the direct motion, the same with its first leg driven the other way
    (`base_motion.fewer_turns_backing`), one that keeps to the planned last leg, one that
    drives smoothly to APPROACH_STEPS before the stop, turns there to the stop's heading
    and drives straight in; the escapes with the smooth motion; last, taken whenever it is
    not blocked, smooth to the path's last corner, stopping there, and the stop-and-go
    motion from there."""
    waypoints = planned if turn else shifted_lead(planned, stop, target)
    yaw, h = float(base[2]), np.array([math.cos(target[2]), math.sin(target[2])])
    straight = profile.stop_and_go()

    # Second: the first leg driven the other way (backed where the rule drives it
    # forwards, or the reverse), where the turn towards it is blocked.
    motions = itertools.chain(
        (profile.segments(waypoints, yaw, float(target[2]), other_way=other)
         for other in (False, True)),
        (profile.segments(way, yaw, float(target[2]))
         for way in along_plan(stop, waypoints, turn=turn)),
        ([] if turn else (
            [*profile.segments([*waypoints[:-1], target[:2] - d * h], yaw, float(target[2])),
             *straight.segments([target[:2] - d * h, target[:2]], float(target[2]),
                                float(target[2]))]
            for d in APPROACH_STEPS)))
    for segments in motions:
        cut = cut_at_collision(segments, free, profile)
        if cut.hit is None or _lands(cut, target, turn):
            yield cut, True
            return
        if not cut.blocked:
            yield cut, False
    cut = _escaped(base, target, waypoints, stop, turn, trail, free, profile)
    if _lands(cut, target, turn):
        yield cut, True
        return
    if not cut.blocked:
        yield cut, False
    if not turn and len(waypoints) > 2:
        corner = waypoints[-2]
        leg = waypoints[-1] - corner
        prefix = profile.segments(waypoints[:-1], yaw, math.atan2(leg[1], leg[0]))
        if prefix and cut_at_collision(prefix, free, profile).hit is None:
            rest = plan_motion(np.asarray(prefix[-1].end, dtype=float), target,
                               path=[corner, target[:2]], stop=stop, turn=False,
                               trail=(), free=free, profile=straight)
            if not rest.blocked:
                yield Cut([*prefix, *rest.segments], hit=rest.hit), True


def shortfall(cut: Cut, base: np.ndarray, target: np.ndarray) -> float:
    """How far (m) from the landing `target` the motion `cut` ends (from `base`, it has no
    segments)."""
    end = np.asarray(cut.segments[-1].end if cut.segments else base, dtype=float)
    return float(np.hypot(*(end[:2] - np.asarray(target[:2], dtype=float))))


def _escaped(base: np.ndarray, target: np.ndarray, waypoints: list[np.ndarray],
             stop: Sequence[float], turn: bool, trail: tuple[BaseSegment, ...],
             free: FreeTest | None, profile: MotionProfile) -> Cut:
    """The direct motion through `waypoints` with `profile`, or when it is blocked the first
    escape that is not, or when it lands short facing away a straight approach that faces
    (`plan_motion`'s docstring)."""
    # A turn turns where the base stands: its pose's x, y are where the planner saw the
    # base a control period earlier, and the base has since drifted by micrometres (the
    # arm's motion pushes it against its PD); driving there first meant turning towards
    # that micro-drive, up to π/2 out of the way and back.
    cut = cut_at_collision(profile.segments(waypoints, float(base[2]), float(target[2])),
                           free, profile)
    if cut.blocked:
        # The noisy landing left the base where the turn towards the path hits something
        # (a stop only keeps the inscribed radius): first turn the other way round,
        # then back straight out or drive straight on (ESCAPE_STEPS, the shortest
        # first) before turning.
        yaw = float(base[2])
        heading = np.array([math.cos(yaw), math.sin(yaw)])
        # Built one at a time: the first that is not blocked ends the search.
        # The way in, each of them then retraced: a base that backs out of a pocket
        # it drove into may still need to keep to the planned leg of the next one.
        ways = [waypoints, *along_plan(stop, waypoints, turn=turn)]
        escapes = itertools.chain(
            [profile.segments(waypoints, yaw, float(target[2]), long_way=True)],
            (profile.segments(way, yaw, float(target[2])) for way in ways[1:]),
            (_straight_out(waypoints, yaw, d * heading, float(target[2]), profile)
             for step in ESCAPE_STEPS for d in (-step, step)),
            itertools.chain.from_iterable(
                retrace(trail, base, way, float(target[2]), profile) for way in ways))
        for escape in escapes:
            escaped = cut_at_collision(escape, free, profile)
            if not escaped.blocked:
                return escaped
    elif cut.hit is not None and not turn and not facing(cut.segments, target[2]):
        # Landed short, facing away from the stop's heading: the final turn towards the
        # dish hits something (a noisy landing between a chair and the bar: the pickups
        # then failed, the arm facing away). Turn before, where there is room, and drive
        # the last APPROACH_STEPS straight in along the stop's heading, as Fea^m's landing
        # model has it (`landing.stop_short`: a landing that collides stops short along
        # its heading, facing the dish).
        h = np.array([math.cos(target[2]), math.sin(target[2])])
        for d in APPROACH_STEPS:
            approach = profile.segments([*waypoints[:-1], target[:2] - d * h, target[:2]],
                                        float(base[2]), float(target[2]))
            approached = cut_at_collision(approach, free, profile)
            if not approached.blocked and facing(approached.segments, target[2]):
                return approached
    return cut


def _straight_out(waypoints: list[np.ndarray], yaw: float, move: np.ndarray,
                  target_yaw: float, profile: MotionProfile) -> list[Segment]:
    """The motion through `waypoints` that first moves the base straight by `move` (x, y)
    along its heading `yaw`, backing or driving on. A smooth motion then leaves from there
    as from a stop, its first leg backed where that turns the base less
    (`base_motion.fewer_turns_backing`), as the plan's motion from a stop is: taken as
    one more leg, the next leg was driven forwards whatever it cost, a turn round at each
    of its ends where backing it turned a little once. Stop and go, the paper's motion,
    takes the waypoints as they come."""
    start = waypoints[0]
    if not profile.smooth:
        return profile.segments([start, start + move, *waypoints[1:]], yaw, target_yaw)
    out = profile.stop_and_go().segment((*start, yaw), (*(start + move), yaw), turn=False,
                                        length=float(np.linalg.norm(move)))
    return [out, *profile.segments([start + move, *waypoints[1:]], yaw, target_yaw)]


def shifted_lead(waypoints: list[np.ndarray], stop: Sequence[float],
                 target: np.ndarray) -> list[np.ndarray]:
    """The waypoints with the inner ones within LEAD of the commanded `stop` moved as the
    landing `target` is off it: the path's last leg joins the stop to the map's driveable
    region, a few centimetres long as planned, and the landing noise would otherwise turn
    it any way (the base turned round for a 4 cm leg). A smooth motion comes in along it
    as planned, only beside it."""
    way = [np.asarray(w, dtype=float) for w in waypoints]
    stop = np.asarray(stop[:2], dtype=float)
    offset = np.asarray(target[:2], dtype=float) - stop
    for k in range(len(way) - 2, 0, -1):
        if np.linalg.norm(way[k] - stop) >= LEAD:
            break
        way[k] = way[k] + offset
    return way


def along_plan(stop: Sequence[float], waypoints: list[np.ndarray], *, turn: bool
               ) -> Iterator[list[np.ndarray]]:
    """Waypoints that keep to the planned last leg, towards the commanded `stop`, and turn
    off it to the noisy landing (`waypoints[-1]`) only APPROACH_STEPS before the stop,
    the nearest first. The straight drive from the last waypoint to the landing swings
    the whole leg by the noise; next to a chair, its first metre then clips what the
    planned leg clears (a 1 m leg, 10 cm of noise, blocked 4 cm after the turn)."""
    if turn or len(waypoints) < 2:
        return
    stop = np.asarray(stop[:2], dtype=float)
    leg = stop - waypoints[-2]
    length = float(np.linalg.norm(leg))
    for d in APPROACH_STEPS:
        if d >= length:
            return
        yield [*waypoints[:-1], stop - d * leg / length, waypoints[-1]]


def retrace(trail: tuple[BaseSegment, ...], base: np.ndarray, waypoints: list[np.ndarray],
            target_yaw: float, profile: MotionProfile) -> Iterator[list[BaseSegment]]:
    """The last escape: back the way the base came (`trail`, undone move by move: its
    turns turned back, its drives driven in reverse), to where the last long drive's
    last leg began, then on to the waypoints; none when the base no longer stands
    where the trail ends. In an aisle too narrow to turn in (the dense restaurant's
    0.85 m), a noisy landing leaves the base where it can neither turn towards its
    next path nor back out by ESCAPE_STEPS, but the way in is free."""
    if not trail:
        return
    end = np.asarray(trail[-1].end)
    if (np.linalg.norm(end[:2] - base[:2]) > RETRACE_TOLERANCE
            or abs(wrap(end[2] - base[2])) > RETRACE_TOLERANCE):
        return
    back = [profile.segment(seg.end, seg.start, turn=seg.turn, length=seg.length)
            for seg in reversed(trail)]
    origin = np.asarray(trail[0].start)
    yield back + profile.segments([origin[:2], *waypoints[1:]], float(origin[2]), target_yaw)


def cut_at_collision(segments: list[BaseSegment], free: FreeTest | None,
                     profile: MotionProfile) -> Cut:
    """The segments up to the last free pose, whether the collision blocks the way, and
    the first colliding pose (see `Cut`). Collisions at the very start (the base already
    stands there) are ignored until the first free pose; with a `PaddedFree` test only
    those within the padding: a pose on the way out that touches is a collision."""
    if free is None or not segments:
        return Cut(segments)
    # Samples: (segment index, distance along it, pose); index -1 is the start pose.
    samples = [(-1, 0.0, np.asarray(segments[0].start))]
    for i, seg in enumerate(segments):
        samples += [(i, s, pose) for s, pose in _samples(seg)]
    poses = np.array([pose for _, _, pose in samples])
    is_free = free(poses)
    first_free = int(np.argmax(is_free)) if is_free.any() else len(is_free)
    colliding = np.zeros(len(poses), dtype=bool)
    colliding[first_free:] = ~is_free[first_free:]
    if isinstance(free, PaddedFree) and first_free > 1:
        # A landing left the base within the padding: it may turn or drive out of it,
        # but a turn that swings a corner of the base into a table leg is a collision.
        colliding[1:first_free] = ~free.untouched(poses[1:first_free])
    if not colliding.any():
        return Cut(segments)
    hit = int(np.argmax(colliding))
    last = hit - 1
    if last > first_free and not free(nudged(samples[last][2], samples[hit][2])[None])[0]:
        # The collision begins a hair past the last free pose: the plant, which settles
        # within a hair of its set point, would stand in it. Stop a step earlier.
        last -= 1
    last_i, last_s, _ = samples[last]
    kept = list(segments[:last_i]) if last_i >= 0 else []
    if last_i >= 0 and last_s > TINY:
        seg = segments[last_i]
        part = seg if last_s >= seg.length - TINY else _truncated(seg, last_s, profile)
        if part is None:  # a smooth motion that cannot stop there within its limits
            return Cut(kept, blocked=True, hit=samples[hit][2])
        kept.append(part)
    if kept and not _ends_at_rest(kept[-1]):
        return Cut(kept, blocked=True, hit=samples[hit][2])
    return Cut(kept, blocked=blocks(segments, samples[hit][:2]), hit=samples[hit][2])


def _samples(seg: Segment) -> list[tuple[float, np.ndarray]]:
    """(distance along, pose) every CHECK_STEP_XY of travel and CHECK_STEP_YAW of turning
    along a segment, its end included, its start not."""
    if isinstance(seg, HolonomicMotion):
        poses = seg.poses(CHECK_STEP_XY, CHECK_STEP_YAW)
        n = len(poses) - 1
        return [(seg.length * k / n, poses[k]) for k in range(1, n + 1)]
    if isinstance(seg, MovingTurn):
        n = max(1, math.ceil(max(seg.length / CHECK_STEP_XY, abs(seg.angle) / CHECK_STEP_YAW)))
    else:
        n = max(1, math.ceil(seg.length / (CHECK_STEP_YAW if seg.turn else CHECK_STEP_XY)))
    return [(seg.length * k / n, seg.pose(seg.length * k / n)) for k in range(1, n + 1)]


def _truncated(seg: Segment, s: float, profile: MotionProfile) -> Segment | None:
    """The segment's first `s` (m or rad), ending at rest; None where it cannot stop
    there within the profile's limits (a moving turn, or a drive that must brake
    sooner)."""
    if isinstance(seg, BaseSegment):
        return profile.segment(seg.start, seg.pose(s), turn=seg.turn, length=s)
    if isinstance(seg, MovingDrive) and seg.u0**2 <= 2.0 * seg.acceleration * s:
        end = seg.pose(s)
        return MovingDrive.make(seg.start, (end[0], end[1], seg.start[2]), u0=seg.u0, u1=0.0,
                                profile=profile.base)
    return None


def _ends_at_rest(seg: Segment) -> bool:
    return isinstance(seg, BaseSegment | HolonomicMotion) or (
        isinstance(seg, MovingDrive) and seg.u1 == 0.0)


def nudged(free_pose: np.ndarray, colliding_pose: np.ndarray) -> np.ndarray:
    """The pose SETTLE_MARGIN of the way from a free sample to the colliding one."""
    step = np.asarray(colliding_pose, dtype=float) - free_pose
    step[2] = wrap(step[2])
    return free_pose + SETTLE_MARGIN * step


def blocks(segments: Sequence[BaseSegment], hit: tuple[int, float]) -> bool:
    """Whether a collision `hit` = (segment index, distance along it) blocks the way,
    rather than only shortening the landing."""
    i, s = hit
    drives = [0.0 if seg.turn else seg.length for seg in segments]
    final_turn = segments[i].turn and i == len(segments) - 1
    travelled = sum(drives[:i]) + (0.0 if segments[i].turn else s)
    # A turn before any driving that collides is no landing short, however short the
    # drive after it (a corrective move of 10 cm next to a table): it is blocked, so that
    # the escapes (the other way round, backing out first) get their try.
    turn_first = segments[i].turn and travelled == 0.0 and sum(drives) > 0.0
    return turn_first or not (final_turn or travelled >= sum(drives) - FINAL_APPROACH)


def extend_trail(before: tuple[Segment, ...], segments: Sequence[Segment]
                 ) -> tuple[Segment, ...]:
    """The way the base came after a motion of `segments`: from its last drive leg on
    when it drove at least RETRACE_RESET, else `before` and the motion."""
    curved = [i for i, seg in enumerate(segments)
              if isinstance(seg, MovingTurn | HolonomicMotion)]
    if curved:
        # Only straight moves are retraced: the way came after the motion's last curve.
        before, segments = (), segments[curved[-1] + 1:]
    drives = [i for i, seg in enumerate(segments) if not seg.turn]
    if drives and sum(segments[i].length for i in drives) >= RETRACE_RESET:
        return tuple(segments[drives[-1]:])
    return (*before, *segments)
