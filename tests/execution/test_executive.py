"""The Executive alone, without Drake: every transition of the walk and of the recovery
policy, driven by hand with fake plans, a fake stop check and an exact localisation."""

import dataclasses
import math
import subprocess
import sys

import numpy as np
import pytest

from s3o_drake.execution.executive import (
    MIN_CORRECTION,
    STOW_ATTEMPTS,
    ArmFinished,
    Assessment,
    BaseFinished,
    Drive,
    Executive,
    ExecutiveParams,
    ExecutiveState,
    Finish,
    Mode,
    Pick,
    Plan,
    PlanFailed,
    PlanReady,
    Release,
    ReplanRequested,
    Start,
    Stow,
    TaskObject,
    Tick,
    Turn,
)
from s3o_drake.execution.messages import PLAN_ENDED, PlanTime
from s3o_drake.planning.plan import Goto, Pickup, Place, TaskMotionPlan
from s3o_drake.world.choices import Recovery


def test_the_executive_imports_no_drake():
    code = ("import sys, s3o_drake.execution.executive; "
            "print([m for m in sys.modules if m.startswith('pydrake')])")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "[]"


# A stop L1 at (1, 1) facing the plate at (2, 1); the cup at (2, 2) is 45 degrees off it.
# The apple (goal place) stands at (3, 0) and goes to its place target at (4, 0), from L2.
L1 = (1.0, 1.0, 0.0)
L2 = (3.0, -1.0, math.pi / 2)
OBJECTS = (TaskObject("plate", "plate"), TaskObject("cup", "cup"),
           TaskObject("apple", "apple", "place"), TaskObject("vase", "vase", "stay"))
TARGETS = {"plate": (2.0, 1.0), "cup": (2.0, 2.0), "apple": (3.0, 0.0),
           "apple_place": (4.0, 0.0), "vase": (0.0, 3.0)}


def _params(recovery=Recovery.REPLAN, **changes) -> ExecutiveParams:
    return dataclasses.replace(
        ExecutiveParams(objects=OBJECTS, targets=TARGETS, place_targets={"apple": "apple_place"},
                        method="M", recovery=recovery, time_budget=30.0, replan_budget=10.0,
                        max_tries=3, max_corrections=2, max_replans=4),
        **changes)


def _goto(name, pose):
    return Goto(name, pose, ((0.0, 0.0), (0.5, 0.5), pose[:2]), length=2.0)


def _plan(*actions, unreachable=()) -> TaskMotionPlan:
    return TaskMotionPlan(method="M", seed=0, groups=(), locations=(), actions=tuple(actions),
                          utility=0.0, predicted_time=0.0, planning_time=1.0,
                          unreachable=tuple(unreachable))


PLATE = _plan(_goto("l1", L1), Pickup("plate", "l1", 0.9))
PLATE_CUP = _plan(_goto("l1", L1), Pickup("plate", "l1", 0.9), Pickup("cup", "l1", 0.7))
APPLE = _plan(_goto("l2", (3.0, -1.0, math.pi / 2)), Pickup("apple", "l2", 0.8),
              _goto("l3", (4.0, -1.0, math.pi / 2)), Place("apple", "l3", 0.6),
              _goto("l1", L1), Pickup("plate", "l1", 0.9))


class FakeCheck:
    """A stop check that answers from lists, in turn: `verdicts` (default: acceptable) and
    `corrections` (default: none); `asked` logs the questions."""

    def __init__(self, verdicts=(), corrections=()):
        self.verdicts, self.corrections, self.asked = list(verdicts), list(corrections), []

    def assess(self, position, dish):
        self.asked.append(("assess", dish))
        return self.verdicts.pop(0) if self.verdicts else Assessment(True, 1.0)

    def correction(self, position, dish, radius, *, threshold=0.0, detour=False):
        self.asked.append(("correction", dish, radius, threshold, detour))
        return self.corrections.pop(0) if self.corrections else None


class NoCheck:
    """A stop check that must not be asked (open loop)."""

    def assess(self, *args, **kwargs):
        raise AssertionError("no stop check in open loop")

    correction = assess


def _ready(plan, *, check=None, unchecked=(), budget=30.0) -> PlanReady:
    return PlanReady(plan, PlanTime(2.0, 0.5, budget), start=(0.0, 0.0, 0.0), source="oracle",
                     unchecked=tuple(unchecked), check=check, result=("result", plan))


