"""The Executive: walks a plan one action at a time and recovers when an action fails.

A plain-Python state machine with an explicit `Mode`, no Drake: `Executive.step(state,
event)` returns the next `ExecutiveState` (an immutable value) and the `Decision`s to carry
out. The ExecutiveSystem (executive_system.py) is its adapter: it turns the controllers'
reports into events, carries out the decisions (commands on its output ports, plans
through the planning pipeline) and keeps the state in its Context. What needs Drake or
perception comes in as plain values and callables: a `Plan` decision is answered with a
`PlanReady` (the plan, its `StopChecker`) or a `PlanFailed` event, and the robot's belief
of its pose is the `localise` callable's.

The walk (`execution.recovery: none`, the paper's open loop): a `goto` becomes a `Drive`;
a `pickup` a `Pick`, after a `Turn` in place when the base does not face the dish (Fea^m
assumed it does; a stop that serves several dishes faces the first); a `place` a `Pick`
with `place`. A failed pickup is recorded and the plan goes on with the next action (the
dish stays where it is); a failed goto ends the execution (the plan's later pickups
assumed that stop); an object to place whose place failed is let go over the tray
(`Release`), so that the gripper is free for the pickups that follow. Each finished
pickup leaves a `PickupRecord`: the Fea^m the plan predicted from its planned stop, where
the base really stood, the outcome, the reach noise the arm drew.

With `retry`, before each pickup the robot localises and checks the stop: when the
pickup test fails from where it believes it stands, or the plan's Fea^m there is below
`min_feasibility`, it makes a corrective move to the best nearby stop (at most
`max_corrections` per attempt), and a failed pickup is tried again, after a move where the
arm found no way (at most `max_tries` attempts per dish and plan). With `replan`, also a
blocked drive, or a dish that failed all its tries, asks for a plan of the dishes that
remain from where the robot believes it stands, with `replan_budget` (at most
`max_replans` per run). Where a blocked drive touched what blocked it is passed on to the
replans (their navigation keeps clear of it). A dish that failed all its tries in
PLANS_PER_DISH plans is left, and so is one whose replan finds no plan (the old plan goes
on). The dishes a plan left out (on the network's Fea^m alone, or with no stop on the map)
are planned for again at its end, on the tight navigation map. Every recovery is a
`RecoveryRecord`.

With smooth motion (`ExecutiveParams.motion`) the arm works while the base drives: a
drive to a stop whose next action is a pickup also sends the arm towards that dish's
pre-grasp (`Drive.prepare`), and a pickup leaves the arm over the tray when another
pickup or place follows at the stop (`Pick.stow` False), else stowing as the base leaves.
The arm controller reports a pickup done once the dish is lifted, and the walk goes on. A
base command that is no turn to face a dish is sent with the arm stowed: a prepared arm
that is still out (its pickup not made, or failed where it stood) is stowed first
(`Stow`).

Modes (with nothing out, the next `Tick` sends the next command):

    IDLE --Start--> PLANNING --PlanReady--> SEND (FINISHED: no actions)
                             --PlanFailed--> FINISHED
    SEND, goto --> DRIVING --done--> SEND (the next action) | FINISHED (the plan ended)
                           --failed--> PLANNING (replan) | FINISHED
    SEND, pickup or place --> CORRECTING (the stop check asks for a move) --> SEND
                          --> TURNING (not facing) --done--> PICK --> PICKING
                                                   --failed--> as a failed attempt
                          --> PICKING --done--> SEND | FINISHED
                                      --failed--> SEND (retry) | PLANNING (replan)
                                                  | SEND (given up) | RELEASE (a place)
    RELEASE --> RELEASING --> SEND | FINISHED
    SEND, smooth, a base command with the arm out --> STOWING --> SEND
                                                            --failed STOW_ATTEMPTS times--> FINISHED
    FINISHED (the plan ended; recovery replan) --> PLANNING (the dishes left out, once)
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from enum import Enum
from typing import Any, Protocol

import numpy as np

from s3o_drake.execution.messages import (
    NO_COMMAND,
    PLAN_ENDED,
    ActionOutcome,
    PickupRecord,
    PlanProgress,
    PlanTime,
    RecoveryRecord,
)
from s3o_drake.feasibility.landing import TURN_TOLERANCE
from s3o_drake.planning.plan import Goto, Pickup, Place, TaskMotionPlan
from s3o_drake.world.angles import facing_yaw, wrap
from s3o_drake.world.choices import Goal, Motion, Recovery

#: A dish that fails all its tries in this many plans is left (recovery replan).
PLANS_PER_DISH = 2
#: Arm failures that no retry can mend: the walk goes on with the next action.
NOT_RETRIED = ("unknown_dish", "hand_full", "not_held")
#: A corrective move shorter than this (m) is not worth a drive: the stop stays.
MIN_CORRECTION = 0.02

Pose = tuple[float, float, float]
"""A base pose X_WB as (x, y, yaw): m, m, rad."""


class Mode(Enum):
    """Where the walk of the plan stands (see the module docstring)."""

    IDLE = "idle"  # no plan asked for yet
    PLANNING = "planning"  # a `Plan` is out: PlanReady or PlanFailed comes next
    SEND = "send"  # the action at `step` is commanded next (a pickup's stop check first)
    DRIVING = "driving"  # a goto's drive is out
    CORRECTING = "correcting"  # a corrective move is out; the stop is checked again after
    TURNING = "turning"  # the turn to face what the arm reaches for is out
    PICK = "pick"  # the stop is checked and faced: the arm's command next
    PICKING = "picking"  # the arm's pickup or place is out
    RELEASE = "release"  # `to_tray`, held, is let go over the tray next
    RELEASING = "releasing"  # its release is out
    STOWING = "stowing"  # the arm's stow is out, before a base command
    FINISHED = "finished"  # nothing more to do; `reason` says why


# ------------------------------------------------------------------------ the stop check
@dataclass(frozen=True)
class Assessment:
    """The stop check's verdict from a believed position: `feasible` (the pickup test
    passes, facing the dish) and the plan's `feasibility` (Fea^m) there."""

    feasible: bool
    feasibility: float

    def acceptable(self, threshold: float) -> bool:
        return self.feasible and self.feasibility >= threshold


