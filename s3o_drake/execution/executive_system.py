"""The Executive as a LeafSystem: plans at start, sends goals, follows the controllers.

`ExecutiveSystem` adapts the diagram's ports to the `Executive` (executive.py: the walk of
the plan and the recovery policy, plain Python). Every control period it turns its ports
into one event (a tick when nothing is out, or the end of the command out), steps the
Executive and carries out its decisions: a drive becomes a BaseCommand whose path, on the
plan's navigation map, starts where the base really is (the last landing carried noise);
a plan request is answered at once by the planning pipeline (`plan_from`) on a
`KnownWorld` of the overhead camera's images (`perceive_world`), with a
`recovery.StopCheck` of its stops when recovering. A change of the optional
`replan_request` input's value asks for a plan of what remains, from where the base is.
"""

from __future__ import annotations

import dataclasses
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import Context, LeafSystem, State
from pydrake.systems.sensors import ImageDepth32F, ImageLabel16I, ImageRgba8U

from s3o_drake.belief.known_world import KnownWorld
from s3o_drake.execution import executive as ex
from s3o_drake.execution.executive import Executive, ExecutiveParams, ExecutiveState
from s3o_drake.execution.messages import (
    BaseCommand,
    CommandState,
    KnownScene,
    PickCommand,
    PlanProgress,
    PlanTime,
    Status,
)
from s3o_drake.execution.recovery import StopCheck, localiser
from s3o_drake.feasibility.planning_scene import PlanningScene
from s3o_drake.planning.navigation.map import DRIVE_MARGIN, TIGHT_DRIVE_MARGIN
from s3o_drake.planning.pipeline import PlanningResult, plan_from
from s3o_drake.world.choices import Recovery
from s3o_drake.world.goals import Goal, placed_object
from s3o_drake.world.robot import CONTROL_PERIOD, Robot
from s3o_drake.world.settings import Uncertainty
from s3o_drake.world.system_lifetime import weak_callback
from s3o_drake.world.words import counted


def _known_scene(memory: _Memory) -> KnownScene:
    """The scene of what the robot knew at its latest plan (none before the first)."""
    result = memory.executive.result
    return KnownScene(None if result is None or result.scene is None else result.scene.scene)


def _progress(memory: _Memory) -> PlanProgress:
    """The walk's progress; finished once the arm's motion has ended too."""
    progress = memory.executive.progress()
    if progress.finished and not memory.arm_done:
        return dataclasses.replace(progress, finished=False)
    return progress


PerceiveWorld = Callable[..., KnownWorld]
PlanFrom = Callable[..., PlanningResult]
"""How a plan is made from what the robot knows: `planning.pipeline.plan_from`'s signature."""
"""(color, depth, label images), *, pose, dishes, held -> what the robot knows."""


@dataclass(frozen=True)
class ExecutiveSystemParams:
    """What the system needs of the scenario besides the Executive's params: the planning
    `method`, `seed`, `workers`, the Fea^m source (`feasibility`, for what it says while
    planning), and the localisation noise (`uncertainty`; none without `noise`)."""

    executive: ExecutiveParams
    method: str
    seed: int
    workers: int = 1
    feasibility: str = "oracle"
    uncertainty: Uncertainty = field(default_factory=Uncertainty)
    noise: bool = True


@dataclass(frozen=True)
class _Memory:
    """The abstract state: the Executive's, the commands out, the last replan request."""

    executive: ExecutiveState = field(default_factory=ExecutiveState)
    base_command: BaseCommand = field(default_factory=BaseCommand)
    pick_command: PickCommand = field(default_factory=PickCommand)
    replan_seen: float = 0.0
    started: bool = False
    """The walk has started: the first plan was asked for."""
    arm_done: bool = True
    """The arm's motion has ended: the run ends once the walk has and the arm has (a
    pickup is done before its dish is on the tray, with smooth motion)."""

    def __deepcopy__(self, memo: dict) -> _Memory:
        return self  # immutable (see ExecutiveState): Drake's copies may share it