def _failed(error="no plan: none valid", budget=10.0) -> PlanFailed:
    return PlanFailed(error, PlanTime(3.0, None, budget), result=("failed", error))


class Run:
    """An Executive driven by hand: each call sends one event at a new time, from the
    base's true `pose`, and returns the decisions."""

    def __init__(self, recovery=Recovery.REPLAN, *, offset=(0.0, 0.0, 0.0), **changes):
        self.believed = []

        def localise(pose, command_id):
            self.believed.append(command_id)
            return np.asarray(pose, dtype=float) + offset

        self.executive = Executive(_params(recovery, **changes), localise=localise)
        self.state = ExecutiveState()
        self.t = 0.0
        self.pose = np.zeros(3)

    def send(self, event):
        self.state, decisions = self.executive.step(self.state, event)
        return decisions

    def at(self, pose):
        self.pose = np.asarray(pose, dtype=float)

    def start(self, answer):
        (plan,) = self.send(Start(self.t, self.pose.copy()))
        assert isinstance(plan, Plan) and self.state.mode is Mode.PLANNING
        return plan, self.send(answer)

    def tick(self):
        self.t += 1.0
        return self.send(Tick(self.t, self.pose.copy()))

    def base(self, ok=True, reason="", contact=None, land=None):
        self.t += 1.0
        if land is not None:
            self.at(land)
        return self.send(BaseFinished(self.t, self.pose.copy(), self.state.command_id, ok,
                                      reason, contact))

    def arm(self, ok=True, reason="", sighted=False):
        self.t += 1.0
        return self.send(ArmFinished(self.t, self.pose.copy(), self.state.command_id, ok,
                                     reason, sighted))

    def to_stop(self, pose=L1):
        """Sends the goto out and lands it at `pose`; returns the drive."""
        (drive,) = self.tick()
        assert isinstance(drive, Drive) and self.state.mode is Mode.DRIVING
        assert self.base(land=pose) == ()
        return drive

    def pick(self):
        (pick,) = self.tick()
        assert isinstance(pick, Pick), pick
        return pick

    @property
    def progress(self):
        return self.state.progress()


# --------------------------------------------------------------------------- planning
def test_the_first_plan_is_asked_for_every_object_from_the_true_pose():
    run = Run()
    run.at((0.5, 0.2, 0.1))
    plan, decisions = run.start(_ready(PLATE, check=FakeCheck()))
    assert plan.dishes == ("plate", "cup", "apple", "vase") and plan.held == ""
    assert plan.start == pytest.approx([0.5, 0.2, 0.1]) and plan.budget == 30.0
    assert not plan.tight and plan.contacts == () and decisions == ()
    assert run.state.mode is Mode.SEND and run.state.step == 0
    assert run.state.plan is PLATE and run.state.result == ("result", PLATE)
    assert run.progress.total == 2 and run.progress.plans == (PlanTime(2.0, 0.5, 30.0),)


def test_no_plan_finishes_the_run_with_the_planner_s_reason():
    run = Run()
    _, decisions = run.start(_failed("no plan: nothing valid", budget=30.0))
    assert decisions == (Finish("no plan: nothing valid"),)
    assert run.state.finished and run.state.plan is None
    assert run.state.result == ("failed", "no plan: nothing valid")
    progress = run.progress
    assert progress.finished and progress.reason == "no plan: nothing valid"
    assert progress.total == 0 and len(progress.plans) == 1
    assert run.tick() == () and run.state.finished  # nothing more happens


def test_a_plan_without_actions_has_ended():
    run = Run()
    _, decisions = run.start(_ready(_plan(), check=FakeCheck()))
    assert decisions == (Finish(PLAN_ENDED),) and run.progress.reason == PLAN_ENDED


def test_a_plan_needs_its_stop_check_when_recovering():
    run = Run(Recovery.RETRY)
    run.send(Start(0.0, np.zeros(3)))
    with pytest.raises(ValueError, match="stop check"):
        run.send(_ready(PLATE))


def test_an_answer_nobody_asked_for_is_refused():
    with pytest.raises(ValueError, match="no plan asked"):
        Run().send(_ready(PLATE, check=FakeCheck()))