class StopChecker(Protocol):
    """Judges and corrects stops on what the robot knows (recovery.StopCheck)."""

    def assess(self, position: np.ndarray, dish: str) -> Assessment:
        """The verdict on reaching for `dish` from the believed `position` (x, y[, yaw])."""

    def correction(self, position: np.ndarray, dish: str, radius: float, *,
                   threshold: float = 0.0, detour: bool = False
                   ) -> tuple[np.ndarray, float] | None:
        """A better stop (x, y) for `dish` near the believed pose, and its Fea^m; None when
        there is none."""


def describe_move(start: np.ndarray, target: np.ndarray) -> str:
    """`moved 0.18 m to (3.42, 2.10)`: a corrective move, as the report says it."""
    length = math.dist(np.asarray(start)[:2], np.asarray(target)[:2])
    return f"moved {length:.2f} m to ({target[0]:.2f}, {target[1]:.2f})"


# ------------------------------------------------------------------------------ events
@dataclass(frozen=True)
class Start:
    """The run begins at simulated time `t` (s), the base at its true `pose` (x, y, yaw)."""

    t: float
    pose: np.ndarray


@dataclass(frozen=True)
class ReplanRequested:
    """Someone asks for a new plan of the dishes not yet done, from the true `pose`."""

    t: float
    pose: np.ndarray


@dataclass(frozen=True)
class PlanReady:
    """The answer to a `Plan`: `plan`, with the time it took (`time`), the pose it starts
    from (`start`, the belief's), where its Fea^m came from (`source`), the dishes it left
    out unchecked, the `check` of its stops (required with recovery) and `result`, whatever
    the adapter keeps with the plan (the Executive only carries it)."""

    plan: TaskMotionPlan
    time: PlanTime
    start: Pose
    source: str
    unchecked: tuple[str, ...] = ()
    check: StopChecker | None = None
    result: Any = None


@dataclass(frozen=True)
class PlanFailed:
    """The answer to a `Plan` when there is none: why (`error`), the time it took, and the
    adapter's `result`."""

    error: str
    time: PlanTime
    result: Any = None


@dataclass(frozen=True)
class Tick:
    """A control period with no command out (or none finished): time `t`, true `pose`."""

    t: float
    pose: np.ndarray


@dataclass(frozen=True)
class BaseFinished:
    """Base command `id` ended at time `t`, the base at `pose`: done (`ok`) or failed for
    `reason`, touching what blocked it at `contact` (x, y), if it says."""

    t: float
    pose: np.ndarray
    id: int
    ok: bool
    reason: str = ""
    contact: tuple[float, float] | None = None


@dataclass(frozen=True)
class ArmFinished:
    """Arm command `id` ended at time `t`, the base at `pose`: done (`ok`) or failed for
    `reason`; `sighted`: it aimed where the robot's sensor saw its target."""

    t: float
    pose: np.ndarray
    id: int
    ok: bool
    reason: str = ""
    sighted: bool = False


Event = Start | ReplanRequested | PlanReady | PlanFailed | Tick | BaseFinished | ArmFinished


# --------------------------------------------------------------------------- decisions
@dataclass(frozen=True)
class Drive:
    """Base command `id`: drive from `start` (x, y) to `pose`, on the plan's navigation
    map, else along `planned` (the plan's own waypoints), else straight."""

    id: int
    start: np.ndarray
    pose: Pose
    planned: tuple[tuple[float, float], ...] | None = None
    prepare: str = ""
    """With smooth motion: the dish whose pickup follows at the stop; arm command
    `prepare_id` brings the arm to its pre-grasp as the base arrives."""
    prepare_id: int = NO_COMMAND
    face: tuple[float, float] | None = None
    """With smooth motion: the point the base lands facing (what the arm reaches for
    first at the stop), from where it really lands."""


@dataclass(frozen=True)
class Turn:
    """Base command `id`: turn in place to `pose`'s yaw (its x, y: where the base stands)."""

    id: int
    pose: Pose


@dataclass(frozen=True)
class Pick:
    """Arm command `id`: pick `dish` (with `place`, put the held `dish` down at its place);
    `place_from`: the stop its place is planned from, when one follows."""

    id: int
    dish: str
    place: bool = False
    place_from: Pose | None = None
    stow: bool = True
    """After a pickup onto the tray, the arm stows (False: it stays over the tray, where
    the next pickup at this stop starts)."""


