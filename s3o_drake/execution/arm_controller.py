"""The arm's part of execution: a `PickCommand` becomes a timed arm motion and grip events.

A pickup is planned once, when its command arrives, from where the robot is (base and arm
from `robot_state`) towards where the robot's sensor sees the dish: the controller asks for
it (`target_request`) and aims at the answer (`target_sighting`), which is off by the
sensor's error T^m (`plan_pickup`'s `reach_offset`, from where the briefing put the dish).
The motion is then played back open-loop from the Context: the plant's PD actuators track
it. Whether the fingers hold the dish is the robot's to say: after they close, the
gripper's report (`gripper_status`) tells a caught dish from a miss.

An object whose goal is place is picked the same way but kept in the gripper, held above
the tray (`plan_pickup(..., hold=True)`), until a command with `place` puts it down at its
place target (`arm.place.plan_place`: with the grasp it was picked with, where the sensor
sees the place). The controller checks its motions in the world as the robot knows it
(`known_scene`, the latest plan's: the map, the perceived chairs, the objects left and
their place targets).

With smooth motion (`ArmParams.motion`) the arm works while the base drives. A pickup
onto the tray is reported done once the dish is lifted: the base may leave while the arm
carries it to the tray, lets go and stows (the navigator checks the two motions together;
the status's `until` says when the arm's ends). A command may bring the arm to a dish's
pre-grasp while the base drives to its stop (`PickCommand.prepare`), timed to arrive with
the base and started later where the arm's motion along the base's (`base_motion`) is not
collision-free; the pickup that follows approaches from there. The grasp itself is made
with the base at rest.
"""

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import BasicVector, Context, EventStatus, LeafSystem, State
from pydrake.trajectories import Trajectory

from s3o_drake.execution.arm.pickup import PickupPlan, plan_pickup, plan_reach, plan_release
from s3o_drake.execution.arm.place import place_grasps, plan_place
from s3o_drake.execution.messages import (
    NO_COMMAND,
    ArmMotion,
    CommandState,
    KnownScene,
    PickCommand,
    Status,
)
from s3o_drake.execution.together import WAIT_STEP, free_together
from s3o_drake.feasibility.check import FeasibilityChecker
from s3o_drake.feasibility.scene import FeasibilityScene
from s3o_drake.world.choices import Motion
from s3o_drake.world.goals import place_target_name
from s3o_drake.world.robot import Robot
from s3o_drake.world.robot_messages import (
    REACH_STREAM,
    GripEvent,
    GripperStatus,
    TargetRequest,
    TargetSighting,
)
from s3o_drake.world.system_lifetime import weak_callback

#: How long after the fingers close the arm waits for the gripper to report an object
#: before it counts the grasp as missed (s): a parallel gripper's driver reports one a few
#: of its cycles after its fingers stop on it (the simulated robot's, two control periods).
GRIP_REPORT_TIMEOUT = 0.25
#: Stream tag of the landing draws that choose an object to place's grasp at its pickup.
PLACE_GRASP_STREAM = 5
#: How many landings at the place's stop rate each grasp (`place.place_grasps`).
PLACE_LANDINGS = 16