# ------------------------------------------------------------------------------ walk
def test_the_open_loop_walks_the_plan_one_command_at_a_time():
    run = Run(Recovery.NONE)
    run.start(_ready(PLATE, check=NoCheck()))
    (drive,) = run.tick()
    assert drive == Drive(1, drive.start, L1, PLATE.actions[0].path)
    assert drive.start == pytest.approx([0.0, 0.0])
    assert run.tick() == ()  # the drive is out: a tick changes nothing
    assert run.base(ok=True, land=L1) == ()
    assert tuple(run.progress.outcomes[-1]) == ("goto", "l1", "done")
    pick = run.pick()
    assert pick == Pick(2, "plate", place=False, place_from=None)
    assert run.state.pick_pose == L1
    decisions = run.arm(ok=True, sighted=True)
    assert decisions == (Finish(PLAN_ENDED),)
    progress = run.progress
    assert progress.finished and progress.step == progress.total == 2
    # Each action's end, in simulated time: the drive's report at 3 s, the arm's last.
    assert [o.ended for o in progress.outcomes] == [3.0, run.t]
    (record,) = progress.pickups
    assert (record.dish, record.kind, record.method, record.source) == (
        "plate", "plate", "M", "oracle")
    assert record.planned_pose == L1 and record.actual_pose == L1
    # The arm aimed with a sighting: its command is the record's, for the referee to join
    # the sensing error to.
    assert record.outcome == "done" and record.sighting == pick.id > 0
    assert record.predicted == record.planned == 0.9 and record.attempt == 1
    assert run.believed == []  # no localisation in open loop


def test_a_report_of_another_command_is_ignored():
    run = Run(Recovery.NONE)
    run.start(_ready(PLATE, check=NoCheck()))
    run.tick()
    stale = BaseFinished(5.0, np.zeros(3), 99, False, "blocked")
    assert run.send(stale) == () and run.state.mode is Mode.DRIVING
    arm = ArmFinished(5.0, np.zeros(3), run.state.command_id, True)
    assert run.send(arm) == () and run.state.mode is Mode.DRIVING


def test_a_step_is_pure():
    run = Run(Recovery.NONE)
    run.start(_ready(PLATE, check=NoCheck()))
    state = run.state
    event = Tick(1.0, np.zeros(3))
    first = run.executive.step(state, event)
    second = run.executive.step(state, event)
    assert first[0].mode is second[0].mode is Mode.DRIVING
    assert first[0].command_id == second[0].command_id == 1
    assert run.state is state and state.mode is Mode.SEND  # the old state is untouched
    with pytest.raises(dataclasses.FrozenInstanceError):
        state.step = 3


def test_the_base_turns_to_face_a_further_dish_before_picking_it():
    run = Run(Recovery.NONE)
    run.start(_ready(PLATE_CUP, check=NoCheck()))
    run.to_stop()
    run.pick()
    run.arm()
    (turn,) = run.tick()
    assert isinstance(turn, Turn) and run.state.mode is Mode.TURNING
    assert turn.pose == pytest.approx((1.0, 1.0, math.pi / 4))
    assert run.base(ok=True, land=turn.pose) == () and run.state.mode is Mode.PICK
    pick = run.pick()
    assert pick.dish == "cup" and pick.id == turn.id + 1
    assert run.arm() == (Finish(PLAN_ENDED),)


def test_a_turn_that_fails_is_a_failed_attempt_recorded_where_the_base_stopped():
    run = Run(Recovery.NONE)
    run.start(_ready(PLATE_CUP, check=NoCheck()))
    run.to_stop()
    run.pick()
    run.arm()
    run.tick()
    stopped = (1.0, 1.0, 0.2)
    decisions = run.base(ok=False, reason="blocked", land=stopped)
    assert decisions == (Finish(PLAN_ENDED),)  # open loop: on with the plan (it ended)
    progress = run.progress
    assert tuple(progress.outcomes[-1]) == ("pickup", "cup", "failed: turn blocked")
    record = progress.pickups[-1]
    assert record.outcome == "turn blocked" and record.reach_noise is None
    assert record.actual_pose == stopped and record.planned_pose == L1


def test_a_failed_goto_ends_the_open_loop():
    run = Run(Recovery.NONE)
    run.start(_ready(PLATE, check=NoCheck()))
    run.tick()
    decisions = run.base(ok=False, reason="blocked", contact=(0.5, 0.5))
    assert decisions == (Finish("goto l1 failed: blocked"),)
    assert run.state.contacts == ()  # what blocked it is of use to replans only
    assert [tuple(o) for o in run.progress.outcomes] == [("goto", "l1", "failed: blocked")]