@dataclass(frozen=True)
class Stow:
    """Arm command `id`: bring the arm to its stow, before the base moves."""

    id: int


@dataclass(frozen=True)
class Release:
    """Arm command `id`: let the held `dish` go over the tray."""

    id: int
    dish: str


@dataclass(frozen=True)
class Plan:
    """Plan `dishes` (`held` in the gripper) from base pose `start` within `budget` s, on
    the tight navigation map when `tight`, knowing the `contacts` of blocked drives; answer
    with PlanReady or PlanFailed."""

    start: np.ndarray
    dishes: tuple[str, ...]
    held: str
    budget: float
    tight: bool = False
    contacts: tuple[tuple[float, float], ...] = ()


@dataclass(frozen=True)
class Finish:
    """The execution is over, for `reason`."""

    reason: str


Decision = Drive | Turn | Pick | Stow | Release | Plan | Finish


STOW_ATTEMPTS = 3
"""Stows tried in a row before a run whose arm will not stow ends (each is a new path
search with a seed of its own)."""


# ------------------------------------------------------------------------------ params
@dataclass(frozen=True)
class TaskObject:
    """An object of the task: its `name`, `kind` and `goal` (collect, place or stay)."""

    name: str
    kind: str
    goal: str = Goal.COLLECT.value


@dataclass(frozen=True)
class ExecutiveParams:
    """What the Executive needs of the scenario.

    `objects`: the task's; `targets`: the position (x, y, m) of each thing the arm reaches
    for (every object, and every place target); `place_targets`: each object to place's
    place target. `method` names the plans in the pickup records. The first plan (and one
    asked for) has `time_budget` s, a replan `replan_budget`; the rest are
    `execution.*`'s limits and its `motion` (see the module docstring).
    """

    objects: tuple[TaskObject, ...]
    targets: Mapping[str, Sequence[float]]
    place_targets: Mapping[str, str] = dataclasses.field(default_factory=dict)
    method: str = ""
    recovery: Recovery = Recovery.NONE
    time_budget: float = 60.0
    replan_budget: float = 60.0
    min_feasibility: float = 0.5
    correction_radius: float = 0.3
    detour: bool = True
    max_corrections: int = 2
    max_tries: int = 3
    max_replans: int = 4
    motion: str = Motion.STOP_AND_GO.value
    """How the robot moves (`choices.Motion`): with "smooth", the arm works while the base
    drives (module docstring)."""


# ------------------------------------------------------------------------------- state
@dataclass(frozen=True)
class PlanAsk:
    """Why a `Plan` is out, and what to do with its answer: `why` is "start", "request",
    "replan" or "recheck"; a replan's `trigger`, the `dish` that failed (if it was one), the
    `belief` it planned from, the `dishes` asked for, the dishes a recheck asks for again
    (`left`); time `t` and true `pose` when asked."""

    why: str
    t: float
    pose: np.ndarray
    trigger: str = ""
    dish: str = ""
    belief: np.ndarray | None = None
    dishes: tuple[str, ...] = ()
    left: tuple[str, ...] = ()


