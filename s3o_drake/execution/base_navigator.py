"""The base's local planner and trajectory source: drives a `BaseCommand`'s path.

A command's motion is a chain of segments, each either a turn in place or a straight drive
(the base drives where it faces, or backs straight away from a stop when the path leaves
behind it), with a trapezoidal speed profile: cruise at the planner's
speed v (or `max_yaw_rate` when turning), accelerate and brake at a fixed rate so that the
PD-controlled plant can follow. The landing is the command's pose plus the navigation noise
T^n, drawn from the command's own random stream so that a seed fixes every landing whatever
else happens in the run. Before the motion starts its poses are checked against the true
world; a base that would collide stops at the last free pose, as a local planner
stops short.
"""

import itertools
import math
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import BasicVector, Context, EventStatus, LeafSystem, State

from s3o_drake.execution.messages import NO_COMMAND, BaseCommand, CommandState, Status
from s3o_drake.feasibility.landing import (
    CHECK_STEP_XY,
    CHECK_STEP_YAW,
    FINAL_APPROACH,
    TURN_TOLERANCE,
)
from s3o_drake.feasibility.scene import FeasibilityScene
from s3o_drake.planning.navigation.base_motion import (
    ACCELERATION,
    SETTLE_TIME,
    TINY,
    YAW_ACCELERATION,
    YAW_RATE,
    motion_segments,
    trapezoid,
)
from s3o_drake.world.angles import wrap
from s3o_drake.world.robot import ARM_STOW, GRIPPER_OPEN, NUM_POSITIONS, robot_positions
from s3o_drake.world.scenario import Scenario
from s3o_drake.world.system_lifetime import weak_callback

#: How far (m) the base may back straight out of a tight stop, or drive straight on, before
#: it turns, tried in turn (backing out first at each distance) when the direct motion is
#: blocked.
ESCAPE_STEPS = tuple(0.05 * k for k in range(1, 13))
#: A motion that drives at least this far (m) starts a new trail (`_trail`): the base came
#: from open floor.
RETRACE_RESET = 0.5
#: The base must stand within this (m, rad) of where its trail ends to retrace it.
RETRACE_TOLERANCE = 0.05
#: How far (m) before a stop the base may turn to the stop's heading and drive straight in,
#: tried in turn when the direct motion lands short.
APPROACH_STEPS = tuple(0.1 * k for k in range(1, 9))


def _facing(segments: list["_Segment"], yaw: float) -> bool:
    """Whether the motion ends facing `yaw` (within the landing model's TURN_TOLERANCE)."""
    return bool(segments) and abs(wrap(segments[-1].end[2] - yaw)) <= TURN_TOLERANCE


#: A drive cut short of a collision ends at its last free sample only when the pose this
#: share of a check step beyond it (1 mm, 0.0025 rad) is free too, else a sample earlier:
#: the plant settles within a hair of its set point (0.00008 rad past a turn's end was
#: seen), and a sample that close to the collision left the base standing in it (a pickup
#: then failed "base_collision"; 2 of 1222 in the open-loop study).
SETTLE_MARGIN = 0.05