def test_a_failed_pickup_is_not_retried_in_open_loop():
    run = Run(Recovery.NONE)
    run.start(_ready(PLATE_CUP, check=NoCheck()))
    run.to_stop()
    run.pick()
    assert run.arm(ok=False, reason="no_ik") == ()
    assert run.state.mode is Mode.SEND and run.state.step == 2 and run.state.tries == 0
    assert run.progress.recoveries == ()


# ------------------------------------------------------------------ the stop check
def test_a_good_stop_is_accepted():
    check = FakeCheck([Assessment(True, 0.8)])
    run = Run(Recovery.RETRY)
    run.start(_ready(PLATE, check=check))
    run.to_stop()
    pick = run.pick()
    assert pick.dish == "plate" and check.asked == [("assess", "plate")]
    assert run.believed == [pick.id]  # localised for the command that follows


@pytest.mark.parametrize("verdict, trigger", [
    (Assessment(False, 0.9), "not feasible"), (Assessment(True, 0.3), "Fea^m 0.30 < 0.5")])
def test_a_poor_stop_is_corrected_then_checked_again(verdict, trigger):
    # The robot believes it stands 5 cm east of where it does: the move aims 5 cm west.
    check = FakeCheck([verdict], corrections=[(np.array([1.2, 1.0]), 0.85)])
    run = Run(Recovery.RETRY, offset=(0.05, 0.0, 0.0))
    run.start(_ready(PLATE, check=check))
    run.to_stop()
    (move,) = run.tick()
    assert isinstance(move, Drive) and move.planned is None and run.state.mode is Mode.CORRECTING
    assert move.pose == pytest.approx((1.15, 1.0, 0.0))
    assert check.asked[1] == ("correction", "plate", 0.3, 0.5, True)
    assert run.base(land=move.pose) == () and run.state.mode is Mode.SEND
    (correction,) = run.progress.recoveries
    assert correction.kind == "correction" and correction.dish == "plate"
    assert correction.trigger == f"stop check at (1.05, 1.00): {trigger}"
    assert correction.action == "moved 0.15 m to (1.20, 1.00)" and correction.result == "done"
    pick = run.pick()  # checked again (acceptable now), faced already
    assert check.asked[-1] == ("assess", "plate") and pick.id == move.id + 1
    run.arm()
    (record,) = run.progress.pickups
    # Its prediction is the corrected stop's.
    assert record.planned_pose == pytest.approx((1.2, 1.0, 0.0)) and record.predicted == 0.85
    assert record.planned == 0.9


def test_a_failed_corrective_move_is_recorded_and_the_stop_checked_again():
    check = FakeCheck([Assessment(False, 0.0)], corrections=[(np.array([1.2, 1.0]), 0.85)])
    run = Run(Recovery.REPLAN)
    run.start(_ready(PLATE, check=check))
    run.to_stop()
    run.tick()
    assert run.base(ok=False, reason="blocked", contact=(1.3, 1.0)) == ()
    assert run.state.mode is Mode.SEND and run.state.replans == 0  # no replan for it
    assert run.progress.recoveries[0].result == "failed: blocked"
    assert run.state.contacts == ((1.3, 1.0),)


def test_corrections_stop_after_max_corrections():
    poor = Assessment(False, 0.0)
    check = FakeCheck([poor, poor], corrections=[(np.array([1.2, 1.0]), 0.6),
                                                 (np.array([1.0, 1.2]), 0.6)])
    run = Run(Recovery.RETRY, max_corrections=2)
    run.start(_ready(PLATE, check=check))
    run.to_stop()
    for _ in range(2):
        (move,) = run.tick()
        assert isinstance(move, Drive)
        run.base(land=move.pose)
    pick = run.pick()  # two corrections: the stop is taken as it is, unasked
    assert pick.dish == "plate" and [a[0] for a in check.asked].count("assess") == 2
    assert run.state.corrections == 2


def test_a_tiny_or_no_correction_leaves_the_stop():
    for best in (None, (np.array([1.0 + MIN_CORRECTION / 2, 1.0]), 0.9)):
        check = FakeCheck([Assessment(True, 0.2)], corrections=[best])
        run = Run(Recovery.RETRY)
        run.start(_ready(PLATE, check=check))
        run.to_stop()
        assert run.pick().dish == "plate" and run.progress.recoveries == ()