@dataclass(frozen=True)
class ExecutiveState:
    """Where the execution stands: the mode, the plan in use and the step of it, the
    command out, the current pickup's recovery, and everything the run reports.

    Immutable: every step makes a new one, so the Context's copies of it may share it.
    """

    mode: Mode = Mode.IDLE
    planned: PlanReady | PlanFailed | None = None
    """The latest plan in use, or the failed planning that ended the execution."""
    asked: PlanAsk | None = None  # while PLANNING: why
    step: int = 0  # index into plan.actions of the action being executed
    command_id: int = NO_COMMAND  # the command out for `step` (0: none)
    next_id: int = 1
    reason: str = ""  # why the execution finished
    pick_pose: Pose = (0.0, 0.0, 0.0)  # the true base pose when the arm's command went out
    pick_started: float = 0.0  # simulated time (s) the arm's command went out
    to_tray: str = ""  # an object to place whose place failed for good, to let go
    arm_out: bool = False  # smooth: the arm may be out at a pre-grasp, not stowed
    stow_failures: int = 0  # stows failed in a row, the arm still out
    deferred: tuple[Pose, tuple[str, str, float], tuple[Pose, float] | None] | None = None
    """A corrective move decided while the arm was out: (its pose, `pending`, `stop`), sent
    once the arm has stowed."""
    # The recovery, for the pickup at `step`:
    corrections: int = 0  # corrective moves before this attempt
    tries: int = 0  # failed attempts at this pickup, this plan
    force_move: bool = False  # the last attempt failed where it stood: move before the next
    last_failure: str = ""  # why the last attempt failed (a retry's trigger)
    pending: tuple[str, str, float] = ("", "", 0.0)  # a correction's trigger, action, start
    stop: tuple[Pose, float] | None = None
    """The corrected stop and its Fea^m, when a correction moved the base for this pickup."""
    # The run:
    replans: int = 0
    exhausted: tuple[str, ...] = ()  # a dish per plan in which it failed all its tries
    given_up: tuple[str, ...] = ()
    rechecked: tuple[str, ...] = ()  # dishes planned for again at a plan's end, left out
    unreachable: tuple[str, ...] = ()
    contacts: tuple[tuple[float, float], ...] = ()  # where blocked drives touched (x, y)
    outcomes: tuple[ActionOutcome, ...] = ()
    pickups: tuple[PickupRecord, ...] = ()
    recoveries: tuple[RecoveryRecord, ...] = ()
    plans: tuple[PlanTime, ...] = ()  # each plan's time against its budget

    def __deepcopy__(self, memo: dict) -> ExecutiveState:
        # Immutable all the way down (the plan's navigation map is sealed; the stop check
        # only caches its oracle): a copy would cost megabytes and buy nothing.
        return self

    @property
    def plan(self) -> TaskMotionPlan | None:
        return self.planned.plan if isinstance(self.planned, PlanReady) else None

    @property
    def check(self) -> StopChecker | None:
        return self.planned.check if isinstance(self.planned, PlanReady) else None

    @property
    def result(self) -> Any:
        """The adapter's record of the latest planning (None before any)."""
        return None if self.planned is None else self.planned.result

    @property
    def finished(self) -> bool:
        return self.mode is Mode.FINISHED

    @property
    def active(self) -> bool:
        """Whether the plan is being walked: a control period may move it on."""
        return self.mode not in (Mode.IDLE, Mode.PLANNING, Mode.FINISHED)

    @property
    def awaiting(self) -> str | None:
        """The controller whose report the walk waits for, "base" or "arm"; None when
        nothing is out."""
        if self.mode in (Mode.DRIVING, Mode.CORRECTING, Mode.TURNING):
            return "base"
        if self.mode in (Mode.PICKING, Mode.RELEASING, Mode.STOWING):
            return "arm"
        return None

    @property
    def planning_time(self) -> float:
        """Wall time (s) spent planning, summed over the plans."""
        return sum(p.planning_time for p in self.plans)

    @property
    def picked(self) -> set[str]:
        """The objects picked so far (collected, or held to place)."""
        return {o.argument for o in self.outcomes if o.action == "pickup" and o.done}

    @property
    def put(self) -> set[str]:
        """The objects put down at their places so far."""
        return {o.argument for o in self.outcomes if o.action == "place" and o.done}

    def progress(self) -> PlanProgress:
        """What the run has done so far, as the task monitor reads it."""
        total = len(self.plan.actions) if self.plan is not None else 0
        return PlanProgress(step=min(self.step + 1, total) if total else 0, total=total,
                            finished=self.finished, reason=self.reason,
                            outcomes=self.outcomes, pickups=self.pickups,
                            recoveries=self.recoveries, unreachable=self.unreachable,
                            plans=self.plans)


Step = tuple[ExecutiveState, tuple[Decision, ...]]
Localise = Callable[[np.ndarray, int], np.ndarray]
"""(true pose, id of the next command) -> the pose (x, y, yaw) the robot believes it has."""