@dataclass(frozen=True)
class _Activity:
    """Everything the controller remembers (one abstract state).

    `hold`: the arm's and fingers' positions held while no motion plays; `trajectory`: the
    motion playing (the robot's positions, t from 0 at `t_start`) or None; `t_grasp`, `t_release`:
    when (since `t_start`) the gripper closes on and lets go of `dish` (inf: it keeps it);
    `putting`: the motion puts `dish` down at its place (else it lets go over the tray);
    `grasp`: the motion's grasp ("top" or "side"); `held_grasp`: the grasp the gripper
    holds an object to place with between motions ("": it holds nothing); `sighted`: the
    target whose sighting the command aims at ("": none); `checked`: the gripper's
    report has settled the grasp, and `missed`: the fingers hold nothing (no object
    reported within GRIP_REPORT_TIMEOUT of their closing); `t_done`: when (since
    `t_start`) the command is reported done (or failed, missed): the motion's end, or
    with smooth motion a pickup's lift.
    """

    started: bool = False
    command: int = NO_COMMAND
    status: Status = field(default_factory=Status)
    grip: GripEvent = field(default_factory=GripEvent)
    hold: tuple[float, ...] = ()
    dish: str = ""
    trajectory: Trajectory | None = None
    t_start: float = 0.0
    t_grasp: float = 0.0
    t_release: float = 0.0
    putting: bool = False
    grasp: str = ""
    held_grasp: str = ""
    sighted: str = ""
    checked: bool = False
    missed: bool = False
    t_done: float = math.inf
    along: object = None
    """The navigator's motion a prepare playing was checked along (None: none)."""

    def __deepcopy__(self, memo: dict) -> "_Activity":
        # Shared, not copied: every field is an immutable value, and the trajectory, the one
        # C++ object, is made once by `_start` and never changed afterwards (an update
        # makes a new _Activity). Drake copies the state before every update; a deep copy
        # would clone the whole pickup trajectory every control period.
        return self


@dataclass(frozen=True)
class ArmParams:
    """What the arm controller needs of the scenario: the run's `seed` (its motion
    planner's seeds); the navigation noise T^n (`nav_std`: x, y in m, yaw in rad; None:
    none), which the choice of an object to place's grasp rates its place's landings with;
    the objects whose goal is place (`to_place`, held after their pickup); the cap (s) on
    one motion plan; and the robot's `motion`."""

    seed: int
    nav_std: tuple[float, float, float] | None = None
    to_place: frozenset[str] = frozenset()
    plan_time_limit: float = 5.0
    motion: str = Motion.STOP_AND_GO.value
    """With "smooth", a pickup onto the tray is reported done once the dish is lifted."""