class ExecutiveSystem(LeafSystem):
    """Plans the task with S3O (or a baseline) and sequences the controllers.

    Input ports:
      overhead_color_image (ImageRgba8U), overhead_depth_image (ImageDepth32F),
      overhead_label_image (ImageLabel16I): the overhead camera, read once at start (and
        at each replan) through `perceive_world`;
      robot_state (2 robot.num_positions: the robot's positions then its velocities);
      base_status, arm_status (abstract Status): the controllers' reports;
      replan_request (1, optional): a change of its value asks for a new plan.
    Output ports:
      base_command (abstract BaseCommand), pick_command (abstract PickCommand); progress
        (abstract PlanProgress: an ActionOutcome per finished action, a PickupRecord per
        finished pickup, a RecoveryRecord per recovery, a PlanTime per plan, the unreachable
        dishes);
      plan (abstract TaskMotionPlan, or None before planning / when none could be made);
      planning_result (abstract PlanningResult, or None before planning: the latest plan
        and what it was made on, the KnownWorld, heatmaps, navigation map and state spaces);
      known_scene (abstract KnownScene): the Drake scene of the KnownWorld the latest plan
        was made on, which the controllers check their motions in;
      planning_time (1: wall time in s spent planning so far, all plans).

    `plan_from` makes each plan (default the planning pipeline's): another planner, or the
    pipeline with its Fea^m computed elsewhere, plugs in here.
    """

    def __init__(self, *, robot: Robot, params: ExecutiveSystemParams,
                 perceive_world: PerceiveWorld, plan_from: PlanFrom = plan_from,
                 control_period: float = CONTROL_PERIOD, progress_bar: bool = False):
        super().__init__()
        self._params = params
        self._perceive_world = perceive_world
        self._plan_from = plan_from
        self._progress_bar = progress_bar

        self._executive = Executive(params.executive, localise=localiser(
            uncertainty=params.uncertainty, seed=params.seed, noise=params.noise))
        self._images = [self.DeclareAbstractInputPort(f"overhead_{name}_image",
                                                      AbstractValue.Make(image()))
                        for name, image in (("color", ImageRgba8U), ("depth", ImageDepth32F),
                                            ("label", ImageLabel16I))]
        self._robot_state = self.DeclareVectorInputPort("robot_state", 2 * robot.num_positions)
        self._status = {
            "base": self.DeclareAbstractInputPort("base_status", AbstractValue.Make(Status())),
            "arm": self.DeclareAbstractInputPort("arm_status", AbstractValue.Make(Status()))}
        self._replan_port = self.DeclareVectorInputPort("replan_request", 1)
        self._state = self.DeclareAbstractState(AbstractValue.Make(_Memory()))
        self.DeclareInitializationUnrestrictedUpdateEvent(weak_callback(self._initialize))
        self.DeclarePeriodicUnrestrictedUpdateEvent(control_period, 0.0, weak_callback(self._step))
        self.DeclareForcedUnrestrictedUpdateEvent(weak_callback(self._step))  # a step on demand
        state = {self.abstract_state_ticket(self._state)}
        # The plan ports' model is None: they carry None until (and unless) there is a plan.
        for name, make, read in (
                ("base_command", BaseCommand, lambda m: m.base_command),
                ("pick_command", PickCommand, lambda m: m.pick_command),
                ("plan", lambda: None, lambda m: m.executive.plan),
                ("planning_result", lambda: None, lambda m: m.executive.result),
                ("known_scene", KnownScene, _known_scene),
                ("progress", PlanProgress, _progress)):
            self.DeclareAbstractOutputPort(
                name, lambda make=make: AbstractValue.Make(make()),
                weak_callback(self._calc_output, read=read), prerequisites_of_calc=state)
        self.DeclareVectorOutputPort("planning_time", 1, weak_callback(self._calc_planning_time),
                                     prerequisites_of_calc=state)

    def _memory(self, context: Context) -> _Memory:
        return context.get_abstract_state(int(self._state)).get_value()

    def _calc_output(self, context: Context, out, *, read: Callable[[_Memory], object]) -> None:
        out.set_value(read(self._memory(context)))

    def _calc_planning_time(self, context: Context, out) -> None:
        out.SetAtIndex(0, self._memory(context).executive.planning_time)

    def _pose(self, context: Context) -> np.ndarray:
        """The base's true pose (x, y, yaw)."""
        return np.asarray(self._robot_state.Eval(context))[:3].copy()

    def _initialize(self, context: Context, state: State) -> None:
        memory = self._start(context, _Memory())
        if self._replan_port.HasValue(context):
            memory = dataclasses.replace(
                memory, replan_seen=float(self._replan_port.Eval(context)[0]))
        state.get_mutable_abstract_state(int(self._state)).set_value(memory)

    def _start(self, context: Context, memory: _Memory) -> _Memory:
        """`memory` started (its first plan asked for), once the camera's images have come:
        over a message bus they come after the start."""
        if self._images[1].Eval(context).size() == 0:
            return memory
        return dataclasses.replace(
            self._run(context, memory, ex.Start(context.get_time(), self._pose(context))),
            started=True)

    def _step(self, context: Context, state: State) -> None:
        memory = self._memory(context)
        if not memory.started:
            memory = self._start(context, memory)
        if self._replan_port.HasValue(context):
            request = float(self._replan_port.Eval(context)[0])
            if request != memory.replan_seen:
                memory = self._run(context, dataclasses.replace(memory, replan_seen=request),
                                   ex.ReplanRequested(context.get_time(), self._pose(context)))
        if memory.executive.active:
            event = self._report(context, memory.executive)
            if event is not None:
                memory = self._run(context, memory, event)
        arm: Status = self._status["arm"].Eval(context)
        memory = dataclasses.replace(memory, arm_done=context.get_time() >= arm.until)
        state.get_mutable_abstract_state(int(self._state)).set_value(memory)

    def _report(self, context: Context, e: ExecutiveState) -> ex.Event | None:
        """This period's event: a tick when nothing is out, the end of the command out when
        its controller reports it, else none."""
        t = context.get_time()
        if e.awaiting is None:
            return ex.Tick(t, self._pose(context))
        status: Status = self._status[e.awaiting].Eval(context)
        if status.id != e.command_id or not status.finished:
            return None
        ok = status.state == CommandState.DONE
        if e.awaiting == "base":
            return ex.BaseFinished(t, self._pose(context), status.id, ok, status.reason,
                                   status.contact)
        return ex.ArmFinished(t, self._pose(context), status.id, ok, status.reason,
                              status.sighted)

    def _run(self, context: Context, memory: _Memory, event: ex.Event) -> _Memory:
        """`memory` after the Executive's step on `event`, its decisions carried out."""
        executive, decisions = self._executive.step(memory.executive, event)
        memory = dataclasses.replace(memory, executive=executive)
        for d in decisions:
            if isinstance(d, ex.Plan):  # answered at once
                memory = self._run(context, memory, self._plan(context, d))
            elif isinstance(d, ex.Drive):
                memory = dataclasses.replace(
                    memory, base_command=self._drive(memory.executive.result, d))
                if d.prepare:
                    memory = dataclasses.replace(memory, pick_command=PickCommand(
                        id=d.prepare_id, dish=d.prepare, prepare=tuple(d.pose),
                        base_id=d.id))
            elif isinstance(d, ex.Turn):
                memory = dataclasses.replace(memory, base_command=BaseCommand(
                    id=d.id, path=(d.pose[:2],), pose=d.pose, turn=True))
            elif isinstance(d, ex.Pick):
                memory = dataclasses.replace(memory, pick_command=PickCommand(
                    id=d.id, dish=d.dish, place=d.place, place_from=d.place_from,
                    stow=d.stow))
            elif isinstance(d, ex.Stow):
                memory = dataclasses.replace(memory, pick_command=PickCommand(
                    id=d.id, to_stow=True))
            elif isinstance(d, ex.Release):  # the held object named, without a place
                memory = dataclasses.replace(memory, pick_command=PickCommand(d.id, d.dish))
        return memory  # a Finish needs nothing: `progress` says so

    @staticmethod
    def _drive(result: PlanningResult, drive: ex.Drive) -> BaseCommand:
        """The drive from `drive.start` to `drive.pose` on the plan's navigation map (else
        along the plan's own waypoints, or straight)."""
        here, pose, nav = drive.start, drive.pose, result.navigation
        path = nav.path(here[:2], pose[:2]) if nav is not None else None
        if path is None:
            rest = (np.asarray(drive.planned)[1:] if drive.planned is not None
                    else np.asarray([pose[:2]]))
            path = np.vstack([here[:2], rest])
        return BaseCommand(id=drive.id, path=tuple((float(x), float(y)) for x, y in path),
                           pose=tuple(float(v) for v in pose), face=drive.face)

    def _plan(self, context: Context, ask: ex.Plan) -> ex.PlanReady | ex.PlanFailed:
        """The answer to `ask`: a plan from the images and the robot's pose, or why not."""
        t0 = time.perf_counter()
        p = self._params
        if self._progress_bar:  # say what is happening as it happens (stderr, with the bars)
            # The objects to act on: not the place targets, not the objects that stay.
            stay = {o.name for o in p.executive.objects if o.goal == Goal.STAY.value}
            objects = [d for d in ask.dishes if placed_object(d) is None and d not in stay]
            print(f"perceiving the unmapped chairs in the overhead camera's images "
                  f"({counted(len(objects), 'object')} to plan for)", file=sys.stderr,
                  flush=True)
        # Copies: a view of an image is a view of this context's cache, and one kept in the
        # plan's results would keep the whole context (scene graph, renderer) alive.
        images = tuple(np.array(port.Eval(context).data) for port in self._images)
        known = self._perceive_world(images, pose=ask.start, dishes=list(ask.dishes),
                                     held=ask.held)
        known = dataclasses.replace(known, contacts=ask.contacts)
        if self._progress_bar:
            print(f"planning with {p.method} (Fea^m from {p.feasibility}) within a budget "
                  f"of {ask.budget:g} s", file=sys.stderr, flush=True)
        result = self._plan_from(known, method=p.method, seed=p.seed, workers=p.workers,
                                 time_budget=ask.budget, progress=self._progress_bar,
                                 started=t0,
                                 drive_margin=TIGHT_DRIVE_MARGIN if ask.tight else DRIVE_MARGIN)
        if result.navigation is not None:
            result.navigation.seal()
        if result.scene is None:  # a plan of nothing: the controllers check in it still
            result = dataclasses.replace(result, scene=PlanningScene(result.known))
        took = PlanTime(result.planning_time, None if result.plan is None
                        else result.plan.timing.get("feasibility", 0.0), ask.budget)
        if result.plan is None:
            return ex.PlanFailed(result.error, took, result=result)
        check = (StopCheck(known, result.heatmaps, result.navigation,
                           model_heatmaps=result.model_heatmaps, scene=result.scene)
                 if p.executive.recovery != Recovery.NONE else None)
        return ex.PlanReady(result.plan, took, start=result.known.pose,
                            source=result.known.planner.feasibility,
                            unchecked=result.unchecked, check=check, result=result)