# --------------------------------------------------------------------------- executive
class Executive:
    """The recovery policy (see the module docstring): `step(state, event)` is pure, so a
    state may be stepped from twice; `params` and `localise` are fixed for the run."""

    def __init__(self, params: ExecutiveParams, *, localise: Localise) -> None:
        self._params = params
        self._localise = localise
        self._recovery = Recovery(params.recovery)
        self._kinds = {o.name: o.kind for o in params.objects}
        self._to_place = {o.name for o in params.objects if o.goal == Goal.PLACE.value}
        self._smooth = params.motion == Motion.SMOOTH.value

    @property
    def params(self) -> ExecutiveParams:
        return self._params

    def step(self, state: ExecutiveState, event: Event) -> Step:
        """The state after `event`, and what to do about it."""
        if isinstance(event, Start):
            dishes = tuple(o.name for o in self._params.objects)
            new, decisions = self._ask(state, PlanAsk("start", event.t, event.pose),
                                       start=event.pose, dishes=dishes, held="",
                                       budget=self._params.time_budget)
        elif isinstance(event, ReplanRequested):
            remaining, held = self._remaining(state)
            new, decisions = self._ask(state, PlanAsk("request", event.t, event.pose),
                                       start=event.pose, dishes=remaining, held=held,
                                       budget=self._params.time_budget)
        elif isinstance(event, PlanReady | PlanFailed):
            new, decisions = self._planned(state, event)
        elif state.active:
            new, decisions = self._advance(state, event)
            if not decisions or not isinstance(decisions[-1], Plan):
                new, decisions = self._settle(new, decisions, event.t, event.pose)
        else:
            new, decisions = state, ()
        if new.finished and not state.finished:
            decisions = (*decisions, Finish(new.reason))
        return new, decisions

    # ----------------------------------------------------------------------- planning
    def _ask(self, e: ExecutiveState, ask: PlanAsk, *, start: np.ndarray,
             dishes: Sequence[str], held: str, budget: float, tight: bool = False) -> Step:
        ask = dataclasses.replace(ask, dishes=tuple(dishes))
        plan = Plan(start=start, dishes=tuple(dishes), held=held, budget=budget, tight=tight,
                    contacts=e.contacts)
        return dataclasses.replace(e, mode=Mode.PLANNING, asked=ask), (plan,)

    def _planned(self, e: ExecutiveState, event: PlanReady | PlanFailed) -> Step:
        ask = e.asked
        if e.mode is not Mode.PLANNING or ask is None:
            raise ValueError(f"{type(event).__name__} while {e.mode.value}: no plan asked for")
        e = dataclasses.replace(e, asked=None)
        if ask.why in ("start", "request"):
            return self._adopt(e, event), ()
        if ask.why == "recheck":
            if isinstance(event, PlanFailed):
                # The run ends as the old plan did, the replan recorded.
                return dataclasses.replace(
                    e, mode=Mode.FINISHED, plans=(*e.plans, event.time),
                    recoveries=(*e.recoveries, self._replan_record(ask, event))), ()
            e = dataclasses.replace(
                e, replans=e.replans + 1, rechecked=(*e.rechecked, *ask.left),
                unreachable=tuple(d for d in e.unreachable if d not in ask.left))
            e = self._adopt(e, event)
            return dataclasses.replace(
                e, recoveries=(*e.recoveries, self._replan_record(ask, event))), ()
        # A replan while walking.
        record = self._replan_record(ask, event)
        if isinstance(event, PlanFailed) and ask.dish:
            # No plan for what remains (the motion search found no valid one, often for the
            # very dish that failed): that dish is left and the old plan goes on, rather than
            # the run ending with the other dishes still on the tables.
            e = dataclasses.replace(e, plans=(*e.plans, event.time),
                                    recoveries=(*e.recoveries, record))
            e = self._give_up(e, e.plan.actions[e.step], ask.trigger, ask.t)
        else:
            e = self._adopt(e, event)
            e = dataclasses.replace(e, recoveries=(*e.recoveries, record))
        return self._settle(e, (), ask.t, ask.pose)

    def _adopt(self, e: ExecutiveState, event: PlanReady | PlanFailed) -> ExecutiveState:
        """`e` with the new plan from its first action, or finished without one."""
        plans = (*e.plans, event.time)
        if isinstance(event, PlanFailed):
            return dataclasses.replace(e, planned=event, mode=Mode.FINISHED,
                                       reason=event.error, plans=plans)
        if self._recovery != Recovery.NONE and event.check is None:
            raise ValueError(f"recovery {self._recovery.value}: a plan needs its stop check")
        actions = event.plan.actions
        unreachable = tuple(sorted(set(e.unreachable) | set(event.plan.unreachable)))
        e = _next_step(dataclasses.replace(e, planned=event, step=-1, unreachable=unreachable,
                                           plans=plans, reason="" if actions else PLAN_ENDED))
        return e if actions else dataclasses.replace(e, mode=Mode.FINISHED)

    def _replan(self, e: ExecutiveState, ask: PlanAsk) -> Step:
        """A plan of the dishes that remain, from where the robot believes it stands, or
        the execution finished when none remain."""
        remaining, held = self._remaining(e)
        if not remaining:
            return dataclasses.replace(e, mode=Mode.FINISHED, reason=PLAN_ENDED), ()
        ask = dataclasses.replace(ask, belief=self._localise(ask.pose, e.next_id))
        return self._ask(dataclasses.replace(e, replans=e.replans + 1), ask, start=ask.belief,
                         dishes=remaining, held=held, budget=self._params.replan_budget)

    @staticmethod
    def _replan_record(ask: PlanAsk, event: PlanReady | PlanFailed) -> RecoveryRecord:
        count = len(ask.dishes)
        plan = event.plan if isinstance(event, PlanReady) else None
        action = (f"planned {count} dish{'es' if count > 1 else ''} from "
                  f"({ask.belief[0]:.2f}, {ask.belief[1]:.2f})"
                  + (f": {len(plan.actions)} actions" if plan is not None else ""))
        return RecoveryRecord("replan", ask.dish, ask.trigger, action,
                              "done" if plan is not None else event.error, ask.t, ask.t,
                              planning_time=event.time.planning_time)

    def _remaining(self, e: ExecutiveState) -> tuple[tuple[str, ...], str]:
        """The objects whose goal is not yet met (collected, or put down at their place),
        less those given up or unreachable; and the one in the gripper ("" for none)."""
        done = e.picked - self._to_place | e.put
        left = tuple(o.name for o in self._params.objects
                     if o.goal != Goal.STAY.value and o.name not in done
                     and o.name not in e.given_up and o.name not in e.unreachable)
        return left, next((d for d in left if d in e.picked), "")

    def _settle(self, e: ExecutiveState, decisions: tuple[Decision, ...], t: float,
                pose: np.ndarray) -> Step:
        """After a step of the walk: at the plan's end, with recovery replan, the dishes the
        plans left out are planned for again, once, on a map that keeps only the collision
        check's padding: those left out on the network's Fea^m alone (no time for the
        Drake check, which runs now) and those the map gave no stop (a way closed by
        millimetres, behind a chair perceived a few mm off)."""
        if not (e.finished and e.reason == PLAN_ENDED):
            return e, decisions
        unchecked = e.planned.unchecked if isinstance(e.planned, PlanReady) else ()
        left = tuple(sorted((set(unchecked) | set(e.unreachable)) - set(e.rechecked)))
        if (self._recovery != Recovery.REPLAN or not left
                or e.replans >= self._params.max_replans):
            return e, decisions
        ask = PlanAsk("recheck", t, pose, trigger=f"left out: {', '.join(left)}", left=left)
        candidate = dataclasses.replace(
            e, rechecked=(*e.rechecked, *left),
            unreachable=tuple(d for d in e.unreachable if d not in left))
        remaining, held = self._remaining(candidate)
        if not remaining:
            return candidate, decisions
        # Asked from `e`: its lists change only with a plan (PlanFailed leaves the run as
        # it ended).
        ask = dataclasses.replace(ask, belief=self._localise(pose, e.next_id))
        return self._ask(e, ask, start=ask.belief, dishes=remaining, held=held,
                         budget=self._params.replan_budget, tight=True)

    # --------------------------------------------------------------------------- walk
    def _advance(self, e: ExecutiveState, event: Event) -> Step:
        if isinstance(event, Tick):
            if e.awaiting is not None:
                return e, ()
            return self._send(e, event.t, np.asarray(event.pose, dtype=float))
        if event.id != e.command_id or e.awaiting != (
                "base" if isinstance(event, BaseFinished) else "arm"):
            return e, ()
        if e.mode is Mode.RELEASING:  # let go, whatever came of it: on with the plan
            return _after(dataclasses.replace(e, mode=Mode.SEND, to_tray="",
                                              command_id=NO_COMMAND)), ()
        if e.mode is Mode.STOWING:  # the base command it made way for goes out next
            failures = 0 if event.ok else e.stow_failures + 1
            if failures >= STOW_ATTEMPTS:
                # The base may not move with the arm out, and the arm finds no way in: the
                # run ends here rather than asking again for ever.
                return dataclasses.replace(
                    e, mode=Mode.FINISHED, command_id=NO_COMMAND, stow_failures=failures,
                    reason=f"the arm could not stow ({failures} tries): {event.reason}"), ()
            return dataclasses.replace(e, mode=Mode.SEND, command_id=NO_COMMAND,
                                       arm_out=not event.ok, stow_failures=failures), ()
        action = e.plan.actions[e.step]
        if isinstance(event, BaseFinished):
            if event.contact is not None and self._recovery == Recovery.REPLAN:
                e = dataclasses.replace(e, contacts=(*e.contacts, event.contact))
            if e.mode is Mode.CORRECTING:
                return self._corrected(e, event), ()
            if e.mode is Mode.TURNING and event.ok:
                return dataclasses.replace(e, mode=Mode.PICK, command_id=NO_COMMAND), ()
            if e.mode is Mode.DRIVING:
                return self._arrived(e, action, event)
        return self._picked(e, action, event)

    def _send(self, e: ExecutiveState, t: float, here: np.ndarray) -> Step:
        """The command for the action at `e.step` (a stop check first, when recovering)."""
        cid = e.next_id
        if e.mode is Mode.RELEASE:
            return dataclasses.replace(e, mode=Mode.RELEASING, command_id=cid,
                                       next_id=cid + 1, pick_started=t), (Release(cid, e.to_tray),)
        action = e.plan.actions[e.step]
        if isinstance(action, Goto):
            if e.arm_out:
                return self._stow(e)
            prepare, face = self._prepare_for(e), self._faced(e)
            if prepare:
                return (_sent_base(e, Mode.DRIVING, next_id=cid + 2, arm_out=True),
                        (Drive(cid, here[:2], action.pose, action.path, prepare=prepare,
                               prepare_id=cid + 1, face=face),))
            return _sent_base(e, Mode.DRIVING), (
                Drive(cid, here[:2], action.pose, action.path, face=face),)
        target = self._target(action)
        if e.deferred is not None:  # the correction decided before the arm stowed
            pose, pending, stop = e.deferred
            e = _sent_base(e, Mode.CORRECTING, corrections=e.corrections + 1,
                           pending=pending, stop=stop, deferred=None)
            return e, (Drive(e.command_id, here[:2], pose),)
        if e.mode is Mode.SEND and self._recovery != Recovery.NONE:
            corrected = self._check_stop(e, target, t, here)
            if corrected is not None:
                if e.arm_out:
                    c, (drive,) = corrected
                    return self._stow(dataclasses.replace(
                        e, deferred=(drive.pose, c.pending, c.stop)))
                return corrected
        x, y, yaw = here
        if e.mode is Mode.SEND:
            facing = facing_yaw((x, y), self._params.targets[target])
            if abs(wrap(facing - yaw)) > TURN_TOLERANCE:
                return _sent_base(e, Mode.TURNING), (
                    Turn(cid, (float(x), float(y), float(facing))),)
        placing = isinstance(action, Place)
        pick = Pick(cid, action.dish, place=placing,
                    place_from=None if placing else _place_stop(e, action.dish, here),
                    stow=not (self._smooth and _arm_action_follows(e)))
        return dataclasses.replace(e, mode=Mode.PICKING, command_id=cid, next_id=cid + 1,
                                   pick_pose=(float(x), float(y), float(yaw)),
                                   pick_started=t), (pick,)

    def _stow(self, e: ExecutiveState) -> Step:
        """The arm's stow out, before the base command of the action at `e.step`."""
        cid = e.next_id
        return dataclasses.replace(e, mode=Mode.STOWING, command_id=cid,
                                   next_id=cid + 1), (Stow(cid),)

    def _prepare_for(self, e: ExecutiveState) -> str:
        """With smooth motion, the dish to bring the arm towards during the goto at
        `e.step`: that of the pickup after it, when it is one onto the tray ("" else)."""
        actions = e.plan.actions
        if not self._smooth or e.step + 1 >= len(actions):
            return ""
        after = actions[e.step + 1]
        if isinstance(after, Pickup) and after.dish not in self._to_place:
            return after.dish
        return ""

    def _faced(self, e: ExecutiveState) -> tuple[float, float] | None:
        """With smooth motion, where the goto at `e.step` lands facing: what the arm
        reaches for next, when a pickup or place follows at the stop (None else)."""
        actions = e.plan.actions
        if not self._smooth or e.step + 1 >= len(actions):
            return None
        after = actions[e.step + 1]
        if isinstance(after, Goto):
            return None
        x, y = self._params.targets[self._target(after)][:2]
        return float(x), float(y)

    def _target(self, action: Pickup | Place) -> str:
        """What the arm reaches for: the dish, or the place target of the object to put."""
        return self._params.place_targets[action.dish] if isinstance(action, Place) \
            else action.dish

    def _check_stop(self, e: ExecutiveState, dish: str, t: float, here: np.ndarray
                    ) -> Step | None:
        """A corrective move when the stop check asks for one and allows it (`dish`: what
        the arm reaches for, a dish or a place target)."""
        p = self._params
        if e.corrections >= p.max_corrections:
            return None
        belief = self._localise(here, e.next_id)
        if not e.force_move:
            verdict = e.check.assess(belief, dish)
            if verdict.acceptable(p.min_feasibility):
                return None
            trigger = ("not feasible" if not verdict.feasible else
                       f"Fea^m {verdict.feasibility:.2f} < {p.min_feasibility:g}")
            trigger = f"stop check at ({belief[0]:.2f}, {belief[1]:.2f}): {trigger}"
        else:
            trigger = f"pickup failed: {e.last_failure}"
        best = e.check.correction(belief, dish, p.correction_radius,
                                  threshold=p.min_feasibility, detour=p.detour)
        if best is None or (not e.force_move
                            and np.linalg.norm(best[0] - belief[:2]) < MIN_CORRECTION):
            return None
        target, feasibility = best
        # The base drives by what it believes: a target in the map is reached as far off
        # as the robot's belief of where it stood.
        aim = target + (here[:2] - belief[:2])
        pose = (float(aim[0]), float(aim[1]), float(facing_yaw(aim, p.targets[dish])))
        stop = ((float(target[0]), float(target[1]), pose[2]), feasibility)
        e = _sent_base(e, Mode.CORRECTING, corrections=e.corrections + 1,
                       pending=(trigger, describe_move(belief, target), t), stop=stop)
        return e, (Drive(e.command_id, here[:2], pose),)

    def _corrected(self, e: ExecutiveState, event: BaseFinished) -> ExecutiveState:
        """A corrective move ended: recorded; the stop is checked again from the landing."""
        trigger, action, started = e.pending
        record = RecoveryRecord("correction", e.plan.actions[e.step].dish, trigger, action,
                                "done" if event.ok else f"failed: {event.reason}", started,
                                event.t)
        return dataclasses.replace(e, mode=Mode.SEND, command_id=NO_COMMAND, force_move=False,
                                   recoveries=(*e.recoveries, record))

    def _arrived(self, e: ExecutiveState, action: Goto, event: BaseFinished) -> Step:
        """A goto's drive ended: on with the plan, or (blocked) a replan or the end."""
        outcome = ActionOutcome("goto", action.location, done=event.ok,
                                reason="" if event.ok else event.reason, ended=event.t)
        e = dataclasses.replace(e, outcomes=(*e.outcomes, outcome))
        if event.ok:
            return _after(_next_step(e)), ()
        trigger = f"goto {action.location} failed: {event.reason}"
        if self._recovery == Recovery.REPLAN and e.replans < self._params.max_replans:
            return self._replan(e, PlanAsk("replan", event.t, event.pose, trigger=trigger))
        return dataclasses.replace(e, mode=Mode.FINISHED, reason=trigger), ()

    def _picked(self, e: ExecutiveState, action: Pickup | Place,
                event: BaseFinished | ArmFinished) -> Step:
        """A pickup or place attempt (or the turn before it) ended: recorded, then retried,
        replanned or left, as the recovery says."""
        p = self._params
        turning = e.mode is Mode.TURNING
        done = event.ok and not turning
        reason = f"turn {event.reason}" if turning else "" if done else event.reason
        if not turning and (done or reason == "missed"):
            e = dataclasses.replace(e, arm_out=False)  # the arm's motion played to its end
        name = "place" if isinstance(action, Place) else "pickup"
        e = dataclasses.replace(
            e, outcomes=(*e.outcomes, ActionOutcome(name, action.dish, done=done, reason=reason,
                                               ended=event.t)),
            pickups=(*e.pickups, self._record(e, action, event)))
        if e.tries > 0:  # this attempt was a retry
            record = RecoveryRecord("retry", action.dish, e.last_failure,
                                    f"try {e.tries + 1} of {p.max_tries}",
                                    "done" if done else f"failed: {reason}",
                                    e.pick_started if not turning else event.t, event.t)
            e = dataclasses.replace(e, recoveries=(*e.recoveries, record))
        if done or self._recovery == Recovery.NONE or reason in NOT_RETRIED:
            if not done and isinstance(action, Place):
                return _next_step(e, to_tray=action.dish), ()
            return _after(_next_step(e)), ()
        if e.tries + 1 < p.max_tries:
            # Tried again after a check of the stop; where the arm found no way from where
            # the base stood, the base moves first.
            return dataclasses.replace(
                e, mode=Mode.SEND, tries=e.tries + 1, command_id=NO_COMMAND, corrections=0,
                force_move=reason != "missed", last_failure=reason), ()
        trigger = f"{action.dish} failed {e.tries + 1} tries (last: {reason})"
        e = dataclasses.replace(e, exhausted=(*e.exhausted, action.dish))
        if (self._recovery == Recovery.REPLAN and e.replans < p.max_replans
                and e.exhausted.count(action.dish) < PLANS_PER_DISH):
            return self._replan(e, PlanAsk("replan", event.t, event.pose, trigger=trigger,
                                           dish=action.dish))
        return self._give_up(e, action, trigger, event.t), ()

    def _give_up(self, e: ExecutiveState, action: Pickup | Place, trigger: str,
                 t: float) -> ExecutiveState:
        """On to the next action, the dish of `action` left on the table, or, held to be
        placed, let go over the tray first; the give-up recorded at time `t` (s)."""
        placing = isinstance(action, Place)
        left = "put on the tray" if placing else "left on the table"
        record = RecoveryRecord("give_up", action.dish, trigger, left, "done", t, t)
        e = _next_step(e, given_up=(*e.given_up, action.dish),
                       recoveries=(*e.recoveries, record),
                       to_tray=action.dish if placing else "")
        return e if e.to_tray else _after(e)

    def _record(self, e: ExecutiveState, action: Pickup | Place,
                event: BaseFinished | ArmFinished) -> PickupRecord:
        """The record of the pickup or place `action` at `e.step` (of what the arm reaches
        for), which `event` has just ended."""
        if e.mode is Mode.TURNING:  # the turn to face the dish failed: no pick, the base
            actual = tuple(float(v) for v in event.pose)  # stopped here
            outcome, sighting = f"turn {event.reason}", 0
        else:
            actual = e.pick_pose
            outcome = "done" if event.ok else event.reason
            sighting = event.id if event.sighted else 0
        if e.stop is not None:  # a correction moved the base: its stop and Fea^m
            stop, predicted = e.stop
        else:
            # The stop the prediction was made for: the latest goto's pose, else where the
            # plan started.
            stop = next((a.pose for a in reversed(e.plan.actions[:e.step])
                         if isinstance(a, Goto)), e.planned.start)
            predicted = float(action.feasibility)
        return PickupRecord(dish=self._target(action), kind=self._kinds[action.dish],
                            method=self._params.method, predicted=float(predicted),
                            source=e.planned.source,
                            planned_pose=tuple(float(v) for v in stop), actual_pose=actual,
                            outcome=outcome, sighting=sighting, attempt=e.tries + 1,
                            planned=float(action.feasibility))


