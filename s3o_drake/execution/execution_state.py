"""The S3O planner's abstract state: the plan, and where its execution stands.

`ExecutionState` is what `S3OPlanner` (s3o_planner.py) keeps in its Context: the latest
planning's result, the step being executed, the commands out, and everything the run
reports (outcomes, pickup and recovery records, the plans' times). Immutable: every update
makes a new one, so Drake's copies of the state may share it.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

from s3o_drake.execution.messages import (
    NO_COMMAND,
    ActionOutcome,
    BaseCommand,
    CommandState,
    PickCommand,
    PickupRecord,
    PlanTime,
    RecoveryRecord,
    Status,
)
from s3o_drake.execution.recovery import StopCheck
from s3o_drake.planning.pipeline import PlanningResult
from s3o_drake.planning.plan import Goto, Pickup, Place, TaskMotionPlan


@dataclass(frozen=True)
class ExecutionState:
    """The planner's abstract state: the plan and where execution stands.

    Immutable (every update makes a new one), so Drake's copies of the state may share it.
    """

    result: PlanningResult | None = None
    """The latest planning's result: the plan, and what it was made on (the KnownWorld,
    the heatmaps, the navigation map that re-paths the drives from where the base is)."""
    check: StopCheck | None = None  # the recovery's stop check on that result
    step: int = 0  # index into plan.actions of the action being executed
    command_id: int = NO_COMMAND  # id of the command sent for `step` (0: none yet)
    turning: bool = False  # the command out is the turn in place before a pickup
    turned: bool = False  # the base faces the dish of the pickup at `step`
    next_id: int = 1
    base_command: BaseCommand = field(default_factory=BaseCommand)
    pick_command: PickCommand = field(default_factory=PickCommand)
    outcomes: tuple[ActionOutcome, ...] = ()
    pickups: tuple[PickupRecord, ...] = ()
    pick_pose: tuple[float, float, float] = (0.0, 0.0, 0.0)  # the base's, at the PickCommand
    pick_started: float = 0.0  # simulated time the current PickCommand was sent
    finished: bool = False
    reason: str = ""
    replan_seen: float = 0.0
    plans: tuple[PlanTime, ...] = ()  # each plan's time against its budget
    # The recovery (execution.recovery other than none), for the pickup at `step`:
    checked: bool = False  # the stop check has accepted (or could not better) the stop
    correcting: bool = False  # the command out is a corrective move
    corrections: int = 0  # corrective moves before this attempt
    tries: int = 0  # failed attempts at this pickup, this plan
    force_move: bool = False  # the last attempt failed where it stood: move before the next
    last_failure: str = ""  # why the last attempt failed (a retry's trigger)
    pending: tuple[str, str, float] = ("", "", 0.0)  # a correction's trigger, action, start
    stop: tuple[tuple[float, float, float], float] | None = None
    """The corrected stop and its Fea^m, when a correction moved the base for this pickup."""
    recoveries: tuple[RecoveryRecord, ...] = ()
    unreachable: tuple[str, ...] = ()
    replans: int = 0
    exhausted: tuple[str, ...] = ()  # a dish per plan in which it failed all its tries
    given_up: tuple[str, ...] = ()
    rechecked: tuple[str, ...] = ()  # dishes planned for again at a plan's end, left out
    contacts: tuple[tuple[float, float], ...] = ()
    """Where blocked drives touched what blocked them (KnownWorld.contacts of replans)."""
    to_tray: str = ""
    """An object to place whose place failed for good, in the gripper: put on the tray
    before the next action, so that the gripper is free for the pickups that follow."""

    @property
    def plan(self) -> TaskMotionPlan | None:
        return None if self.result is None else self.result.plan

    @property
    def planning_time(self) -> float:
        """Wall time (s) spent planning, summed over the plans (the terminal's figure)."""
        return sum(p.planning_time for p in self.plans)

    @property
    def picked(self) -> set[str]:
        """The objects picked so far (collected, or held to place)."""
        return {o.argument for o in self.outcomes if o.action == "pickup" and o.done}

    @property
    def put(self) -> set[str]:
        """The objects put down at their places so far."""
        return {o.argument for o in self.outcomes if o.action == "place" and o.done}

    def place_stop(self, dish: str, here) -> tuple[float, float, float] | None:
        """The base pose the plan puts `dish` down from, when a place of it follows the
        action at `step`: the pose of the last goto before that place (`here`, where the
        base stands, when the place is at this stop); None when none follows."""
        actions = self.plan.actions
        put = next((k for k in range(self.step + 1, len(actions))
                    if isinstance(actions[k], Place) and actions[k].dish == dish), None)
        if put is None:
            return None
        goto = next((actions[k] for k in range(put - 1, self.step, -1)
                     if isinstance(actions[k], Goto)), None)
        pose = here if goto is None else goto.pose
        return tuple(float(v) for v in pose)

    def pickup_record(self, action: Pickup | Place, status: Status, *, target: str, kind: str,
                      method: str, here) -> PickupRecord:
        """The record of the pickup or place `action` at `step` (of `target`, a dish or a
        place target, of `kind`), which `status` has just finished; `here`: the base's
        pose now."""
        if self.turning:  # the turn to face the dish failed: no pick, the base stopped here
            actual = tuple(float(v) for v in here)
            outcome, noise = f"turn {status.reason}", None
        else:
            actual = self.pick_pose
            outcome = "done" if status.state == CommandState.DONE else status.reason
            noise = status.reach_noise
        if self.stop is not None:  # a correction moved the base: its stop and Fea^m
            stop, predicted = self.stop
        else:
            # The stop the prediction was made for: the latest goto's pose, else where the
            # plan started.
            stop = next((a.pose for a in reversed(self.plan.actions[:self.step])
                         if isinstance(a, Goto)), self.result.known.pose)
            predicted = float(action.feasibility)
        return PickupRecord(dish=target, kind=kind, method=method, predicted=float(predicted),
                            source=self.result.known.planner.feasibility,
                            planned_pose=tuple(float(v) for v in stop), actual_pose=actual,
                            outcome=outcome, reach_noise=noise, attempt=self.tries + 1,
                            planned=float(action.feasibility))

    def give_up(self, dish: str, trigger: str, t: float, *, placing: bool) -> ExecutionState:
        """On to the next action, `dish` left on the table, or, held to be placed, to be
        put on the tray first; the give-up recorded at time `t` (s)."""
        left = "put on the tray" if placing else "left on the table"
        record = RecoveryRecord("give_up", dish, trigger, left, "done", t, t)
        return self.next_step(given_up=(*self.given_up, dish),
                              recoveries=(*self.recoveries, record),
                              to_tray=dish if placing else "")

    def next_step(self, **changes) -> ExecutionState:
        """On to the next action, every per-pickup field reset."""
        return dataclasses.replace(
            self, step=self.step + 1, command_id=NO_COMMAND, turning=False, turned=False,
            checked=False, correcting=False, corrections=0, tries=0, force_move=False,
            last_failure="", stop=None, **changes)

    def __deepcopy__(self, memo) -> ExecutionState:
        # Immutable: frozen, and the navigation map is sealed after planning (its queries
        # memoise nothing more), so Drake's copies may share it; a copy would only cost
        # (the map is megabytes). The stop check only caches its oracle.
        return self