def test_a_place_is_checked_and_faced_against_its_place_target():
    check = FakeCheck()
    run = Run(Recovery.RETRY)
    run.start(_ready(APPLE, check=check))
    run.to_stop((3.0, -1.0, math.pi / 2))
    pick = run.pick()
    # The apple's pickup is told where the plan puts it down from.
    assert pick == Pick(2, "apple", place=False, place_from=(4.0, -1.0, math.pi / 2))
    run.arm()
    run.to_stop((4.0, -1.0, math.pi / 2))
    place = run.pick()
    assert place == Pick(4, "apple", place=True, place_from=None)
    assert check.asked[-1] == ("assess", "apple_place")
    run.arm()
    assert run.progress.pickups[-1].dish == "apple_place"


# ----------------------------------------------------------------------- retries
def test_a_miss_is_tried_again_where_the_base_stands():
    check = FakeCheck()
    run = Run(Recovery.RETRY)
    run.start(_ready(PLATE, check=check))
    run.to_stop()
    first = run.pick()
    assert run.arm(ok=False, reason="missed") == ()
    assert run.state.mode is Mode.SEND and run.state.tries == 1 and not run.state.force_move
    second = run.pick()  # checked again: acceptable, no move
    assert second.id == first.id + 1 and check.asked.count(("assess", "plate")) == 2
    run.arm()
    retry = run.progress.recoveries[-1]
    assert (retry.kind, retry.trigger, retry.action, retry.result) == (
        "retry", "missed", "try 2 of 3", "done")
    assert [r.attempt for r in run.progress.pickups] == [1, 2]


def test_where_the_arm_found_no_way_the_base_moves_before_the_next_try():
    check = FakeCheck(corrections=[(np.array([1.0, 0.95]), 0.7)])
    run = Run(Recovery.RETRY)
    run.start(_ready(PLATE, check=check))
    run.to_stop()
    run.pick()
    run.arm(ok=False, reason="no_ik")
    assert run.state.force_move
    (move,) = run.tick()
    assert isinstance(move, Drive)  # a move even though the stop check is not asked
    assert check.asked == [("assess", "plate"), ("correction", "plate", 0.3, 0.5, True)]
    run.base(land=move.pose)
    assert not run.state.force_move
    correction = run.progress.recoveries[-1]
    assert correction.trigger == "pickup failed: no_ik"


@pytest.mark.parametrize("reason", ["unknown_dish", "hand_full", "not_held"])
def test_failures_no_retry_mends_go_on_with_the_next_action(reason):
    run = Run(Recovery.REPLAN)
    run.start(_ready(PLATE_CUP, check=FakeCheck()))
    run.to_stop()
    run.pick()
    assert run.arm(ok=False, reason=reason) == ()
    assert run.state.step == 2 and run.state.tries == 0 and run.progress.recoveries == ()


def _exhaust(run, tries=3):
    """Fails the pickup out `tries` times (the base staying put)."""
    decisions = ()
    for _ in range(tries):
        run.pick()
        decisions = run.arm(ok=False, reason="missed")
    return decisions


def test_with_retry_a_dish_that_fails_all_its_tries_is_left():
    run = Run(Recovery.RETRY)
    run.start(_ready(PLATE_CUP, check=FakeCheck()))
    run.to_stop()
    assert _exhaust(run) == ()
    kinds = [r.kind for r in run.progress.recoveries]
    assert kinds == ["retry", "retry", "give_up"]
    give_up = run.progress.recoveries[-1]
    assert give_up.trigger == "plate failed 3 tries (last: missed)"
    assert give_up.action == "left on the table" and run.state.given_up == ("plate",)
    assert run.state.step == 2 and run.state.mode is Mode.SEND and run.state.tries == 0


def test_with_replan_a_dish_that_fails_all_its_tries_is_planned_again():
    run = Run(Recovery.REPLAN, offset=(0.01, 0.0, 0.0))
    run.start(_ready(PLATE_CUP, check=FakeCheck()))
    run.to_stop()
    (plan,) = _exhaust(run)
    assert isinstance(plan, Plan) and run.state.mode is Mode.PLANNING
    # The objects not done yet (the vase stays; the plate is not given up), from the belief.
    assert plan.dishes == ("plate", "cup", "apple") and plan.budget == 10.0
    assert plan.start == pytest.approx([1.01, 1.0, 0.0]) and not plan.tight
    again = _plan(_goto("l4", (2.0, 0.0, math.pi / 2)), Pickup("plate", "l4", 0.8))
    assert run.send(_ready(again, check=FakeCheck(), budget=10.0)) == ()
    assert run.state.plan is again and run.state.step == 0 and run.state.mode is Mode.SEND
    assert run.state.replans == 1 and run.state.exhausted == ("plate",)
    replan = run.progress.recoveries[-1]
    assert (replan.kind, replan.dish, replan.result) == ("replan", "plate", "done")
    assert replan.action == "planned 3 dishes from (1.01, 1.00): 2 actions"
    assert replan.planning_time == 2.0 and len(run.progress.plans) == 2


