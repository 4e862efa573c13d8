"""The S3O planner as a LeafSystem: plans at start, sends goals, follows the controllers.

The planner sees what the robot can know: the overhead camera's images and the robot's
state. At initialization it makes a `KnownWorld` of them (`perception.perceive_known_world`:
the map, the chairs a perception function reports, by default `perception.ChairPerception`,
the dishes left and where the robot stands) and plans from it with the planning pipeline
(`planning.pipeline.plan_from`: Fea^m from `planner.feasibility`, "oracle" or "fcn", then
the chosen method). It then walks the plan one action at a time: a `goto` becomes a
BaseCommand whose path, on the plan's own navigation map, starts where the base really is
(the previous landing carried noise), a `pickup` a PickCommand, a `place` a PickCommand
with `place` (put the held object down at its place target). It advances when the
controller reports the command done; a failed pickup is recorded and the plan goes on with
the next action (the dish stays where it is); a failed goto ends the execution (the plan's
later pickups assumed that stop). Each finished pickup also leaves a `PickupRecord` on
`progress` (the Fea^m the plan predicted from its planned stop, where the base really stood,
the outcome, the reach noise the arm drew): what Fea^m is calibrated against.

That is the paper's open loop, `execution.recovery: none`. With `retry`, before each
pickup the robot localises and checks the stop (s3o_drake/execution/recovery.py): when the
pickup test fails from where it believes it stands, or the plan's Fea^m there is below
`execution.min_feasibility`, it makes a corrective move to the best nearby stop (at most
`max_corrections` per attempt), and a failed pickup is tried again, after a move where the
arm found no way (at most `max_tries` attempts per dish and plan). With `replan`, also a
blocked drive, or a dish that failed all its tries, makes the planner plan the dishes that
remain from where the robot believes it stands, with the same pipeline and
`execution.replan_budget` (at most `max_replans` per run). Where a blocked drive touched
what blocked it is an obstacle to the replans' navigation. A dish that failed all its tries
in PLANS_PER_DISH plans is left, and so is one whose replan finds no plan (the old plan
goes on). Dishes no free pose of the known world can pick are reported on
`progress.unreachable`; those a plan left out (on the network's Fea^m alone, or with no
stop on the map) are planned for again at its end, on a map with TIGHT_DRIVE_MARGIN.
Every recovery is a `RecoveryRecord`.

A change of the optional `replan_request` input's value also plans the dishes not yet
collected again, from the robot's current pose.
"""

from __future__ import annotations

import dataclasses
import sys
import time
from collections.abc import Sequence

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import Context, LeafSystem, State
from pydrake.systems.sensors import ImageDepth32F, ImageLabel16I, ImageRgba8U

from s3o_drake.belief import Perceive, perceive_known_world
from s3o_drake.execution.execution_state import ExecutionState
from s3o_drake.execution.messages import (
    NO_COMMAND,
    PLAN_ENDED,
    ActionOutcome,
    BaseCommand,
    CommandState,
    PickCommand,
    PickupRecord,
    PlanProgress,
    PlanTime,
    RecoveryRecord,
    Status,
)
from s3o_drake.execution.recovery import MIN_CORRECTION, StopCheck, describe_move, localise
from s3o_drake.feasibility.landing import TURN_TOLERANCE
from s3o_drake.planning.navigation.map import DRIVE_MARGIN, TIGHT_DRIVE_MARGIN
from s3o_drake.planning.pipeline import plan_from
from s3o_drake.planning.plan import Goto, Pickup, Place
from s3o_drake.world.angles import facing_yaw, wrap
from s3o_drake.world.choices import Recovery
from s3o_drake.world.goals import place_target_name, place_targets
from s3o_drake.world.robot import CONTROL_PERIOD, NUM_POSITIONS
from s3o_drake.world.scenario import Scenario
from s3o_drake.world.system_lifetime import weak_callback

