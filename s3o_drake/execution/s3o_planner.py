"""The S3O planner as a LeafSystem: plans at start, sends goals, follows the controllers.

The planner sees what the robot can know: the overhead camera's images and the robot's
state. At initialization it makes a `KnownWorld` of them (`perception.perceive_known_world`:
the map, the chairs a perception function reports, by default `perception.ChairPerception`,
the dishes left and where the robot stands) and plans from it with the planning pipeline
(`planning.pipeline.plan_from`: Fea^m from `planner.feasibility`, "oracle" or "fcn", then
the chosen method). It then walks the plan one action at a time: a `goto` becomes a
BaseCommand whose path, on the plan's own navigation map, starts where the base really is
(the previous landing carried noise), a `pickup` a PickCommand. It advances when the
controller reports the command done; a failed pickup is recorded and the plan goes on with
the next action (the dish stays where it is); a failed goto ends the execution (the plan's
later pickups assumed that stop). Each finished pickup also leaves a `PickupRecord` on
`progress` (the Fea^m the plan predicted from its planned stop, where the base really stood,
the outcome, the reach noise the arm drew): the executions against which Fea^m is
calibrated.

Replanning (later issues): a change of the optional `replan_request` input's value plans
again from the robot's current pose for the dishes not yet collected (the state keeps the
new plan and starts it from its first action).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import Context, LeafSystem, State
from pydrake.systems.sensors import ImageDepth32F, ImageLabel16I, ImageRgba8U

from s3o_drake.angles import facing_yaw, wrap
from s3o_drake.execution.messages import (
    NO_COMMAND,
    ActionOutcome,
    BaseCommand,
    CommandState,
    PickCommand,
    PickupRecord,
    PlanProgress,
    Status,
)
from s3o_drake.feasibility.landing import TURN_TOLERANCE
from s3o_drake.perception import Perceive, perceive_known_world
from s3o_drake.planning.pipeline import PlanningResult, plan_from
from s3o_drake.planning.plan import Goto, Pickup, TaskMotionPlan
from s3o_drake.robot import CONTROL_PERIOD, NUM_POSITIONS
from s3o_drake.scenario import Scenario


def scenario_unmapped_chairs(scenario: Scenario) -> Perceive:
    """Perfect perception, for tests and comparisons: the scenario's unmapped chairs
    exactly, whatever the images show."""
    chairs = [list(map(float, c.pose)) for c in scenario.chairs if not c.mapped]
    return lambda color, depth, label: [list(c) for c in chairs]


@dataclass(frozen=True)
class _Execution:
    """The planner's abstract state: the plan and where execution stands.

    Immutable (every update makes a new one), so Drake's copies of the state may share it.
    """

    result: PlanningResult | None = None
    """The latest planning's result: the plan, and what it was made on (the KnownWorld,
    the heatmaps, the navigation map that re-paths the drives from where the base is)."""
    step: int = 0  # index into plan.actions of the action being executed
    command_id: int = NO_COMMAND  # id of the command sent for `step` (0: none yet)
    turning: bool = False  # the command out is the turn in place before a pickup
    turned: bool = False  # the base faces the dish of the pickup at `step`
    next_id: int = 1
    base_command: BaseCommand = field(default_factory=BaseCommand)
    pick_command: PickCommand = field(default_factory=PickCommand)
    outcomes: tuple[ActionOutcome, ...] = ()
    pickups: tuple[PickupRecord, ...] = ()
    pick_pose: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """The base's pose when the current pickup's PickCommand was sent."""
    finished: bool = False
    reason: str = ""
    replan_seen: float = 0.0
    planning_time: float = 0.0
    """Wall time (s) spent planning, summed over plans."""

    @property
    def plan(self) -> TaskMotionPlan | None:
        return None if self.result is None else self.result.plan

    def __deepcopy__(self, memo) -> _Execution:
        # Immutable: frozen, and the navigation map is sealed after planning (its queries
        # memoise nothing more), so Drake's copies may share it; a copy would only cost
        # (the map is megabytes).
        return self


class S3OPlanner(LeafSystem):
    """Plans the task with S3O (or a baseline) and sequences the controllers.

    Input ports:
      overhead_color_image (ImageRgba8U), overhead_depth_image (ImageDepth32F),
      overhead_label_image (ImageLabel16I): the overhead camera, read once at start (and
        at each replan) through the perception function;
      robot_state (22: the robot's 11 positions then 11 velocities);
      base_status, arm_status (abstract Status): the controllers' reports;
      replan_request (1, optional): a change of its value asks for a new plan.
    Output ports:
      base_command (abstract BaseCommand), pick_command (abstract PickCommand);
      progress (abstract PlanProgress: an ActionOutcome per finished action, and a
        PickupRecord per finished pickup);
      plan (abstract TaskMotionPlan, or None before planning / when none could be made);
      planning_result (abstract PlanningResult, or None before planning: the latest plan
        and what it was made on, the KnownWorld, heatmaps, navigation map and state spaces);
      planning_time (1: wall time in s spent planning so far, all plans).
    """

    def __init__(self, *, scenario: Scenario, method: str | None = None, seed: int | None = None,
                 perceive: Perceive | None = None, workers: int | None = None,
                 control_period: float = CONTROL_PERIOD, progress_bar: bool = False,
                 robot_labels: frozenset[int] = frozenset()):
        super().__init__()
        self._scenario = scenario
        self._method = method or scenario.planner.method
        self._seed = scenario.seed if seed is None else int(seed)
        self._perceive = perceive  # None: ChairPerception from where the robot stands
        self._workers = scenario.planner.workers if workers is None else workers
        self._progress_bar = progress_bar
        self._robot_labels = robot_labels  # the robot's own pixels, for the FCN's view
        self._dish_xy = {d.name: tuple(d.position) for d in scenario.dishes}
        self._dish_kind = {d.name: d.kind for d in scenario.dishes}
        self._images = [
            self.DeclareAbstractInputPort("overhead_color_image",
                                          AbstractValue.Make(ImageRgba8U())),
            self.DeclareAbstractInputPort("overhead_depth_image",
                                          AbstractValue.Make(ImageDepth32F())),
            self.DeclareAbstractInputPort("overhead_label_image",
                                          AbstractValue.Make(ImageLabel16I())),
        ]
        self._robot_state = self.DeclareVectorInputPort("robot_state", 2 * NUM_POSITIONS)
        self._base_status = self.DeclareAbstractInputPort("base_status",
                                                          AbstractValue.Make(Status()))
        self._arm_status = self.DeclareAbstractInputPort("arm_status",
                                                         AbstractValue.Make(Status()))
        self._replan = self.DeclareVectorInputPort("replan_request", 1)
        self._state = self.DeclareAbstractState(AbstractValue.Make(_Execution()))
        self.DeclareInitializationUnrestrictedUpdateEvent(self._initialize)
        self.DeclarePeriodicUnrestrictedUpdateEvent(control_period, 0.0, self._step)
        self.DeclareForcedUnrestrictedUpdateEvent(self._step)  # one step on demand (tests)
        self.DeclareAbstractOutputPort(
            "base_command", lambda: AbstractValue.Make(BaseCommand()),
            lambda c, out: out.set_value(self._execution(c).base_command),
            prerequisites_of_calc={self.abstract_state_ticket(self._state)})
        self.DeclareAbstractOutputPort(
            "pick_command", lambda: AbstractValue.Make(PickCommand()),
            lambda c, out: out.set_value(self._execution(c).pick_command),
            prerequisites_of_calc={self.abstract_state_ticket(self._state)})
        self.DeclareAbstractOutputPort(
            "progress", lambda: AbstractValue.Make(PlanProgress()), self._calc_progress,
            prerequisites_of_calc={self.abstract_state_ticket(self._state)})
        # A model value of object: the ports carry None until (and unless) there is a plan.
        self.DeclareAbstractOutputPort(
            "plan", lambda: AbstractValue.Make(None),
            lambda c, out: out.set_value(self._execution(c).plan),
            prerequisites_of_calc={self.abstract_state_ticket(self._state)})
        self.DeclareAbstractOutputPort(
            "planning_result", lambda: AbstractValue.Make(None),
            lambda c, out: out.set_value(self._execution(c).result),
            prerequisites_of_calc={self.abstract_state_ticket(self._state)})
        self.DeclareVectorOutputPort(
            "planning_time", 1,
            lambda c, out: out.SetAtIndex(0, self._execution(c).planning_time),
            prerequisites_of_calc={self.abstract_state_ticket(self._state)})

    # ------------------------------------------------------------------------ helpers
    def _execution(self, context: Context) -> _Execution:
        return context.get_abstract_state(int(self._state)).get_value()

    def _plan(self, context: Context, execution: _Execution, *, start: np.ndarray,
              dishes: Sequence[str]) -> _Execution:
        """A new plan from base pose `start` for `dishes`, or a finished execution saying
        why there is none."""
        t0 = time.perf_counter()
        images = tuple(np.asarray(port.Eval(context).data) for port in self._images)
        known = perceive_known_world(self._scenario, images, pose=start, dishes=dishes,
                                     perceive=self._perceive, robot_labels=self._robot_labels)
        result = plan_from(known, method=self._method, seed=self._seed, workers=self._workers,
                           progress=self._progress_bar, started=t0)
        if result.navigation is not None:
            result.navigation.seal()
        spent = execution.planning_time + time.perf_counter() - t0
        if result.plan is None:
            return dataclasses.replace(execution, result=result, finished=True,
                                       reason=result.error, planning_time=spent)
        return dataclasses.replace(execution, result=result, step=0, command_id=NO_COMMAND,
                                   finished=not result.plan.actions,
                                   reason="" if result.plan.actions else "plan complete",
                                   planning_time=spent)

    # ------------------------------------------------------------------------- events
    def _initialize(self, context: Context, state: State) -> None:
        start = np.asarray(self._robot_state.Eval(context))[:3]
        execution = self._plan(context, _Execution(), start=start,
                               dishes=[d.name for d in self._scenario.dishes])
        if self._replan.HasValue(context):
            execution = dataclasses.replace(execution,
                                            replan_seen=float(self._replan.Eval(context)[0]))
        state.get_mutable_abstract_state(int(self._state)).set_value(execution)

    def _step(self, context: Context, state: State) -> None:
        execution = self._execution(context)
        if self._replan.HasValue(context):
            request = float(self._replan.Eval(context)[0])
            if request != execution.replan_seen:
                collected = {o.argument for o in execution.outcomes
                             if o.action == "pickup" and o.done}
                remaining = [d.name for d in self._scenario.dishes if d.name not in collected]
                start = np.asarray(self._robot_state.Eval(context))[:3]
                execution = self._plan(context, dataclasses.replace(
                    execution, finished=False, reason="", replan_seen=request),
                    start=start, dishes=remaining)
        if not execution.finished and execution.plan is not None:
            execution = self._advance(context, execution)
        state.get_mutable_abstract_state(int(self._state)).set_value(execution)

    def _advance(self, context: Context, e: _Execution) -> _Execution:
        actions = e.plan.actions
        action = actions[e.step]
        if e.command_id == NO_COMMAND:  # send the command for this step
            cid = e.next_id
            if isinstance(action, Goto):
                here = np.asarray(self._robot_state.Eval(context))[:2]
                nav = e.result.navigation
                path = nav.path(here, action.pose[:2]) if nav is not None else None
                if path is None:  # no way from where it stands: drive the planned path
                    path = np.vstack([here, np.asarray(action.path)[1:]])
                command = BaseCommand(id=cid, path=tuple((float(x), float(y)) for x, y in path),
                                      pose=tuple(float(v) for v in action.pose))
                return dataclasses.replace(e, command_id=cid, next_id=cid + 1,
                                           base_command=command)
            x, y, yaw = np.asarray(self._robot_state.Eval(context))[:3]
            facing = facing_yaw((x, y), self._dish_xy[action.dish])
            if not e.turned and abs(wrap(facing - yaw)) > TURN_TOLERANCE:
                # Fea^m assumed the base faces the dish it picks; the stop faced the first.
                turn = BaseCommand(id=cid, path=((float(x), float(y)),),
                                   pose=(float(x), float(y), float(facing)), turn=True)
                return dataclasses.replace(e, command_id=cid, next_id=cid + 1,
                                           base_command=turn, turning=True)
            return dataclasses.replace(e, command_id=cid, next_id=cid + 1, turned=True,
                                       pick_command=PickCommand(id=cid, dish=action.dish),
                                       pick_pose=(float(x), float(y), float(yaw)))
        goto = isinstance(action, Goto) or e.turning
        status: Status = (self._base_status if goto else self._arm_status).Eval(context)
        if status.id != e.command_id or not status.finished:
            return e
        done = status.state == CommandState.DONE
        if e.turning and done:
            return dataclasses.replace(e, command_id=NO_COMMAND, turning=False, turned=True)
        goto = isinstance(action, Goto)
        name, arg = ("goto", action.location) if goto else ("pickup", action.dish)
        outcome = ActionOutcome(name, arg, done=done and not e.turning,
                                reason=f"turn {status.reason}" if e.turning else
                                "" if done else status.reason)
        pickups = e.pickups
        if not goto:
            pickups = (*pickups, self._record(context, e, action, status))
        e = dataclasses.replace(e, outcomes=(*e.outcomes, outcome),
                                pickups=pickups, command_id=NO_COMMAND, step=e.step + 1,
                                turning=False, turned=False)
        if goto and not done:
            return dataclasses.replace(e, finished=True,
                                       reason=f"goto {arg} failed: {status.reason}")
        if e.step >= len(actions):
            return dataclasses.replace(e, finished=True, reason="plan complete")
        return e

    def _record(self, context: Context, e: _Execution, action: Pickup,
                status: Status) -> PickupRecord:
        """The record of the pickup at `e.step`, which `status` has just finished."""
        if e.turning:  # the turn to face the dish failed: no pick, the base stopped here
            actual = tuple(float(v) for v in np.asarray(self._robot_state.Eval(context))[:3])
            outcome, noise = f"turn {status.reason}", None
        else:
            actual = e.pick_pose
            outcome = "done" if status.state == CommandState.DONE else status.reason
            noise = status.reach_noise
        # The stop the prediction was made for: the latest goto's pose, else where the
        # plan started.
        stop = next((a.pose for a in reversed(e.plan.actions[:e.step]) if isinstance(a, Goto)),
                    e.result.known.pose)
        return PickupRecord(dish=action.dish, kind=self._dish_kind[action.dish],
                            method=self._method, predicted=float(action.feasibility),
                            source=e.result.known.planner.feasibility,
                            planned_pose=tuple(float(v) for v in stop), actual_pose=actual,
                            outcome=outcome, reach_noise=noise)

    def _calc_progress(self, context: Context, out) -> None:
        e = self._execution(context)
        total = len(e.plan.actions) if e.plan is not None else 0
        out.set_value(PlanProgress(step=min(e.step + 1, total) if total else 0, total=total,
                                   finished=e.finished, reason=e.reason, outcomes=e.outcomes,
                                   pickups=e.pickups))