def test_a_dish_is_planned_for_in_two_plans_at_most():
    run = Run(Recovery.REPLAN)
    run.start(_ready(PLATE, check=FakeCheck()))
    run.to_stop()
    _exhaust(run)
    run.send(_ready(PLATE, check=FakeCheck()))
    run.to_stop()
    decisions = _exhaust(run)  # the second plan in which it failed: left
    assert decisions == (Finish(PLAN_ENDED),)
    assert run.state.exhausted == ("plate", "plate") and run.state.given_up == ("plate",)
    assert run.state.replans == 1


def test_replans_stop_at_max_replans():
    run = Run(Recovery.REPLAN, max_replans=0)
    run.start(_ready(PLATE_CUP, check=FakeCheck()))
    run.to_stop()
    assert _exhaust(run) == ()
    assert run.progress.recoveries[-1].kind == "give_up" and run.state.replans == 0


def test_a_dish_whose_replan_finds_no_plan_is_left_and_the_old_plan_goes_on():
    run = Run(Recovery.REPLAN)
    run.start(_ready(PLATE_CUP, check=FakeCheck()))
    run.to_stop()
    _exhaust(run)
    assert run.send(_failed("no plan: none valid")) == ()
    state = run.state
    assert state.plan is PLATE_CUP and state.step == 2 and state.mode is Mode.SEND
    assert [r.kind for r in run.progress.recoveries][-2:] == ["replan", "give_up"]
    assert run.progress.recoveries[-2].result == "no plan: none valid"
    assert state.given_up == ("plate",) and state.replans == 1 and len(state.plans) == 2
    assert run.state.result == ("result", PLATE_CUP)


def test_a_replan_with_nothing_left_to_plan_ends_the_run():
    """The plate collected, the drive on to nowhere is blocked: nothing remains to plan."""
    run = Run(Recovery.REPLAN)
    run.executive = Executive(_params(objects=(TaskObject("plate", "plate"),)),
                              localise=lambda pose, cid: pose)
    plan = _plan(_goto("l1", L1), Pickup("plate", "l1", 0.9), _goto("l2", L2))
    run.start(_ready(plan, check=FakeCheck()))
    run.to_stop()
    run.pick()
    run.arm()
    run.tick()
    assert run.base(ok=False, reason="blocked") == (Finish(PLAN_ENDED),)
    assert run.state.replans == 0 and run.progress.recoveries == ()


# --------------------------------------------------------------------- failed gotos
def test_with_replan_a_blocked_drive_is_replanned_knowing_the_contact():
    run = Run(Recovery.REPLAN, offset=(0.0, 0.02, 0.0))
    run.start(_ready(PLATE, check=FakeCheck()))
    run.tick()
    (plan,) = run.base(ok=False, reason="blocked", contact=(0.7, 0.7), land=(0.5, 0.5, 0.8))
    assert plan.contacts == ((0.7, 0.7),) and plan.start == pytest.approx([0.5, 0.52, 0.8])
    assert plan.dishes == ("plate", "cup", "apple")
    again = _plan(_goto("l5", L1), Pickup("plate", "l5", 0.9))
    run.send(_ready(again, check=FakeCheck()))
    replan = run.progress.recoveries[-1]
    assert replan.trigger == "goto l1 failed: blocked" and replan.dish == ""
    (drive,) = run.tick()
    assert drive.start == pytest.approx([0.5, 0.5]) and drive.pose == L1


def test_a_blocked_drive_whose_replan_finds_no_plan_ends_the_run():
    run = Run(Recovery.REPLAN)
    run.start(_ready(PLATE, check=FakeCheck()))
    run.tick()
    run.base(ok=False, reason="blocked")
    decisions = run.send(_failed("no plan: boxed in"))
    assert decisions == (Finish("no plan: boxed in"),)
    assert run.state.plan is None and run.progress.recoveries[-1].result == "no plan: boxed in"


def test_with_retry_a_blocked_drive_ends_the_run():
    run = Run(Recovery.RETRY)
    run.start(_ready(PLATE, check=FakeCheck()))
    run.tick()
    assert run.base(ok=False, reason="blocked") == (Finish("goto l1 failed: blocked"),)
    assert run.progress.recoveries == ()