@dataclass(frozen=True)
class _Segment:
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
    def make(start, end, *, turn: bool, length: float, max_speed: float,
             accel: float) -> "_Segment":
        # The profile's arithmetic is the planner's too (planning/navigation/base_motion.py).
        speed, duration = trapezoid(length, max_speed, accel)
        return _Segment(tuple(map(float, start)), tuple(map(float, end)), turn, float(length),
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


@dataclass(frozen=True)
class _Motion:
    """What the navigator is doing (its abstract state): command `id` started at `t0` (s),
    playing `segments` from `hold` (the pose before the first one, and the pose kept when
    there are none), ending in `outcome` (done or failed) with `reason`."""

    id: int = NO_COMMAND
    t0: float = 0.0
    hold: tuple[float, float, float] = (0.0, 0.0, 0.0)
    segments: tuple[_Segment, ...] = ()
    outcome: CommandState = CommandState.DONE
    reason: str = ""
    contact: tuple[float, float] | None = None
    trail: tuple[_Segment, ...] = ()
    """The way the base came to where this motion ends: the last drive leg of the last
    motion that drove at least RETRACE_RESET, and every move since (`_trail`)."""
    initialized: bool = False

    def __deepcopy__(self, memo: dict) -> "_Motion":
        # Immutable all the way down: Drake clones abstract state on every update, and a
        # real deep copy of the segments was a sixth of the simulation's time.
        return self

    @property
    def duration(self) -> float:
        return sum(seg.duration for seg in self.segments)

    @property
    def end(self) -> np.ndarray:
        return np.asarray(self.segments[-1].end if self.segments else self.hold)

    def desired(self, t: float) -> np.ndarray:
        """[x, y, yaw, xdot, ydot, yawdot] at time t."""
        tau = t - self.t0
        for seg in self.segments:
            if tau < seg.duration:
                # Plain floats: evaluated at every plant step, where numpy's per-call cost
                # on three-element arrays dominated.
                s, rate = seg.at(tau)
                d = [(b - a) / seg.length for a, b in zip(seg.start, seg.end, strict=True)]
                return np.array([a + di * s for a, di in zip(seg.start, d, strict=True)]
                                + [di * rate for di in d])
            tau -= seg.duration
        return np.concatenate([self.end, np.zeros(3)])


class BaseNavigator(LeafSystem):
    """Drives the base along a `BaseCommand`'s path to its noisy landing pose.

    Input ports:
        base_command (abstract `BaseCommand`): a new `id` starts a command; id 0 holds still.
        robot_state (vector 22): the robot's 11 positions then 11 velocities; the base pose
            (x, y, yaw) is positions 0..2.
    Output ports:
        base_desired_state (vector 6): x, y, yaw (m, rad) then their rates (m/s, rad/s).
        status (abstract `Status`): CommandState idle before any command, running while the
            motion plays, then done (landed, possibly short of a colliding goal) or failed
            with reason "blocked" (stopped far from the goal by a collision) and the
            `contact` where it touched, `settle_time` after the motion ended.

    Every `control_period` s (and at initialization, and on a forced unrestricted update)
    it compares the command's id with the one it executes; on a new id it plans the whole
    motion from where the base actually is: the waypoints of `command.path` (the first is
    replaced by the base's position, the last by the landing), each drive preceded by a turn
    in place toward its heading, and a final turn to the landing yaw; a `turn` command only
    turns, where the base stands. Yaw stays continuous (no 2 pi jumps), so the desired yaw
    equals the landing's only modulo 2 pi.

    The landing is `command.pose` + (dx, dy, dyaw) with dx, dy ~ N(0, nav_xy_std^2) and
    dyaw ~ N(0, nav_yaw_std^2) from numpy.random.default_rng([seed, 1, command.id]), or
    exactly `command.pose` with `noise=False`. With a `scene` (the true world), poses every
    2 cm / 0.05 rad along the motion are checked (inside the room and collision-free, arm
    stowed); the motion is cut at the last free pose before the first collision. A
    collision within the last 0.5 m of driving or in the final turn ends the command done
    there (landed short); an earlier one, or one in the turn before the first drive (however
    short the drive), ends it failed, reason "blocked". Collisions at
    the very start (the base already stands there) are ignored until the first free pose.
    Before giving up on a blocked motion it tries, in turn, the first turn the other way
    round, then backing straight out or driving straight on by 5, 10, ... 60 cm before
    turning (a noisy landing can leave the base where the rectangle cannot turn towards the
    path; backed against a bar, only ahead is open: task_089): the first of these that is
    not blocked is driven.
    """

    def __init__(self, *, scenario: Scenario, scene: FeasibilityScene | None,
                 seed: int | None = None, control_period: float = 0.01,
                 max_yaw_rate: float = YAW_RATE, noise: bool = True,
                 settle_time: float = SETTLE_TIME, acceleration: float = ACCELERATION,
                 yaw_acceleration: float = YAW_ACCELERATION) -> None:
        super().__init__()
        self._speed = scenario.planner.speed
        self._xy_std = scenario.uncertainty.nav_xy_std if noise else 0.0
        self._yaw_std = scenario.uncertainty.nav_yaw_std if noise else 0.0
        self._seed = scenario.seed if seed is None else seed
        self._scene = scene
        self._max_yaw_rate = max_yaw_rate
        self._settle_time = settle_time
        self._accel = acceleration
        self._yaw_accel = yaw_acceleration

        self._command_port = self.DeclareAbstractInputPort(
            "base_command", AbstractValue.Make(BaseCommand()))
        self._state_port = self.DeclareVectorInputPort("robot_state", 2 * NUM_POSITIONS)
        # Until the initialization event reads robot_state, hold the scenario's start pose
        # (where the world puts the robot by default).
        start = tuple(float(v) for v in scenario.robot.start)
        self._motion_index = self.DeclareAbstractState(
            AbstractValue.Make(_Motion(hold=start)))
        # Outputs depend on time and state only: no direct feedthrough from robot_state,
        # so the navigator can close the loop with the plant.
        prerequisites = {self.time_ticket(), self.abstract_state_ticket(self._motion_index)}
        self.DeclareVectorOutputPort("base_desired_state", 6,
                                     weak_callback(self._calc_desired_state),
                                     prerequisites_of_calc=prerequisites)
        self.DeclareAbstractOutputPort("status", lambda: AbstractValue.Make(Status()),
                                       weak_callback(self._calc_status),
                                       prerequisites_of_calc=prerequisites)
        self.DeclareInitializationUnrestrictedUpdateEvent(weak_callback(self._update))
        self.DeclarePeriodicUnrestrictedUpdateEvent(control_period, 0.0,
                                                    weak_callback(self._update))
        self.DeclareForcedUnrestrictedUpdateEvent(weak_callback(self._update))

    def _motion(self, context: Context) -> _Motion:
        return context.get_abstract_state(self._motion_index).get_value()

    def _update(self, context: Context, state: State) -> EventStatus:
        motion = self._motion(context)
        command: BaseCommand = self._command_port.Eval(context)
        t = context.get_time()
        if not motion.initialized:
            base = self._state_port.Eval(context)[:3]
            motion = _Motion(id=NO_COMMAND, hold=tuple(map(float, base)), initialized=True)
        elif command.id == motion.id:
            return EventStatus.DidNothing()
        if command.id == NO_COMMAND:
            # Cancelled (or never started): stop where the motion is now.
            here = motion.desired(t)[:3]
            new = _Motion(id=NO_COMMAND, t0=t, hold=tuple(map(float, here)),
                          trail=motion.trail, initialized=True)
        else:
            base = self._state_port.Eval(context)[:3]
            new = self._plan(command, base, t, motion.trail)
        state.get_mutable_abstract_state(self._motion_index).set_value(new)
        return EventStatus.Succeeded()

    def _landing(self, command: BaseCommand) -> np.ndarray:
        """The pose (x, y, yaw) the command aims for: its pose plus the seeded noise T^n
        (none for a turn in place)."""
        if command.turn:
            return np.asarray(command.pose, dtype=float)
        rng = np.random.default_rng([self._seed, 1, command.id])
        noise = rng.normal(0.0, 1.0, 3) * [self._xy_std, self._xy_std, self._yaw_std]
        return np.asarray(command.pose, dtype=float) + noise

    def _plan(self, command: BaseCommand, base: np.ndarray, t: float,
              trail: tuple[_Segment, ...] = ()) -> _Motion:
        target = self._landing(command)
        waypoints = [np.asarray(base[:2], float)]
        if not command.turn:
            waypoints += [np.asarray(p, float) for p in command.path[1:-1]]
            waypoints.append(target[:2])
        # A turn turns where the base stands: its pose's x, y are where the planner saw the
        # base a control period earlier, and the base has since drifted by micrometres (the
        # arm's motion pushes it against its PD); driving there first meant turning towards
        # that micro-drive, up to π/2 out of the way and back.
        segments = self._segments(waypoints, float(base[2]), float(target[2]))
        cut = self._cut_at_collision(segments)
        if cut[1] is CommandState.FAILED:
            # The noisy landing left the base where the turn towards the path hits something
            # (a stop only keeps the inscribed radius): first turn the other way round,
            # then back straight out or drive straight on (ESCAPE_STEPS, the shortest
            # first) before turning.
            yaw = float(base[2])
            heading = np.array([math.cos(yaw), math.sin(yaw)])
            # Built one at a time: the first that is not blocked ends the search.
            # The way in, each of them then retraced: a base that backs out of a pocket
            # it drove into may still need to keep to the planned leg of the next one.
            ways = [waypoints, *self._along_plan(command, waypoints)]
            escapes = itertools.chain(
                [self._segments(waypoints, yaw, float(target[2]), long_way=True)],
                (self._segments(way, yaw, float(target[2])) for way in ways[1:]),
                (self._segments([waypoints[0], waypoints[0] + d * heading, *waypoints[1:]],
                                yaw, float(target[2]))
                 for step in ESCAPE_STEPS for d in (-step, step)),
                itertools.chain.from_iterable(
                    self._retrace(trail, base, way, float(target[2])) for way in ways))
            for escape in escapes:
                escaped = self._cut_at_collision(escape)
                if escaped[1] is not CommandState.FAILED:
                    cut = escaped
                    break
        elif cut[0] is not segments and not command.turn and not _facing(cut[0], target[2]):
            # Landed short, facing away from the stop's heading: the final turn towards the
            # dish hits something (a noisy landing between a chair and the bar, task_089:
            # the pickups then failed, the arm facing away). Turn before, where there is
            # room, and drive the last APPROACH_STEPS straight in along the stop's heading,
            # as Fea^m's landing model has it (`landing.stop_short`: a landing that collides
            # stops short along its heading, facing the dish).
            h = np.array([math.cos(target[2]), math.sin(target[2])])
            for d in APPROACH_STEPS:
                approach = self._segments([*waypoints[:-1], target[:2] - d * h, target[:2]],
                                          float(base[2]), float(target[2]))
                approached = self._cut_at_collision(approach)
                if approached[1] is CommandState.DONE and _facing(approached[0], target[2]):
                    cut = approached
                    break
        segments, outcome, reason, hit = cut
        # What blocked the base, where it touched: the bumper's reading on the status.
        contact = (self._scene.clearance.contact(hit)
                   if outcome is CommandState.FAILED and hit is not None else None)
        hold = tuple(float(v) for v in base[:3])
        return _Motion(id=command.id, t0=t, hold=hold, segments=tuple(segments),
                       outcome=outcome, reason=reason, contact=contact,
                       trail=_trail(trail, segments), initialized=True)

    def _along_plan(self, command: BaseCommand, waypoints: list[np.ndarray]
                    ) -> Iterator[list[np.ndarray]]:
        """Waypoints that keep to the planned last leg, towards the commanded stop, and turn
        off it to the noisy landing (`waypoints[-1]`) only APPROACH_STEPS before the stop,
        the nearest first. The straight drive from the last waypoint to the landing swings
        the whole leg by the noise; next to a chair, its first metre then clips what the
        planned leg clears (dense task_033: a 1 m leg, 10 cm of noise, blocked 4 cm after
        the turn)."""
        if command.turn or len(waypoints) < 2:
            return
        stop = np.asarray(command.pose[:2], dtype=float)
        leg = stop - waypoints[-2]
        length = float(np.linalg.norm(leg))
        for d in APPROACH_STEPS:
            if d >= length:
                return
            yield [*waypoints[:-1], stop - d * leg / length, waypoints[-1]]

    def _retrace(self, trail: tuple[_Segment, ...], base: np.ndarray,
                 waypoints: list[np.ndarray], target_yaw: float) -> Iterator[list[_Segment]]:
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
        back = [self._segment(seg.end, seg.start, turn=seg.turn, length=seg.length)
                for seg in reversed(trail)]
        origin = np.asarray(trail[0].start)
        yield back + self._segments([origin[:2], *waypoints[1:]], float(origin[2]), target_yaw)

    def _segments(self, waypoints: list[np.ndarray], yaw: float, target_yaw: float, *,
                  long_way: bool = False) -> list[_Segment]:
        """Turn-then-drive segments through the waypoints, then the turn to `target_yaw`
        (`base_motion.motion_segments`: the rule the planner's cost model times); with
        `long_way`, the first turn goes the other way round."""
        return [self._segment(s.start, s.end, turn=s.turn, length=s.length)
                for s in motion_segments(waypoints, yaw, target_yaw, long_way=long_way)]

    def _segment(self, start, end, *, turn: bool, length: float) -> _Segment:
        if turn:
            return _Segment.make(start, end, turn=True, length=length,
                                 max_speed=self._max_yaw_rate, accel=self._yaw_accel)
        return _Segment.make(start, end, turn=False, length=length, max_speed=self._speed,
                             accel=self._accel)

    def _cut_at_collision(self, segments: list[_Segment]
                          ) -> tuple[list[_Segment], CommandState, str, np.ndarray | None]:
        """The segments up to the last free pose, how the command ends (with the
        failure's reason), and the first colliding pose (None when none collides)."""
        if self._scene is None or not segments:
            return segments, CommandState.DONE, "", None
        # Samples: (segment index, distance along it, pose); index -1 is the start pose.
        samples = [(-1, 0.0, np.asarray(segments[0].start))]
        for i, seg in enumerate(segments):
            n = max(1, math.ceil(seg.length / (CHECK_STEP_YAW if seg.turn else CHECK_STEP_XY)))
            samples += [(i, seg.length * k / n, seg.pose(seg.length * k / n))
                        for k in range(1, n + 1)]
        free = self._free(np.array([pose for _, _, pose in samples]))
        first_free = int(np.argmax(free)) if free.any() else len(free)
        colliding = np.flatnonzero(~free[first_free:])
        if colliding.size == 0:
            return segments, CommandState.DONE, "", None
        hit = first_free + int(colliding[0])
        last = hit - 1
        if last > first_free and not self._free(
                self._nudged(samples[last][2], samples[hit][2])[None])[0]:
            # The collision begins a hair past the last free pose: the plant, which settles
            # within a hair of its set point, would stand in it. Stop a step earlier.
            last -= 1
        last_i, last_s, _ = samples[last]
        kept = list(segments[:last_i]) if last_i >= 0 else []
        if last_i >= 0 and last_s > TINY:
            seg = segments[last_i]
            if last_s >= seg.length - TINY:
                kept.append(seg)
            else:
                kept.append(self._segment(seg.start, seg.pose(last_s), turn=seg.turn,
                                          length=last_s))
        return kept, *self._outcome(segments, samples[hit]), samples[hit][2]

    @staticmethod
    def _nudged(free_pose: np.ndarray, colliding_pose: np.ndarray) -> np.ndarray:
        """The pose SETTLE_MARGIN of the way from a free sample to the colliding one."""
        step = np.asarray(colliding_pose, dtype=float) - free_pose
        step[2] = wrap(step[2])
        return free_pose + SETTLE_MARGIN * step

    @staticmethod
    def _outcome(segments: list[_Segment], hit: tuple) -> tuple[CommandState, str]:
        """Whether a collision at sample `hit` only shortens the landing or blocks the way."""
        i, s, _ = hit
        drives = [0.0 if seg.turn else seg.length for seg in segments]
        final_turn = segments[i].turn and i == len(segments) - 1
        travelled = sum(drives[:i]) + (0.0 if segments[i].turn else s)
        # A turn before any driving that collides is no landing short, however short the
        # drive after it (a corrective move of 10 cm next to a table): it is blocked, so that
        # the escapes (the other way round, backing out first) get their try.
        turn_first = segments[i].turn and travelled == 0.0 and sum(drives) > 0.0
        if not turn_first and (final_turn or travelled >= sum(drives) - FINAL_APPROACH):
            return CommandState.DONE, ""
        return CommandState.FAILED, "blocked"

    def _free(self, poses: np.ndarray) -> np.ndarray:
        """bool (n,): base poses inside the room and collision-free with the arm stowed."""
        clearance = self._scene.clearance
        free = clearance.in_room(poses[:, :2])
        # Far from every obstacle needs no collision query (a sound shortcut).
        query = free & ~clearance.certainly_free(poses[:, :2])
        if query.any():
            configs = [robot_positions(*p, arm=ARM_STOW, gripper=GRIPPER_OPEN)
                       for p in poses[query]]
            checked = self._scene.checker.CheckConfigsCollisionFree(configs)
            free[query] = np.asarray(checked, dtype=bool)
        return free

    def _calc_desired_state(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(self._motion(context).desired(context.get_time()))

    def _calc_status(self, context: Context, output: AbstractValue) -> None:
        motion = self._motion(context)
        if motion.id == NO_COMMAND:
            output.set_value(Status())
        elif context.get_time() < motion.t0 + motion.duration + self._settle_time:
            output.set_value(Status(id=motion.id, state=CommandState.RUNNING))
        else:
            output.set_value(Status(id=motion.id, state=motion.outcome, reason=motion.reason,
                                    contact=motion.contact))


def _trail(before: tuple[_Segment, ...], segments: list[_Segment]) -> tuple[_Segment, ...]:
    """The trail after a motion of `segments` (see `_Motion.trail`): from its last drive
    leg on when it drove at least RETRACE_RESET, else `before` and the motion."""
    drives = [i for i, seg in enumerate(segments) if not seg.turn]
    if drives and sum(segments[i].length for i in drives) >= RETRACE_RESET:
        return tuple(segments[drives[-1]:])
    return (*before, *segments)
