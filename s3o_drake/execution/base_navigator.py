"""The base's local planner and trajectory source: drives a `BaseCommand`'s path.

A command's motion is a chain of segments, each either a turn in place or a straight drive
(the base drives where it faces, or backs straight away from a stop when the path leaves
behind it), with a trapezoidal speed profile: cruise at the planner's
speed v (or `max_yaw_rate` when turning), accelerate and brake at a fixed rate so that the
PD-controlled plant can follow. The landing is the command's pose plus the navigation noise
T^n, drawn from the command's own random stream so that a seed fixes every landing whatever
else happens in the run. Before the motion starts its poses are checked against what the
robot knows (`known_scene`: its map and the chairs it perceived); a base that would collide
stops at the last free pose, as a local planner stops short. The motion and its escapes are
`escape.plan_motion`'s, over this system's collision test on that scene.
"""

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import partial

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import BasicVector, Context, EventStatus, LeafSystem, State

from s3o_drake.execution.escape import (
    BaseSegment,
    MotionProfile,
    Segment,
    extend_trail,
    plan_motion,
)
from s3o_drake.execution.messages import (
    NO_COMMAND,
    ArmMotion,
    BaseCommand,
    CommandState,
    KnownScene,
    Status,
)
from s3o_drake.execution.together import WAIT_STEP, free_together
from s3o_drake.feasibility import ik
from s3o_drake.feasibility.landing import FINAL_APPROACH, PaddedFree
from s3o_drake.feasibility.robot_checker import RobotChecker
from s3o_drake.feasibility.scene import FeasibilityScene
from s3o_drake.planning.navigation.base_motion import SETTLE_TIME
from s3o_drake.world.angles import facing_yaw, wrap
from s3o_drake.world.robot import Robot
from s3o_drake.world.system_lifetime import weak_callback
from s3o_drake.world.worker_processes import drake_parallelism


@dataclass(frozen=True)
class NavigatorParams:
    """What the navigator needs of the scenario: how the base moves (`profile`), where it
    starts (X_WB as x, y, yaw: held until the first update reads robot_state), the run's
    `seed`, and the navigation noise T^n as standard deviations (m, rad; 0: exact
    landings). A command's status turns done or failed `settle_time` s after its motion."""

    profile: MotionProfile
    start: tuple[float, float, float]
    seed: int
    nav_xy_std: float = 0.0
    nav_yaw_std: float = 0.0
    settle_time: float = SETTLE_TIME


@dataclass(frozen=True)
class _Motion:
    """What the navigator is doing (its abstract state): command `id` started at `t0` (s),
    playing `segments` from `hold` (the pose before the first one, and the pose kept when
    there are none), ending in `outcome` (done or failed) with `reason`."""

    id: int = NO_COMMAND
    t0: float = 0.0
    hold: tuple[float, float, float] = (0.0, 0.0, 0.0)
    segments: tuple[Segment, ...] = ()
    outcome: CommandState = CommandState.DONE
    reason: str = ""
    contact: tuple[float, float] | None = None
    trail: tuple[BaseSegment, ...] = ()
    """The way the base came to where this motion ends: the last drive leg of the last
    motion that drove at least RETRACE_RESET, and every move since (`extend_trail`)."""
    initialized: bool = False
    turns: tuple[float, ...] = ()
    """Per segment, the whole turns (rad, multiples of 2π) added to its yaw (`yaw_turns`);
    empty: none."""
    stopped: bool = False
    """The robot's protective stop ended this command's motion."""

    def __deepcopy__(self, memo: dict) -> "_Motion":
        # Immutable all the way down: Drake clones abstract state on every update, and a
        # real deep copy of the segments was a sixth of the simulation's time.
        return self

    @property
    def duration(self) -> float:
        return sum(seg.duration for seg in self.segments)

    @property
    def end_time(self) -> float:
        """When the motion ends (s, simulated)."""
        return self.t0 + self.duration

    @property
    def end(self) -> np.ndarray:
        if not self.segments:
            return np.asarray(self.hold)
        end = np.array(self.segments[-1].end, dtype=float)
        end[2] += self.turns[-1] if self.turns else 0.0
        return end

    def desired(self, t: float) -> np.ndarray:
        """[x, y, yaw, xdot, ydot, yawdot] at time t."""
        tau = t - self.t0
        for i, seg in enumerate(self.segments):
            if tau < seg.duration:
                state = np.array(seg.state(tau))
                state[2] += self.turns[i] if self.turns else 0.0
                return state
            tau -= seg.duration
        return np.concatenate([self.end, np.zeros(3)])