# ------------------------------------------------------------------ places, the tray
def test_an_object_whose_place_fails_is_let_go_over_the_tray():
    run = Run(Recovery.NONE)
    run.start(_ready(APPLE, check=NoCheck()))
    run.to_stop(L2)
    run.pick()
    run.arm()
    run.to_stop((4.0, -1.0, math.pi / 2))
    run.pick()
    assert run.arm(ok=False, reason="no_ik") == () and run.state.mode is Mode.RELEASE
    (release,) = run.tick()
    assert release == Release(5, "apple") and run.state.mode is Mode.RELEASING
    assert run.arm(ok=False, reason="no_path") == ()  # whatever came of it: on with the plan
    assert run.state.mode is Mode.SEND and run.state.to_tray == "" and run.state.step == 4
    assert tuple(run.progress.outcomes[-1]) == ("place", "apple", "failed: no_ik")
    (drive,) = run.tick()
    assert drive.pose == L1 and drive.id == 6


def test_a_place_given_up_is_put_on_the_tray():
    run = Run(Recovery.RETRY, max_tries=1)
    run.start(_ready(APPLE, check=FakeCheck()))
    run.to_stop(L2)
    run.pick()
    run.arm()
    run.to_stop((4.0, -1.0, math.pi / 2))
    run.pick()
    run.arm(ok=False, reason="missed")
    give_up = run.progress.recoveries[-1]
    assert give_up.kind == "give_up" and give_up.action == "put on the tray"
    assert run.state.mode is Mode.RELEASE
    (release,) = run.tick()
    assert release.dish == "apple"


def test_a_replan_asked_for_plans_what_remains_with_the_object_held():
    run = Run(Recovery.NONE)
    run.start(_ready(APPLE, check=NoCheck()))
    run.to_stop(L2)
    run.pick()
    run.arm()  # the apple is in the gripper
    run.tick()  # on the way to its place
    (plan,) = run.send(ReplanRequested(9.0, np.array([3.5, -1.0, 0.0])))
    assert plan.dishes == ("plate", "cup", "apple") and plan.held == "apple"
    assert plan.budget == 30.0 and plan.start == pytest.approx([3.5, -1.0, 0.0])
    run.send(_ready(PLATE, check=NoCheck()))
    assert run.state.mode is Mode.SEND and run.state.step == 0 and run.state.replans == 0
    assert run.progress.recoveries == () and len(run.progress.plans) == 2


# ---------------------------------------------------------------- at the plan's end
def test_dishes_left_out_are_planned_for_again_at_the_plan_s_end():
    run = Run(Recovery.REPLAN)
    plate_only = _plan(_goto("l1", L1), Pickup("plate", "l1", 0.9), unreachable=("apple",))
    run.start(_ready(plate_only, check=FakeCheck(), unchecked=("cup",)))
    assert run.state.unreachable == ("apple",)
    run.to_stop()
    run.pick()
    (plan,) = run.arm()
    assert plan.tight and plan.dishes == ("cup", "apple") and plan.budget == 10.0
    assert run.state.mode is Mode.PLANNING
    cup = _plan(_goto("l6", (1.0, 2.0, 0.0)), Pickup("cup", "l6", 0.5))
    assert run.send(_ready(cup, check=FakeCheck())) == ()
    state = run.state
    assert state.rechecked == ("apple", "cup") and state.unreachable == ()
    assert state.replans == 1 and state.mode is Mode.SEND
    replan = run.progress.recoveries[-1]
    assert replan.trigger == "left out: apple, cup" and replan.result == "done"
    run.to_stop((1.0, 2.0, 0.0))
    run.pick()
    assert run.arm() == (Finish(PLAN_ENDED),)  # asked once: no second recheck


def test_a_recheck_that_finds_no_plan_leaves_the_run_as_it_ended():
    run = Run(Recovery.REPLAN)
    run.start(_ready(PLATE, check=FakeCheck(), unchecked=("cup",)))
    run.to_stop()
    run.pick()
    run.arm()
    decisions = run.send(_failed())
    assert decisions == (Finish(PLAN_ENDED),)
    state = run.state
    assert state.finished and state.reason == PLAN_ENDED and state.plan is PLATE
    assert state.rechecked == () and state.replans == 0 and len(state.plans) == 2
    assert run.progress.recoveries[-1].kind == "replan"