class ArmController(LeafSystem):
    """Plans and plays the arm's motion of each `PickCommand`; reports grip and status.

    Input ports:
        pick_command: abstract PickCommand; a new non-zero `id` starts a pickup, or with
            `place` the putting down of the held object, or, naming the held object
            without `place`, its letting go over the tray (a command that arrives while
            another plays starts when that one ends).
        robot_state: vector (2 robot.num_positions), the robot's positions then its
            velocities (base x, y, yaw; the arm's joints; the fingers).
        target_sighting: abstract TargetSighting, the sensor's answer to `target_request`;
            a command waits for the answer to its own request; unconnected: the targets
            are where the briefing put them.
        gripper_status: abstract GripperStatus, the gripper's report; unconnected: the
            fingers hold what they close on.
        base_motion (optional): abstract, the navigator's motion (`desired(t)`, `id`,
            `end_time`), which a prepare is timed by and checked along.
        known_scene: abstract KnownScene, the world as the robot knows it, which every
            motion is planned and checked in; a command without one fails ("no_scene").
    Output ports:
        arm_desired_state: vector (2 (robot.num_positions - robot.num_base_joints)), the
            arm's and the fingers' positions, then their velocities (for the plant's desired
            state, with the base's entries).
        grip: abstract GripEvent; `dish` from the end of the pickup's "close" segment to
            the end of its "release", `placed` gains it at the end of "release"; an object
            to place stays `dish` until the end of the place's "release", when `put`
            gains it.
        status: abstract Status of the latest command taken: its CommandState idle,
            running, done or failed with reason "no_ik", "no_path", "base_collision",
            "missed", "unknown_dish", "no_scene", "hand_full" (a pickup while an object to place is
            held), "not_held" (a place of an object the gripper does not hold) or
            "base_moved" (a prepare stopped: the base no longer drives as it was checked
            along);
            `sighted`, whether it aimed where the sensor saw its target; `until`, when the
            command's motion ends.
        target_request: abstract TargetRequest, where the sensor is asked to look: the
            target of the pick or place `pick_command` names (none for a prepare, a stow
            or a letting go).
        arm_motion: abstract ArmMotion, the motion playing (or none) and where the arm
            holds: what the navigator checks its motions with.

    Every `control_period` an unrestricted update takes new commands and moves the
    played motion's grip and status on; `arm_desired_state` follows the motion
    continuously in time (a forced unrestricted update runs the same update on demand).
    Before the first update, and between motions, the arm holds: at
    first the configuration that `robot_state` shows at the first update, then where the
    last motion ended (a failed plan leaves the arm where it is).
    """

    def __init__(self, *, robot: Robot, params: ArmParams,
                 control_period: float = 0.01) -> None:
        super().__init__()
        if control_period <= 0:
            raise ValueError(f"control_period: expected a positive period, got {control_period}")
        self._robot = robot
        # The arm's and the fingers' positions among the robot's (after the base's).
        self._arm_and_fingers = slice(robot.num_base_joints, robot.num_positions)
        self._num_arm_and_fingers = robot.num_positions - robot.num_base_joints
        # A memo, not state: the known scene last seen, and the pickup checks in it.
        self._checks: tuple[FeasibilityScene, FeasibilityChecker] | None = None
        self._seed = params.seed
        self._nav_std = None if params.nav_std is None else np.array(params.nav_std)
        self._to_place = params.to_place
        self._plan_time_limit = params.plan_time_limit

        self._command_port = self.DeclareAbstractInputPort(
            "pick_command", AbstractValue.Make(PickCommand()))
        self._robot_state_port = self.DeclareVectorInputPort("robot_state",
                                                              2 * robot.num_positions)
        self._sighting_port = self.DeclareAbstractInputPort(
            "target_sighting", AbstractValue.Make(TargetSighting()))
        self._gripper_port = self.DeclareAbstractInputPort(
            "gripper_status", AbstractValue.Make(GripperStatus()))
        self._base_motion_port = self.DeclareAbstractInputPort(
            "base_motion", AbstractValue.Make(object()))
        self._scene_port = self.DeclareAbstractInputPort(
            "known_scene", AbstractValue.Make(KnownScene()))
        self._smooth = params.motion == Motion.SMOOTH.value
        stowed = tuple(np.concatenate([robot.arm_stow, robot.gripper_open]))
        self._activity_index = self.DeclareAbstractState(
            AbstractValue.Make(_Activity(hold=stowed)))
        activity_ticket = {self.abstract_state_ticket(self._activity_index)}
        self.DeclareVectorOutputPort(
            "arm_desired_state", 2 * self._num_arm_and_fingers,
            weak_callback(self._calc_desired_state),
            prerequisites_of_calc=activity_ticket | {self.time_ticket()})
        self.DeclareAbstractOutputPort(
            "grip", lambda: AbstractValue.Make(GripEvent()), weak_callback(self._calc_grip),
            prerequisites_of_calc=activity_ticket)
        self.DeclareAbstractOutputPort(
            "status", lambda: AbstractValue.Make(Status()), weak_callback(self._calc_status),
            prerequisites_of_calc=activity_ticket)
        self.DeclareAbstractOutputPort(
            "arm_motion", lambda: AbstractValue.Make(ArmMotion()),
            weak_callback(self._calc_arm_motion), prerequisites_of_calc=activity_ticket)
        # From the command itself, so that the answer is there when the command is taken.
        self.DeclareAbstractOutputPort(
            "target_request", lambda: AbstractValue.Make(TargetRequest()),
            weak_callback(self._calc_target_request),
            prerequisites_of_calc=activity_ticket | {self._command_port.ticket()})
        self.DeclarePeriodicUnrestrictedUpdateEvent(control_period, 0.0,
                                                    weak_callback(self._update))
        # The same update on demand (`CalcForcedUnrestrictedUpdate`): tests and callers
        # that step the controller by hand.
        self.DeclareForcedUnrestrictedUpdateEvent(weak_callback(self._update))

    # ----------------------------------------------------------------------------- outputs
    def _activity(self, context: Context) -> _Activity:
        return context.get_abstract_state(self._activity_index).get_value()

    def _calc_desired_state(self, context: Context, output: BasicVector) -> None:
        activity = self._activity(context)
        trajectory = activity.trajectory
        if trajectory is None:
            output.SetFromVector(np.concatenate([activity.hold,
                                                 np.zeros(self._num_arm_and_fingers)]))
            return
        t = min(max(context.get_time() - activity.t_start, 0.0), trajectory.end_time())
        q = trajectory.value(t).ravel()[self._arm_and_fingers]
        v = trajectory.EvalDerivative(t, 1).ravel()[self._arm_and_fingers]
        output.SetFromVector(np.concatenate([q, v]))

    def _calc_grip(self, context: Context, output: AbstractValue) -> None:
        output.set_value(self._activity(context).grip)

    def _calc_status(self, context: Context, output: AbstractValue) -> None:
        output.set_value(self._activity(context).status)

    def _calc_arm_motion(self, context: Context, output: AbstractValue) -> None:
        a = self._activity(context)
        picking = a.trajectory is not None and math.isfinite(a.t_grasp) and not a.putting
        output.set_value(ArmMotion(a.trajectory, a.t_start, a.hold,
                                   dish=a.dish if picking else "",
                                   release_time=a.t_start + a.t_release if picking
                                   else -math.inf))

    def _calc_target_request(self, context: Context, output: AbstractValue) -> None:
        command: PickCommand = self._command_port.Eval(context)
        activity = self._activity(context)
        if command.id == activity.command:  # taken: what it asked when it was taken
            output.set_value(TargetRequest(command.id, activity.sighted)
                             if activity.sighted else TargetRequest())
            return
        reaches = (command.id != NO_COMMAND and command.prepare is None
                   and not command.to_stow and not _releasing(command, _held(activity)))
        output.set_value(TargetRequest(command.id, _target(command)) if reaches
                         else TargetRequest())

    # ------------------------------------------------------------------------------ update
    def _update(self, context: Context, state: State) -> EventStatus:
        activity = self._activity(context)
        robot_state = self._robot_state_port.Eval(context)
        if not activity.started:
            activity = replace(activity, started=True,
                               hold=tuple(robot_state[self._arm_and_fingers]))
        if activity.trajectory is not None:
            gripper = (self._gripper_port.Eval(context)
                       if self._gripper_port.HasValue(context) else None)
            activity = self._advance(activity, context.get_time(), gripper)
        if activity.trajectory is not None and activity.along is not None:
            activity = self._still_along(activity, context)
        command = self._command_port.Eval(context)
        if (activity.trajectory is None and command.id != NO_COMMAND
                and command.id != activity.command
                and (command.prepare is None or self._base_motion(context, command) is not None)):
            activity = self._start(activity, command, context, robot_state)
        state.get_mutable_abstract_state(self._activity_index).set_value(activity)
        return EventStatus.Succeeded()

    def _advance(self, activity: _Activity, time: float,
                 gripper: GripperStatus | None) -> _Activity:
        """The playing motion's grip and status at `time`, with the gripper's report
        `gripper` (None: none; the fingers hold what they close on); at its end the arm
        holds there."""
        elapsed = time - activity.t_start
        trajectory = activity.trajectory
        # The periodic update falls on the end time only up to rounding: a motion counts as
        # ended within a nanosecond of it.
        ended = elapsed >= trajectory.end_time() - 1e-9
        if (not activity.checked and math.isfinite(activity.t_grasp)
                and elapsed >= activity.t_grasp):
            if gripper is None or gripper.object_detected:
                activity = replace(activity, checked=True)
            elif (elapsed >= activity.t_grasp + GRIP_REPORT_TIMEOUT or ended
                  or elapsed >= activity.t_done - 1e-9):
                activity = replace(activity, checked=True, missed=True)
        held = not activity.missed and activity.t_grasp <= elapsed < activity.t_release
        placed, put = activity.grip.placed, activity.grip.put
        if not activity.missed and elapsed >= activity.t_release:
            if activity.putting and activity.dish not in put:
                put = (*put, activity.dish)
            elif not activity.putting and activity.dish not in placed:
                placed = (*placed, activity.dish)
        activity = replace(activity, grip=GripEvent(activity.dish if held else "", placed, put))
        if not activity.status.finished and (ended or elapsed >= activity.t_done - 1e-9):
            until = activity.t_start + trajectory.end_time()
            status = (Status(activity.command, CommandState.FAILED, "missed",
                             sighted=bool(activity.sighted), until=until)
                      if activity.missed
                      else Status(activity.command, CommandState.DONE,
                                  sighted=bool(activity.sighted), until=until))
            activity = replace(activity, status=status)
        if not ended:
            return activity
        end = trajectory.value(trajectory.end_time()).ravel()[self._arm_and_fingers]
        # The object still in the gripper (a pick that holds it) is held with its grasp.
        keeps = held and math.isinf(activity.t_release)
        return replace(activity, hold=tuple(end), trajectory=None,
                       held_grasp=activity.grasp if keeps else "", along=None)

    def _still_along(self, activity: _Activity, context: Context) -> _Activity:
        """A prepare playing along a base motion that the navigator no longer plays (the
        robot's protective stop held the base short of its stop, or the navigator ended
        the motion): its rest is checked along the base's motion as it is now, and where
        the two collide the arm stops where it is and the prepare fails ("base_moved").
        Planned for the base at its stop, the arm would otherwise reach out from where
        the base stands instead."""
        motion = (self._base_motion_port.Eval(context)
                  if self._base_motion_port.HasValue(context) else None)
        if motion is None or motion is activity.along:
            return activity
        now = context.get_time()
        trajectory, start = activity.trajectory, activity.t_start
        duration = float(trajectory.end_time())
        arm_at = self._arm_along(trajectory, start)
        known = self._known(context)
        if known is not None and free_together(lambda t: known[0].checker, motion.desired,
                                               arm_at, now, start + duration,
                                               robot=self._robot):
            return replace(activity, along=motion)
        return replace(activity, trajectory=None, hold=tuple(arm_at(now)), along=None,
                       status=Status(activity.command, CommandState.FAILED, "base_moved"))

    def _start(self, activity: _Activity, command: PickCommand, context: Context,
               robot_state: np.ndarray) -> _Activity:
        """Plans `command`'s pickup; the motion plays from now, or the command fails; or,
        while the sensor has not answered the command's request, nothing yet."""
        holding = _held(activity)
        taken = replace(activity, command=command.id, dish=command.dish, missed=False,
                        checked=False, sighted="", along=None)

        def failed(reason: str) -> _Activity:
            return replace(taken, status=Status(command.id, CommandState.FAILED, reason,
                                                sighted=bool(taken.sighted)))

        known = self._known(context)
        if known is None:
            return failed("no_scene")
        scene, checker = known
        q_now = np.asarray(robot_state[:self._robot.num_positions], dtype=float)
        # The command's own stream (robot_messages.REACH_STREAM): the sensor's error takes
        # its first two draws, the planner's seed the next; neither depends on what ran
        # before, and the seed is the same with the noise off.
        rng = np.random.default_rng([self._seed, REACH_STREAM, command.id])
        if command.prepare is not None or command.to_stow:
            if command.prepare is not None and command.dish not in scene.dishes:
                return failed("unknown_dish")
            return self._reach(taken, command, context, q_now,
                               int(rng.integers(2**31 - 1)), failed, scene, checker)
        name = _target(command)
        releasing = _releasing(command, holding)
        # The held object is in the gripper, not in the known world: letting it go needs no
        # target there.
        if not releasing and name not in scene.dishes:
            return failed("unknown_dish")
        if command.place and holding != command.dish:
            return failed("not_held")
        if not command.place and holding and holding != command.dish:
            return failed("hand_full")
        rng.normal(0.0, 1.0, 2)  # the sensor's
        plan_seed = int(rng.integers(2**31 - 1))
        offset = np.zeros(2)
        if not releasing:
            sighting = self._sighting(context, command.id, name, scene)
            if sighting is None:
                return activity  # asked; the answer comes at a later update
            if sighting.p_WT is None:
                return failed("unknown_dish")
            p_WT, _ = scene.dish_p_WD(name)
            offset = np.asarray(sighting.p_WT) - p_WT
            if self._sighting_port.HasValue(context):
                taken = replace(taken, sighted=name)
        activity = taken
        try:
            if releasing:  # its place failed for good: let go over the tray
                plan = plan_release(scene, q_now[:3], q_now, seed=plan_seed,
                                    time_limit=self._plan_time_limit)
            elif command.place:
                plan = plan_place(scene, checker, q_now[:3], place_target_name(command.dish),
                                  grasp=activity.held_grasp, q_start=q_now,
                                  reach_offset=offset, seed=plan_seed,
                                  time_limit=self._plan_time_limit)
            else:
                plan = self._pick(command, q_now, offset, plan_seed, scene, checker)
        except ValueError:
            # The arm's path planner refuses a start in collision (the arm pushed into
            # something, within the checker's padding): no path from here.
            return failed("no_path")
        if not plan.ok:
            return failed(plan.reason)
        ends = dict(zip((s.name for s in plan.segments),
                        np.cumsum([s.duration for s in plan.segments]), strict=True))
        running = replace(activity, status=Status(command.id, CommandState.RUNNING,
                                                  sighted=bool(activity.sighted)),
                          trajectory=plan.trajectory(), t_start=context.get_time(),
                          putting=command.place, grasp=plan.grasp or "", t_done=math.inf)
        if command.place or releasing:  # held from the start, let go at the end of "release"
            return replace(running, t_grasp=-math.inf, t_release=float(ends["release"]))
        onto_tray = "release" in ends
        return replace(running, t_grasp=float(ends["close"]),
                       t_release=float(ends.get("release", math.inf)),
                       t_done=float(ends["lift"]) if self._smooth and onto_tray else math.inf)

    def _known(self, context: Context) -> tuple[FeasibilityScene, FeasibilityChecker] | None:
        """The world as the robot knows it and the pickup checks in it; None: no scene."""
        known: KnownScene | None = (self._scene_port.Eval(context)
                                    if self._scene_port.HasValue(context) else None)
        if known is None or known.scene is None:
            return None
        scene = known.scene
        if scene.robot is not self._robot:
            raise ValueError(f"known_scene: holds {scene.robot!r}, not the controller's "
                             f"{self._robot!r}")
        if self._checks is None or self._checks[0] is not scene:
            self._checks = (scene, FeasibilityChecker(scene))
        return self._checks

    def _sighting(self, context: Context, command: int, target: str,
                  scene: FeasibilityScene) -> TargetSighting | None:
        """The sensor's answer to command `command`'s request for `target`; None while it
        has not come. Unconnected: the target where `scene` (the briefing) has it."""
        if not self._sighting_port.HasValue(context):
            p_WT, _ = scene.dish_p_WD(target)
            return TargetSighting(command, target, (float(p_WT[0]), float(p_WT[1])))
        sighting: TargetSighting = self._sighting_port.Eval(context)
        if sighting.id != command or sighting.target != target:
            return None
        return sighting

    def _reach(self, activity: _Activity, command: PickCommand, context: Context,
               q_now: np.ndarray, seed: int, failed, scene: FeasibilityScene,
               checker: FeasibilityChecker) -> _Activity:
        """A prepare (to `command.dish`'s pre-grasp from `command.prepare`, timed by the
        base's motion) or a stow; the arm holds where it is when there is none."""
        base = command.prepare if command.prepare is not None else q_now[:3]
        target = command.dish if command.prepare is not None else None
        plan = plan_reach(scene, checker, np.asarray(base), q_now,
                          None if target is None else target, seed=seed,
                          time_limit=self._plan_time_limit)
        if not plan.ok:
            return failed(plan.reason)
        trajectory = plan.trajectory()
        t_start, along = context.get_time(), None
        if command.prepare is not None:
            along = self._base_motion(context, command)
            t_start = self._prepare_start(along, trajectory, t_start, scene)
            if t_start is None:
                return failed("no_path")
        return replace(activity, status=Status(command.id, CommandState.RUNNING),
                       trajectory=trajectory, t_start=t_start, putting=False, grasp="",
                       t_grasp=math.inf, t_release=math.inf, t_done=math.inf, along=along)

    def _base_motion(self, context: Context, command: PickCommand):
        """The navigator's motion of `command.base_id`, once the navigator has taken it."""
        if not self._base_motion_port.HasValue(context):
            return None
        motion = self._base_motion_port.Eval(context)
        return motion if getattr(motion, "id", NO_COMMAND) == command.base_id else None

    def _prepare_start(self, motion, trajectory: Trajectory, now: float,
                       scene: FeasibilityScene) -> float | None:
        """When a prepare's `trajectory` starts: so that it ends as the base's `motion`
        does, or later by WAIT_STEP steps until the two motions are collision-free
        together; None when even after the base has stopped they are not."""
        arrival = motion.end_time
        duration = float(trajectory.end_time())
        start = max(now, arrival - duration)
        while True:
            if free_together(lambda t: scene.checker, motion.desired,
                             self._arm_along(trajectory, start), start, start + duration,
                             robot=self._robot):
                return start
            if start >= arrival:
                return None
            start = min(start + WAIT_STEP, arrival)

    def _arm_along(self, trajectory: Trajectory, start: float
                   ) -> Callable[[float], np.ndarray]:
        """The arm's and fingers' positions at time t of `trajectory` played from `start`
        (held at its ends before and after)."""
        duration = float(trajectory.end_time())

        def arm_at(t: float) -> np.ndarray:
            return trajectory.value(min(max(t - start, 0.0), duration)).ravel()[
                self._arm_and_fingers]

        return arm_at

    def _pick(self, command: PickCommand, q_now: np.ndarray, offset: np.ndarray, seed: int,
              scene: FeasibilityScene, checker: FeasibilityChecker) -> PickupPlan:
        """The pickup of `command.dish` from where the robot stands, aimed `offset` (dx,
        dy; m) from where `scene` has it (an object to place is held, with a grasp it can
        be put down with from `command.place_from` where one picks it)."""
        name = command.dish

        def pick(grasp: str | None) -> PickupPlan:
            # The checker's scene has the dish where the briefing put it: the offset
            # carries where the sensor sees it.
            return plan_pickup(scene, checker, q_now[:3], name,
                               reach_offset=offset, q_start=q_now,
                               seed=seed, time_limit=self._plan_time_limit,
                               hold=name in self._to_place, grasp=grasp, stow=command.stow)

        if name in self._to_place and command.place_from is not None:
            # Where the place's landing will put the base is not known yet: its grasp is
            # the one that works from most of PLACE_LANDINGS draws of the landing noise.
            landing_noise = None
            if self._nav_std is not None:
                rng = np.random.default_rng([self._seed, PLACE_GRASP_STREAM, command.id])
                landing_noise = rng.normal(0.0, 1.0, (PLACE_LANDINGS, 3)) * self._nav_std
            for grasp in place_grasps(scene, checker,
                                      np.asarray(command.place_from), place_target_name(name),
                                      landing_noise=landing_noise):
                plan = pick(grasp)
                if plan.ok:
                    return plan
        return pick(None)


def _held(activity: _Activity) -> str:
    """The object the gripper holds between motions ("": none)."""
    return activity.grip.dish if activity.held_grasp else ""


def _target(command: PickCommand) -> str:
    """What a pick or a place reaches for: the dish, or the held object's place target."""
    return place_target_name(command.dish) if command.place else command.dish


def _releasing(command: PickCommand, held: str) -> bool:
    """Whether `command` lets the `held` object go over the tray (its place failed for
    good): it reaches for nothing."""
    return not command.place and held == command.dish