#: A dish that fails all its tries in this many plans is left (execution.recovery replan).
PLANS_PER_DISH = 2
#: Arm failures that no retry can mend: the planner goes on with the next action.
NOT_RETRIED = ("unknown_dish", "hand_full", "not_held")


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
      base_command (abstract BaseCommand), pick_command (abstract PickCommand); progress
        (abstract PlanProgress: an ActionOutcome per finished action, a PickupRecord per
        finished pickup, a RecoveryRecord per recovery, a PlanTime per plan, the unreachable
        dishes);
      plan (abstract TaskMotionPlan, or None before planning / when none could be made);
      planning_result (abstract PlanningResult, or None before planning: the latest plan
        and what it was made on, the KnownWorld, heatmaps, navigation map and state spaces);
      planning_time (1: wall time in s spent planning so far, all plans).
    """

    def __init__(self, *, scenario: Scenario, method: str | None = None, seed: int | None = None,
                 perceive: Perceive | None = None, workers: int | None = None,
                 control_period: float = CONTROL_PERIOD, progress_bar: bool = False,
                 robot_labels: frozenset[int] = frozenset(), noise: bool = True):
        super().__init__()
        self._settings = scenario.execution
        self._recovery = Recovery(scenario.execution.recovery)
        self._noise = noise  # the localisation's noise (the simulation's noise switch)
        self._scenario = scenario
        self._method = method or scenario.planner.method
        self._seed = scenario.seed if seed is None else int(seed)
        self._perceive = perceive  # None: ChairPerception from where the robot stands
        self._workers = scenario.planner.workers if workers is None else workers
        self._progress_bar = progress_bar
        self._robot_labels = robot_labels  # the robot's own pixels, for the FCN's view
        # Where each pick and each place is: the dish, or the object's place target.
        self._target_xy = {d.name: tuple(d.position) for d in scenario.dishes} | {
            t.target: t.position for t in place_targets(scenario)}
        self._dish_kind = {d.name: d.kind for d in scenario.dishes}
        self._to_place = {t.name for t in place_targets(scenario)}
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
        self._replan_port = self.DeclareVectorInputPort("replan_request", 1)
        self._state = self.DeclareAbstractState(AbstractValue.Make(ExecutionState()))
        self.DeclareInitializationUnrestrictedUpdateEvent(weak_callback(self._initialize))
        self.DeclarePeriodicUnrestrictedUpdateEvent(control_period, 0.0, weak_callback(self._step))
        # One step on demand (tests).
        self.DeclareForcedUnrestrictedUpdateEvent(weak_callback(self._step))
        state = {self.abstract_state_ticket(self._state)}
        # The plan ports' model is None: they carry None until (and unless) there is a plan.
        for name, make, field in (("base_command", BaseCommand, "base_command"),
                                  ("pick_command", PickCommand, "pick_command"),
                                  ("plan", lambda: None, "plan"),
                                  ("planning_result", lambda: None, "result")):
            self.DeclareAbstractOutputPort(
                name, lambda make=make: AbstractValue.Make(make()),
                weak_callback(self._calc_state_field, field=field), prerequisites_of_calc=state)
        self.DeclareAbstractOutputPort("progress", lambda: AbstractValue.Make(PlanProgress()),
                                       weak_callback(self._calc_progress),
                                       prerequisites_of_calc=state)
        self.DeclareVectorOutputPort("planning_time", 1, weak_callback(self._calc_planning_time),
                                     prerequisites_of_calc=state)

    # ------------------------------------------------------------------------ helpers
    def _calc_state_field(self, context: Context, out, *, field: str) -> None:
        out.set_value(getattr(self._execution(context), field))

    def _calc_planning_time(self, context: Context, out) -> None:
        out.SetAtIndex(0, self._execution(context).planning_time)

    def _execution(self, context: Context) -> ExecutionState:
        return context.get_abstract_state(int(self._state)).get_value()

    def _pose(self, context: Context) -> np.ndarray:
        """The base's true pose (x, y, yaw)."""
        return np.asarray(self._robot_state.Eval(context))[:3].copy()

    def _belief(self, context: Context, e: ExecutionState) -> np.ndarray:
        """Where the robot believes it stands now (localised, execution.recovery)."""
        return localise(self._pose(context), uncertainty=self._scenario.uncertainty,
                        seed=self._seed, command_id=e.next_id, noise=self._noise)

    def _remaining(self, e: ExecutionState) -> tuple[list[str], str]:
        """The objects whose goal is not yet met (collected, or put down at their place),
        less those given up or unreachable; and the one in the gripper ("" for none)."""
        done = e.picked - self._to_place | e.put
        left = [d.name for d in self._scenario.dishes
                if d.goal != "stay" and d.name not in done
                and d.name not in e.given_up and d.name not in e.unreachable]
        return left, next((d for d in left if d in e.picked), "")

    def _plan(self, context: Context, execution: ExecutionState, *, start: np.ndarray,
              dishes: Sequence[str], budget: float | None = None, held: str = "",
              drive_margin: float = DRIVE_MARGIN) -> ExecutionState:
        """A new plan from base pose `start` for `dishes` (`held` in the gripper), or a
        finished execution saying why there is none."""
        t0 = time.perf_counter()
        if self._progress_bar:  # say what is happening as it happens (stderr, with the bars)
            print(f"perceiving the unmapped chairs in the overhead camera's images "
                  f"({len(dishes)} dishes to plan for)", file=sys.stderr, flush=True)
        # Copies: a view of an image is a view of this context's cache, and one kept in the
        # plan's results would keep the whole context (scene graph, renderer) alive.
        images = tuple(np.array(port.Eval(context).data) for port in self._images)
        known = perceive_known_world(self._scenario, images, pose=start, dishes=dishes,
                                     perceive=self._perceive, robot_labels=self._robot_labels,
                                     held=held)
        known = dataclasses.replace(known, contacts=execution.contacts)
        planner = self._scenario.planner
        budget = planner.time_budget if budget is None else budget
        if self._progress_bar:
            print(f"planning with {self._method or planner.method} (Fea^m from "
                  f"{planner.feasibility}) within a budget of {budget:g} s",
                  file=sys.stderr, flush=True)
        result = plan_from(known, method=self._method, seed=self._seed, workers=self._workers,
                           time_budget=budget, progress=self._progress_bar, started=t0,
                           drive_margin=drive_margin)
        if result.navigation is not None:
            result.navigation.seal()
        plans = (*execution.plans, PlanTime(result.planning_time, None if result.plan is None
                                            else result.plan.timing.get("feasibility", 0.0),
                                            budget))
        if result.plan is None:
            return dataclasses.replace(execution, result=result, check=None, finished=True,
                                       reason=result.error, plans=plans)
        unreachable = tuple(sorted(set(execution.unreachable) | set(result.plan.unreachable)))
        check = (StopCheck(known, result.heatmaps, result.navigation,
                           model_heatmaps=result.model_heatmaps)
                 if self._recovery != Recovery.NONE else None)
        return dataclasses.replace(
            execution, result=result, check=check, step=-1, unreachable=unreachable,
            plans=plans, finished=not result.plan.actions,
            reason="" if result.plan.actions else PLAN_ENDED).next_step()

    def _replan(self, context: Context, e: ExecutionState, *, trigger: str, dish: str = "",
                drive_margin: float = DRIVE_MARGIN) -> ExecutionState:
        """The dishes that remain planned again from where the robot believes it stands
        (execution.recovery replan), or the execution finished where that is not allowed."""
        remaining, held = self._remaining(e)
        if not remaining:
            return dataclasses.replace(e, finished=True, reason=PLAN_ENDED)
        belief = self._belief(context, e)
        t = context.get_time()
        before = dataclasses.replace(e, replans=e.replans + 1)
        e = self._plan(context, before, start=belief, dishes=remaining, held=held,
                       budget=self._settings.replan_budget, drive_margin=drive_margin)
        plan = e.plan
        result = "done" if plan is not None else e.reason
        action = (f"planned {len(remaining)} dish{'es' if len(remaining) > 1 else ''} from "
                  f"({belief[0]:.2f}, {belief[1]:.2f})"
                  + (f": {len(plan.actions)} actions" if plan is not None else ""))
        record = RecoveryRecord("replan", dish, trigger, action, result, t, t,
                                planning_time=e.plans[-1].planning_time)
        if plan is None and dish:
            # No plan for what remains (the motion search found no valid one, often for the
            # very dish that failed): that dish is left and the old plan goes on, rather than
            # the run ending with the other dishes still on the tables.
            before = dataclasses.replace(before, plans=e.plans,
                                         recoveries=(*before.recoveries, record))
            return self._give_up(context, before, before.plan.actions[before.step], trigger)
        return dataclasses.replace(e, recoveries=(*e.recoveries, record))

    # ------------------------------------------------------------------------- events
    def _initialize(self, context: Context, state: State) -> None:
        execution = self._plan(context, ExecutionState(), start=self._pose(context),
                               dishes=[d.name for d in self._scenario.dishes])
        if self._replan_port.HasValue(context):
            execution = dataclasses.replace(
                execution, replan_seen=float(self._replan_port.Eval(context)[0]))
        state.get_mutable_abstract_state(int(self._state)).set_value(execution)

    def _step(self, context: Context, state: State) -> None:
        execution = self._execution(context)
        if self._replan_port.HasValue(context):
            request = float(self._replan_port.Eval(context)[0])
            if request != execution.replan_seen:
                remaining, held = self._remaining(execution)
                execution = self._plan(context, dataclasses.replace(
                    execution, finished=False, reason="", replan_seen=request),
                    start=self._pose(context), dishes=remaining, held=held)
        if not execution.finished and execution.plan is not None:
            execution = self._advance(context, execution)
            if execution.finished and execution.reason == PLAN_ENDED:
                execution = self._recheck(context, execution)
        state.get_mutable_abstract_state(int(self._state)).set_value(execution)

    def _recheck(self, context: Context, e: ExecutionState) -> ExecutionState:
        """At the plan's end, with recovery replan: the dishes the plans left out planned
        for again, once, with the replan budget, on a map that keeps only the collision
        check's padding (TIGHT_DRIVE_MARGIN): those left out on the network's Fea^m alone
        (`PlanningResult.unchecked`: no time for the Drake check, which runs now) and those
        the map gave no stop (a way closed by millimetres: dense task_030's bowl_1, behind
        a chair perceived 1-6 mm off). The execution as it was when none, or no plan."""
        left = sorted((set(e.result.unchecked) | set(e.unreachable)) - set(e.rechecked))
        if (self._recovery != Recovery.REPLAN or not left
                or e.replans >= self._settings.max_replans):
            return e
        again = self._replan(context, dataclasses.replace(
            e, finished=False, reason="", rechecked=(*e.rechecked, *left),
            unreachable=tuple(d for d in e.unreachable if d not in left)),
            trigger=f"left out: {', '.join(left)}", drive_margin=TIGHT_DRIVE_MARGIN)
        if again.plan is None:  # the run ends as the old plan did, the replan recorded
            return dataclasses.replace(e, recoveries=again.recoveries, plans=again.plans)
        return again

    def _send_base(self, e: ExecutionState, command: BaseCommand, **changes) -> ExecutionState:
        return dataclasses.replace(e, command_id=command.id, next_id=command.id + 1,
                                   base_command=command, **changes)

    def _drive(self, e: ExecutionState, cid: int, here: np.ndarray, pose: Sequence[float],
               planned: Sequence | None = None) -> BaseCommand:
        """A drive from `here` to `pose` on the plan's navigation map (else along `planned`,
        the plan's own waypoints, or straight)."""
        nav = e.result.navigation
        path = nav.path(here[:2], pose[:2]) if nav is not None else None
        if path is None:
            rest = np.asarray(planned)[1:] if planned is not None else np.asarray([pose[:2]])
            path = np.vstack([here[:2], rest])
        return BaseCommand(id=cid, path=tuple((float(x), float(y)) for x, y in path),
                           pose=tuple(float(v) for v in pose))

    def _advance(self, context: Context, e: ExecutionState) -> ExecutionState:
        if e.to_tray:
            return self._put_on_tray(context, e)
        action = e.plan.actions[e.step]
        if e.command_id == NO_COMMAND:
            return self._send(context, e, action)
        base = isinstance(action, Goto) or e.turning or e.correcting
        status: Status = (self._base_status if base else self._arm_status).Eval(context)
        if status.id != e.command_id or not status.finished:
            return e
        done = status.state == CommandState.DONE
        if base and status.contact is not None and self._recovery == Recovery.REPLAN:
            e = dataclasses.replace(e, contacts=(*e.contacts, status.contact))
        if e.correcting:
            return self._corrected(context, e, done, status.reason)
        if e.turning and done:
            return dataclasses.replace(e, command_id=NO_COMMAND, turning=False, turned=True)
        if isinstance(action, Goto):
            outcome = ActionOutcome("goto", action.location, done=done,
                                    reason="" if done else status.reason)
            e = dataclasses.replace(e, outcomes=(*e.outcomes, outcome))
            if done:
                return self._after(e.next_step())
            trigger = f"goto {action.location} failed: {status.reason}"
            if self._recovery == Recovery.REPLAN and e.replans < self._settings.max_replans:
                return self._replan(context, e, trigger=trigger)
            return dataclasses.replace(e, finished=True, reason=trigger)
        return self._picked(context, e, action, status)

    def _send(self, context: Context, e: ExecutionState, action) -> ExecutionState:
        """The command for the action at `e.step` (a stop check first, when recovering)."""
        cid = e.next_id
        here = self._pose(context)
        if isinstance(action, Goto):
            return self._send_base(e, self._drive(e, cid, here, action.pose, action.path))
        target = self._target(action)
        if e.check is not None and not e.checked:
            corrected = self._check_stop(context, e, target)
            if corrected is not None:
                return corrected
            e = dataclasses.replace(e, checked=True)
        x, y, yaw = here
        facing = facing_yaw((x, y), self._target_xy[target])
        if not e.turned and abs(wrap(facing - yaw)) > TURN_TOLERANCE:
            # Fea^m assumed the base faces the dish it picks; the stop faced the first.
            turn = BaseCommand(id=cid, path=((float(x), float(y)),),
                               pose=(float(x), float(y), float(facing)), turn=True)
            return self._send_base(e, turn, turning=True)
        placing = isinstance(action, Place)
        command = PickCommand(id=cid, dish=action.dish, place=placing,
                              place_from=None if placing else e.place_stop(action.dish, here))
        return dataclasses.replace(e, command_id=cid, next_id=cid + 1, turned=True,
                                   pick_command=command,
                                   pick_pose=(float(x), float(y), float(yaw)),
                                   pick_started=context.get_time())

    @staticmethod
    def _target(action: Pickup | Place) -> str:
        """What the arm reaches for: the dish, or the place target of the object to put."""
        return place_target_name(action.dish) if isinstance(action, Place) else action.dish

    def _check_stop(self, context: Context, e: ExecutionState,
                    dish: str) -> ExecutionState | None:
        """A corrective move's command when the stop check asks for one and allows it
        (`dish`: what the arm reaches for, a dish or a place target)."""
        if e.corrections >= self._settings.max_corrections:
            return None
        belief = self._belief(context, e)
        if not e.force_move:
            verdict = e.check.assess(belief, dish)
            if verdict.acceptable(self._settings.min_feasibility):
                return None
            trigger = ("not feasible" if not verdict.feasible else
                       f"Fea^m {verdict.feasibility:.2f} < {self._settings.min_feasibility:g}")
            trigger = f"stop check at ({belief[0]:.2f}, {belief[1]:.2f}): {trigger}"
        else:
            trigger = f"pickup failed: {e.last_failure}"
        best = e.check.correction(belief, dish, self._settings.correction_radius,
                                  threshold=self._settings.min_feasibility,
                                  detour=self._settings.detour)
        if best is None or (not e.force_move
                            and np.linalg.norm(best[0] - belief[:2]) < MIN_CORRECTION):
            return None
        target, feasibility = best
        # The base drives by what it believes: a target in the map is reached as far off
        # as the robot's belief of where it stood.
        here = self._pose(context)
        aim = target + (here[:2] - belief[:2])
        pose = (float(aim[0]), float(aim[1]), float(facing_yaw(aim, self._target_xy[dish])))
        command = self._drive(e, e.next_id, here, pose)
        stop = ((float(target[0]), float(target[1]), pose[2]), feasibility)
        return self._send_base(
            e, command, correcting=True, corrections=e.corrections + 1, turned=False,
            pending=(trigger, describe_move(belief, target), context.get_time()), stop=stop)

    def _corrected(self, context: Context, e: ExecutionState, done: bool,
                   reason: str) -> ExecutionState:
        """A corrective move ended: recorded; the stop is checked again from the landing."""
        trigger, action, started = e.pending
        record = RecoveryRecord("correction", self._current_dish(e), trigger, action,
                                "done" if done else f"failed: {reason}", started,
                                context.get_time())
        return dataclasses.replace(e, command_id=NO_COMMAND, correcting=False, checked=False,
                                   force_move=False, recoveries=(*e.recoveries, record))

    def _current_dish(self, e: ExecutionState) -> str:
        action = e.plan.actions[e.step]
        return action.dish if isinstance(action, Pickup | Place) else ""

    def _picked(self, context: Context, e: ExecutionState, action: Pickup | Place,
                status: Status) -> ExecutionState:
        """A pickup or place attempt (or the turn before it) ended: recorded, then retried,
        replanned or left, as execution.recovery says."""
        done = status.state == CommandState.DONE and not e.turning
        reason = f"turn {status.reason}" if e.turning else "" if done else status.reason
        name = "place" if isinstance(action, Place) else "pickup"
        outcome = ActionOutcome(name, action.dish, done=done, reason=reason)
        e = dataclasses.replace(
            e, outcomes=(*e.outcomes, outcome),
            pickups=(*e.pickups, self._record(context, e, action, status)))
        if e.tries > 0:  # this attempt was a retry
            t = context.get_time()
            record = RecoveryRecord("retry", action.dish, e.last_failure,
                                    f"try {e.tries + 1} of {self._settings.max_tries}",
                                    "done" if done else f"failed: {reason}",
                                    e.pick_started if not e.turning else t, t)
            e = dataclasses.replace(e, recoveries=(*e.recoveries, record))
        if done or e.check is None or reason in NOT_RETRIED:
            if not done and isinstance(action, Place):
                return e.next_step(to_tray=action.dish)
            return self._after(e.next_step())
        if e.tries + 1 < self._settings.max_tries:
            # Tried again after a check of the stop; where the arm found no way from where
            # the base stood, the base moves first.
            return dataclasses.replace(
                e, tries=e.tries + 1, command_id=NO_COMMAND, turning=False, turned=False,
                checked=False, corrections=0, force_move=reason != "missed",
                last_failure=reason)
        trigger = f"{action.dish} failed {e.tries + 1} tries (last: {reason})"
        exhausted = (*e.exhausted, action.dish)
        if (self._recovery == Recovery.REPLAN and e.replans < self._settings.max_replans
                and exhausted.count(action.dish) < PLANS_PER_DISH):
            return self._replan(context, dataclasses.replace(e, exhausted=exhausted),
                                trigger=trigger, dish=action.dish)
        return self._give_up(context, dataclasses.replace(e, exhausted=exhausted), action,
                             trigger)

    def _give_up(self, context: Context, e: ExecutionState, action: Pickup | Place,
                 trigger: str) -> ExecutionState:
        """The dish of `action` at `e.step` given up (`ExecutionState.give_up`)."""
        e = e.give_up(action.dish, trigger, context.get_time(), placing=isinstance(action, Place))
        return e if e.to_tray else self._after(e)

    def _put_on_tray(self, context: Context, e: ExecutionState) -> ExecutionState:
        """`e.to_tray`, whose place failed for good, is let go over the tray (a PickCommand
        of the object the gripper holds); then the plan goes on, whatever came of it."""
        if e.command_id == NO_COMMAND:
            cid = e.next_id
            return dataclasses.replace(e, command_id=cid, next_id=cid + 1,
                                       pick_command=PickCommand(id=cid, dish=e.to_tray),
                                       pick_started=context.get_time())
        status: Status = self._arm_status.Eval(context)
        if status.id != e.command_id or not status.finished:
            return e
        return self._after(dataclasses.replace(e, to_tray="", command_id=NO_COMMAND))

    def _after(self, e: ExecutionState) -> ExecutionState:
        """The execution after an action: finished at the end of the plan."""
        if e.step >= len(e.plan.actions):
            return dataclasses.replace(e, finished=True, reason=PLAN_ENDED)
        return e

    def _record(self, context: Context, e: ExecutionState, action: Pickup | Place,
                status: Status) -> PickupRecord:
        """The record of the pickup (or place: its `dish` is the place target) at
        `e.step`, which `status` has just finished."""
        return e.pickup_record(action, status, target=self._target(action),
                               kind=self._dish_kind[action.dish], method=self._method,
                               here=self._pose(context))

    def _calc_progress(self, context: Context, out) -> None:
        e = self._execution(context)
        total = len(e.plan.actions) if e.plan is not None else 0
        out.set_value(PlanProgress(step=min(e.step + 1, total) if total else 0, total=total,
                                   finished=e.finished, reason=e.reason, outcomes=e.outcomes,
                                   pickups=e.pickups, recoveries=e.recoveries,
                                   unreachable=e.unreachable, plans=e.plans))