def test_a_recheck_with_nothing_left_to_plan_ends_the_run():
    run = Run(Recovery.REPLAN)
    run.executive = Executive(_params(objects=(TaskObject("plate", "plate"),)),
                              localise=lambda pose, cid: pose)
    run.start(_ready(PLATE, check=FakeCheck(), unchecked=("plate",)))
    run.to_stop()
    run.pick()
    assert run.arm() == (Finish(PLAN_ENDED),)  # collected after all: nothing to plan
    assert run.state.rechecked == ("plate",) and run.state.replans == 0


@pytest.mark.parametrize("recovery", [Recovery.NONE, Recovery.RETRY])
def test_only_replan_rechecks(recovery):
    run = Run(recovery)
    run.start(_ready(PLATE, check=FakeCheck(), unchecked=("cup",)))
    run.to_stop()
    run.pick()
    assert run.arm() == (Finish(PLAN_ENDED),)


# ------------------------------------------------------------------------- smooth motion
def test_smooth_a_drive_brings_the_arm_to_its_first_dish_and_a_shared_stop_keeps_it_out():
    """With smooth motion the drive to a stop sends the arm towards its first dish's
    pre-grasp (a command of its own, not waited for); the first pickup leaves the arm over
    the tray for the next, the last one stows it for the base to leave."""
    run = Run(Recovery.NONE, motion="smooth")
    run.start(_ready(PLATE_CUP))
    (drive,) = run.tick()
    assert drive.prepare == "plate" and drive.prepare_id == drive.id + 1
    assert drive.face == TARGETS["plate"]  # lands facing it from where it lands
    assert run.state.arm_out and run.state.next_id == drive.id + 2
    run.base(land=L1)
    first = run.pick()
    assert first.dish == "plate" and not first.stow and first.id == drive.id + 2
    run.arm()
    assert not run.state.arm_out
    (turn,) = run.tick()  # the cup is 45 degrees off: the base turns to it
    assert isinstance(turn, Turn)
    run.base(land=(1.0, 1.0, math.pi / 4))
    second = run.pick()
    assert second.dish == "cup" and second.stow


def test_smooth_no_prepare_before_a_place_or_an_object_to_place():
    run = Run(Recovery.NONE, motion="smooth")
    run.start(_ready(APPLE))
    (drive,) = run.tick()
    assert drive.prepare == ""  # the apple is to be placed: picked as in stop and go


def test_smooth_a_correction_stows_a_prepared_arm_first():
    """A stop check that asks for a corrective move while the arm waits at the pre-grasp:
    the arm stows first, then the base moves."""
    check = FakeCheck(verdicts=[Assessment(False, 0.2)],
                      corrections=[(np.array([1.2, 1.0]), 0.9)])
    run = Run(Recovery.RETRY, motion="smooth")
    run.start(_ready(PLATE, check=check))
    run.to_stop()
    (stow,) = run.tick()
    assert isinstance(stow, Stow) and run.state.mode is Mode.STOWING
    assert run.arm() == ()
    assert not run.state.arm_out and run.state.mode is Mode.SEND
    (correction,) = run.tick()
    assert isinstance(correction, Drive) and run.state.mode is Mode.CORRECTING


def test_smooth_an_arm_that_will_not_stow_ends_the_run_after_a_few_tries():
    """The arm is out after a failed pickup and finds no way to its stow: the base may not
    drive. Each try is a new search; after STOW_ATTEMPTS the run ends, and says why, instead
    of asking again every control period for ever."""
    run = Run(Recovery.NONE, motion="smooth")
    run.start(_ready(_plan(_goto("l1", L1), Pickup("plate", "l1", 0.9),
                           _goto("l2", (3.0, 1.0, 0.0)), Pickup("cup", "l2", 0.7))))
    run.to_stop()
    run.pick()
    run.arm(ok=False, reason="no_ik")
    assert run.state.arm_out
    for attempt in range(1, STOW_ATTEMPTS + 1):
        (stow,) = run.tick()
        assert isinstance(stow, Stow) and run.state.mode is Mode.STOWING
        decisions = run.arm(ok=False, reason="no_path")
        assert run.state.stow_failures == attempt
    assert run.state.finished and "could not stow" in run.state.reason
    assert decisions == (Finish(run.state.reason),)
    assert run.tick() == ()


def test_stop_and_go_sends_no_prepare_and_always_stows():
    run = Run(Recovery.NONE)
    run.start(_ready(PLATE_CUP))
    drive = run.to_stop()
    assert drive.prepare == "" and drive.face is None and not run.state.arm_out
    assert run.pick().stow