def yaw_turns(yaw: float, segments: Sequence[Segment]) -> tuple[float, ...]:
    """For each of `segments`, played from a base at `yaw` (rad, as the plant's yaw joint
    counts it: whole turns included), the whole turns to add to its yaws so that each starts
    where the one before ended. A segment may write a heading one turn round from the
    joint's (a smooth drive starts at its leg's heading, in (-π, π]); the yaw joint's PD
    would unwind that turn on the spot, the robot spinning at its stop."""
    turns, before = [], float(yaw)
    for seg in segments:
        start = float(seg.start[2])
        turn = 2.0 * math.pi * round((before - start) / (2.0 * math.pi))
        turns.append(turn)
        before = float(seg.end[2]) + turn
    return tuple(turns)


class BaseNavigator(LeafSystem):
    """Drives the base along a `BaseCommand`'s path to its noisy landing pose.

    Input ports:
        base_command (abstract `BaseCommand`): a new `id` starts a command; id 0 holds still.
        robot_state (vector, 2 robot.num_positions): the robot's positions then its
            velocities; the base pose (x, y, yaw) is positions 0..2.
        arm_motion (abstract `ArmMotion`, optional; read with smooth motion only): what the
            arm does; a motion is checked with the arm where its motion ends, and with the
            two together while it plays, and waits for the arm where they collide.
        known_scene (abstract `KnownScene`, optional): the world as the robot knows it,
            which motions are checked in; unconnected or empty, they are not checked.
        bumper (vector 3, optional): the robot's protective stop: 1 while it holds the
            base short of something, then where (x, y); a motion it stops ends there,
            done within FINAL_APPROACH of its end (landed short), else failed "blocked"
            with that `contact`.
    Output ports:
        base_desired_state (vector 6): x, y, yaw (m, rad) then their rates (m/s, rad/s).
        status (abstract `Status`): CommandState idle before any command, running while the
            motion plays, then done (landed, possibly short of a colliding goal) or failed
            with reason "blocked" (stopped far from the goal by a collision) and the
            `contact` where it touched, `settle_time` after the motion ended.
        base_motion (abstract): the motion playing (`id`, `desired(t)`, `end_time`), which
            the arm's prepare is timed by.

    Every `control_period` s (and at initialization, and on a forced unrestricted update)
    it compares the command's id with the one it executes; on a new id it plans the whole
    motion from where the base actually is: the waypoints of `command.path` (the first is
    replaced by the base's position, the last by the landing), each drive preceded by a turn
    in place toward its heading, and a final turn to the landing yaw; a `turn` command only
    turns, where the base stands. Yaw stays continuous (no 2 pi jumps), so the desired yaw
    equals the landing's only modulo 2 pi.

    The landing is `command.pose` + (dx, dy, dyaw) with dx, dy ~ N(0, nav_xy_std^2) and
    dyaw ~ N(0, nav_yaw_std^2) from numpy.random.default_rng([seed, 1, command.id]) (the
    `params`; exactly `command.pose` when both are 0). With a `known_scene` (of `robot`),
    poses every
    2 cm / 0.05 rad along the motion are checked (inside the room and collision-free, arm
    stowed); the motion is cut at the last free pose before the first collision. A
    collision within the last 0.5 m of driving or in the final turn ends the command done
    there (landed short); an earlier one, or one in the turn before the first drive (however
    short the drive), ends it failed, reason "blocked". Collisions at
    the very start (the base already stands there) are ignored until the first free pose.
    Before giving up on a blocked motion it tries, in turn, the first turn the other way
    round, keeping to the planned last leg, then backing straight out or driving straight
    on by 5, 10, ... 60 cm before turning (a noisy landing can leave the base where the
    rectangle cannot turn towards the path; backed against a bar, only ahead is open), and
    going back the way it came: the first of these that is not blocked is driven
    (`escape.plan_motion`).
    """

    def __init__(self, *, robot: Robot, params: NavigatorParams,
                 control_period: float = 0.01) -> None:
        super().__init__()
        self._robot = robot
        self._params = params
        # A memo, not state: the known scene last seen, and its checker without the padding.
        self._unpadded: tuple[FeasibilityScene, RobotChecker] | None = None
        self._smooth = params.profile.smooth

        self._command_port = self.DeclareAbstractInputPort(
            "base_command", AbstractValue.Make(BaseCommand()))
        self._state_port = self.DeclareVectorInputPort("robot_state", 2 * robot.num_positions)
        self._arm_port = self.DeclareAbstractInputPort("arm_motion",
                                                       AbstractValue.Make(ArmMotion()))
        self._scene_port = self.DeclareAbstractInputPort("known_scene",
                                                         AbstractValue.Make(KnownScene()))
        self._bumper_port = self.DeclareVectorInputPort("bumper", 3)
        # Until the initialization event reads robot_state, hold the scenario's start pose
        # (where the world puts the robot by default).
        start = tuple(float(v) for v in params.start)
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
        self.DeclareAbstractOutputPort(
            "base_motion", lambda: AbstractValue.Make(_Motion()),
            weak_callback(self._calc_base_motion),
            prerequisites_of_calc={self.abstract_state_ticket(self._motion_index)})
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
            if not self._stopped(context, motion, t):
                return EventStatus.DidNothing()
            base = self._state_port.Eval(context)[:3]
            bumper = self._bumper_port.Eval(context)
            new = _stopped_at(motion, base, t, contact=(float(bumper[1]), float(bumper[2])))
            state.get_mutable_abstract_state(self._motion_index).set_value(new)
            return EventStatus.Succeeded()
        if command.id == NO_COMMAND:
            # Cancelled (or never started): stop where the motion is now.
            here = motion.desired(t)[:3]
            new = _Motion(id=NO_COMMAND, t0=t, hold=tuple(map(float, here)),
                          trail=motion.trail, initialized=True)
        else:
            base = self._state_port.Eval(context)[:3]
            arm = (self._arm_port.Eval(context) if self._smooth
                   and self._arm_port.HasValue(context) else None)
            known: KnownScene | None = (self._scene_port.Eval(context)
                                        if self._scene_port.HasValue(context) else None)
            new = self._plan(command, base, t, motion.trail, arm,
                             None if known is None else known.scene)
        state.get_mutable_abstract_state(self._motion_index).set_value(new)
        return EventStatus.Succeeded()

    def _stopped(self, context: Context, motion: _Motion, t: float) -> bool:
        """Whether the robot's protective stop holds the base while `motion` plays."""
        return (motion.id != NO_COMMAND and not motion.stopped and t < motion.end_time
                and self._bumper_port.HasValue(context)
                and self._bumper_port.Eval(context)[0] != 0.0)

    def _landing(self, command: BaseCommand) -> np.ndarray:
        """The pose (x, y, yaw) the command aims for: its pose plus the seeded noise T^n
        (none for a turn in place); with `face`, its yaw that facing the point from the
        noisy x, y, plus the yaw's noise."""
        if command.turn:
            return np.asarray(command.pose, dtype=float)
        p = self._params
        rng = np.random.default_rng([p.seed, 1, command.id])
        noise = rng.normal(0.0, 1.0, 3) * [p.nav_xy_std, p.nav_xy_std, p.nav_yaw_std]
        landing = np.asarray(command.pose, dtype=float) + noise
        if command.face is not None:
            landing[2] = float(command.pose[2] + wrap(
                facing_yaw(landing[:2], command.face) - command.pose[2])) + noise[2]
        return landing

    def _plan(self, command: BaseCommand, base: np.ndarray, t: float,
              trail: tuple[BaseSegment, ...] = (), arm: ArmMotion | None = None,
              scene: FeasibilityScene | None = None) -> _Motion:
        """The command's motion from `base` at time `t`, checked in `scene` (None: not
        checked): with the arm where it will be once its motion (`arm`; None: stowed)
        ends, and, while that plays, with the two together; where those collide it starts
        later (`together.WAIT_STEP`), at the latest as the arm's motion ends."""
        if scene is not None and scene.robot is not self._robot:
            raise ValueError(f"known_scene: holds {scene.robot!r}, not the navigator's "
                             f"{self._robot!r}")
        posture = None if arm is None or not arm.hold else np.asarray(arm.final)
        free = None if scene is None else PaddedFree(
            partial(self._free, scene=scene, arm=posture),
            partial(self._free, scene=scene, arm=posture, checker=self._untouched_in(scene)))
        cut = plan_motion(base, self._landing(command), path=command.path, stop=command.pose,
                          turn=command.turn, trail=trail, free=free,
                          profile=self._params.profile)
        # What blocked the base, where it touched: the bumper's reading on the status.
        contact = (scene.clearance.contact(cut.hit)
                   if cut.blocked and cut.hit is not None else None)
        motion = _Motion(id=command.id, t0=t, hold=tuple(float(v) for v in base[:3]),
                         segments=tuple(cut.segments),
                         turns=yaw_turns(float(base[2]), cut.segments),
                         outcome=CommandState.FAILED if cut.blocked else CommandState.DONE,
                         reason="blocked" if cut.blocked else "", contact=contact,
                         trail=extend_trail(trail, cut.segments), initialized=True)
        if arm is None or scene is None:
            return motion
        # The earliest start, every WAIT_STEP, at which the two motions are collision-free
        # together until the arm's ends (from there the check above holds). A base that
        # stops first stands where the arm's motion was not planned for: a turn at a stop
        # swings the rest of the arm's way round with it.
        start = t
        while start < arm.end_time:
            moved = dataclasses.replace(motion, t0=start)
            if free_together(partial(_checker, scene, arm), moved.desired, arm.arm_at, start,
                             arm.end_time, robot=self._robot):
                return moved
            start += WAIT_STEP
        return dataclasses.replace(motion, t0=max(t, arm.end_time))

    def _untouched_in(self, scene: FeasibilityScene) -> RobotChecker:
        """`scene`'s checker without its padding: where a landing left the base inside the
        padding, the way out must not touch (`PaddedFree`)."""
        if self._unpadded is None or self._unpadded[0] is not scene:
            self._unpadded = (scene, _unpadded(scene.checker))
        return self._unpadded[1]

    def _free(self, poses: np.ndarray, scene: FeasibilityScene, arm: np.ndarray | None = None,
              checker: RobotChecker | None = None) -> np.ndarray:
        """bool (n,): base poses inside the room and collision-free in `scene` with the arm
        and the fingers at `arm` (default: stowed, open), by `checker` (default the
        scene's, with its padding)."""
        clearance = scene.clearance
        free = clearance.in_room(poses[:, :2])
        # Far from every obstacle needs no collision query (a sound shortcut).
        query = free & ~clearance.certainly_free(poses[:, :2])
        if query.any():
            robot = self._robot
            if arm is None:
                configs = [robot.positions(*p, arm=robot.arm_stow, gripper=robot.gripper_open)
                           for p in poses[query]]
            else:
                num_arm = robot.num_arm_joints
                configs = [robot.positions(*p, arm=arm[:num_arm], gripper=arm[num_arm:])
                           for p in poses[query]]
            checked = (checker or scene.checker).CheckConfigsCollisionFree(
                configs, parallelize=drake_parallelism())
            free[query] = np.asarray(checked, dtype=bool)
        return free

    def _calc_base_motion(self, context: Context, output: AbstractValue) -> None:
        output.set_value(self._motion(context))

    def _calc_desired_state(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(self._motion(context).desired(context.get_time()))

    def _calc_status(self, context: Context, output: AbstractValue) -> None:
        motion = self._motion(context)
        if motion.id == NO_COMMAND:
            output.set_value(Status())
        elif context.get_time() < motion.t0 + motion.duration + self._params.settle_time:
            output.set_value(Status(id=motion.id, state=CommandState.RUNNING))
        else:
            output.set_value(Status(id=motion.id, state=motion.outcome, reason=motion.reason,
                                    contact=motion.contact))


def _stopped_at(motion: _Motion, base: np.ndarray, t: float,
                contact: tuple[float, float]) -> _Motion:
    """`motion` ended at time `t` by the robot's protective stop, the base at `base` (as
    robot_state has it): held there; landed short within FINAL_APPROACH of its end, else
    blocked."""
    left = float(np.linalg.norm(motion.end[:2] - motion.desired(t)[:2]))
    short = left <= FINAL_APPROACH
    return _Motion(id=motion.id, t0=t, hold=tuple(float(v) for v in base[:3]),
                   outcome=CommandState.DONE if short else CommandState.FAILED,
                   reason="" if short else "blocked", contact=None if short else contact,
                   trail=motion.trail, initialized=True, stopped=True)


def _checker(scene: FeasibilityScene, arm: ArmMotion, t: float) -> RobotChecker:
    """`scene`'s checker at time `t`, letting the gripper touch the dish `arm` picks.

    A replan's scene holds only the dishes that remain: the one the arm still carries to
    the tray is not in it, and there is nothing of it for the gripper to touch."""
    dish = arm.touching(t)
    return ik.grasp_checker(scene, dish) if dish in scene.dishes else scene.checker


def _unpadded(checker: RobotChecker) -> RobotChecker:
    """A clone of `checker` without its padding between the robot and the world."""
    clone = checker.Clone()
    clone.inner.SetPaddingAllRobotEnvironmentPairs(0.0)
    return clone