# ------------------------------------------------------------------------------ helpers
def _next_step(e: ExecutiveState, **changes: Any) -> ExecutiveState:
    """On to the next action, every per-pickup field reset."""
    e = dataclasses.replace(e, step=e.step + 1, command_id=NO_COMMAND, corrections=0, tries=0,
                            force_move=False, last_failure="", stop=None, **changes)
    return dataclasses.replace(e, mode=Mode.RELEASE if e.to_tray else Mode.SEND)


def _after(e: ExecutiveState) -> ExecutiveState:
    """The execution after an action: finished at the end of the plan."""
    if e.step >= len(e.plan.actions):
        return dataclasses.replace(e, mode=Mode.FINISHED, reason=PLAN_ENDED)
    return e


def _sent_base(e: ExecutiveState, mode: Mode, **changes: Any) -> ExecutiveState:
    """`e` with the next base command out."""
    changes.setdefault("next_id", e.next_id + 1)
    return dataclasses.replace(e, mode=mode, command_id=e.next_id, **changes)


def _arm_action_follows(e: ExecutiveState) -> bool:
    """Whether the action after the one at `e.step` is another pickup or place at this
    stop (no goto between)."""
    actions = e.plan.actions
    return e.step + 1 < len(actions) and not isinstance(actions[e.step + 1], Goto)


def _place_stop(e: ExecutiveState, dish: str, here: np.ndarray) -> Pose | None:
    """The base pose the plan puts `dish` down from, when a place of it follows the action
    at `e.step`: the pose of the last goto before that place (`here`, where the base
    stands, when the place is at this stop); None when none follows."""
    actions = e.plan.actions
    put = next((k for k in range(e.step + 1, len(actions))
                if isinstance(actions[k], Place) and actions[k].dish == dish), None)
    if put is None:
        return None
    goto = next((actions[k] for k in range(put - 1, e.step, -1)
                 if isinstance(actions[k], Goto)), None)
    pose = here if goto is None else goto.pose
    return tuple(float(v) for v in pose)
