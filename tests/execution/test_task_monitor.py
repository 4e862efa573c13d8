"""TaskMonitor: reports the dishes on the tray and ends the simulation when the plan is over."""

import dataclasses
import json
import math

import pytest
from pydrake.common.value import AbstractValue
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantValueSource

from s3o_drake.execution.messages import (
    ActionOutcome,
    CommandState,
    PickupRecord,
    PlanProgress,
    PlanTime,
    RecoveryRecord,
    RunReport,
    Status,
)
from s3o_drake.execution.task_monitor import OFF_PLACE, TaskMonitor
from s3o_drake.world.dish_messages import DishPoses, DishState, DishStates
from s3o_drake.world.goals import PlaceTarget

STATES = DishStates({"plate_a": DishState.TRAY, "cup_b": DishState.DROPPED,
                     "bowl_c": DishState.TRAY, "plate_d": DishState.TABLE})
RECORDS = (
    PickupRecord(dish="plate_a", kind="plate", method="S3O-GROP*", predicted=0.97,
                 source="fcn", planned_pose=(1.0, 2.0, 0.5), actual_pose=(1.05, 1.9, 0.52),
                 outcome="done", reach_noise=(0.004, -0.01)),
    PickupRecord(dish="cup_b", kind="cup", method="S3O-GROP*", predicted=0.6, source="fcn",
                 planned_pose=(1.0, 2.0, 0.5), actual_pose=(1.05, 1.9, 0.8),
                 outcome="missed", reach_noise=(0.03, 0.02)),
)
DONE = PlanProgress(step=4, total=4, finished=True, reason="plan ended",
                    outcomes=(ActionOutcome("goto", "l1", done=True),
                              ActionOutcome("pickup", "plate_a", done=True),
                              ActionOutcome("pickup", "cup_b", done=False, reason="missed")),
                    pickups=RECORDS)


def _fixed(monitor: TaskMonitor, context, progress: PlanProgress, states=STATES):
    monitor.GetInputPort("progress").FixValue(context, progress)
    monitor.GetInputPort("dish_states").FixValue(context, states)


def _force_check(monitor: TaskMonitor, context):
    updated = context.Clone()
    monitor.CalcForcedDiscreteVariableUpdate(context, updated.get_mutable_discrete_state())
    context.SetTimeStateAndParametersFrom(updated)


def test_report_counts_the_dishes_on_the_tray():
    monitor = TaskMonitor()
    context = monitor.CreateDefaultContext()
    _fixed(monitor, context, PlanProgress(step=2, total=4,
                                          plans=(PlanTime(2.5, 0.5, 5.0),)))
    context.SetTime(3.0)
    report = monitor.GetOutputPort("report").Eval(context)
    assert isinstance(report, RunReport)
    assert report.to_dict() == {
        "dishes": 4, "collected": 2, "placed": 0, "completed": 2,
        "collected_dishes": ["bowl_c", "plate_a"], "placements": [],
        "execution_time": 3.0, "finished": False, "reason": "", "outcomes": [],
        "outcome_times": [], "pickups": [],
        "recoveries": [], "unreachable": [],
        "plans": [{"planning_time": 2.5, "feasibility_time": 0.5, "budget": 5.0}],
        "closest_approach": None}  # no clearance monitor connected: nothing measured it


def test_report_carries_the_closest_approach_measured():
    monitor = TaskMonitor()
    context = monitor.CreateDefaultContext()
    _fixed(monitor, context, PlanProgress(step=0, total=2))
    monitor.GetInputPort("closest_approach").FixValue(context, [0.034])
    report = monitor.GetOutputPort("report").Eval(context)
    assert report.closest_approach == pytest.approx(0.034)
    assert report.to_dict()["closest_approach"] == pytest.approx(0.034)


def test_each_object_to_place_is_judged_against_its_target():
    """The apple's place is on the plate, which stays (no goal, not counted): within 3 cm,
    upright and on the plate's top it is placed; 4 cm off, tilted, on the table beside
    the plate, or still in the gripper, it is not."""
    target = PlaceTarget("apple", "apple", "dining", (4.95, 3.75), 0.775, onto="plate")
    monitor = TaskMonitor(places=[target], fixtures=["plate"])
    context = monitor.CreateDefaultContext()
    upright, tilted = RotationMatrix.MakeZRotation(0.7), RotationMatrix.MakeXRotation(0.4)
    for state, R, p, placed in ((DishState.PLACED, upright, [4.97, 3.74, 0.775], True),
                                (DishState.PLACED, upright, [4.99, 3.75, 0.775], False),
                                (DishState.PLACED, tilted, [4.95, 3.75, 0.775], False),
                                (DishState.PLACED, upright, [4.95, 3.75, 0.75], False),
                                (DishState.GRIPPER, upright, [4.95, 3.75, 0.775], False)):
        _fixed(monitor, context, DONE, DishStates({"can": DishState.TRAY, "apple": state,
                                                   "plate": DishState.TABLE}))
        monitor.GetInputPort("dish_poses").FixValue(context, DishPoses({
            "can": RigidTransform(), "apple": RigidTransform(R, p),
            "plate": RigidTransform([4.95, 3.75, 0.75])}))
        report = monitor.GetOutputPort("report").Eval(context)
        (placement,) = report.placements
        assert placement.placed == placed, (state, p)
        assert placement.upright == (R is upright)
        assert placement.error == pytest.approx(math.hypot(p[0] - 4.95, p[1] - 3.75))
        assert (report.dishes, report.collected, report.placed, report.completed) == \
            (2, 1, int(placed), 1 + placed)
        data = json.loads(json.dumps(report.to_dict()))
        assert data["placements"][0] == {
            "object": "apple", "target": [4.95, 3.75, 0.775], "state": str(state),
            "final": p, "error": placement.error, "upright": R is upright, "placed": placed}


def test_an_object_to_place_let_go_on_the_tray_is_neither_collected_nor_placed():
    target = PlaceTarget("apple", "apple", "dining", (4.95, 3.75), 0.775, onto="plate")
    monitor = TaskMonitor(places=[target], fixtures=["plate"])
    context = monitor.CreateDefaultContext()
    _fixed(monitor, context, DONE, DishStates({"can": DishState.TRAY, "apple": DishState.TRAY,
                                              "plate": DishState.TABLE}))
    monitor.GetInputPort("dish_poses").FixValue(context, DishPoses({
        "can": RigidTransform(), "apple": RigidTransform([1.0, 1.0, 0.5]),
        "plate": RigidTransform([4.95, 3.75, 0.75])}))
    report = monitor.GetOutputPort("report").Eval(context)
    assert report.collected_dishes == ("can",) and report.placed == 0
    assert (report.dishes, report.completed) == (2, 1)
    assert report.placements[0].state == "tray"


def test_a_put_down_that_leaves_its_object_off_its_place_is_recorded_as_failed():
    """The arm's place motion ended "done" twice (a first put-down, then the record of a
    later one); the object stands 4 cm off: the later record, the one that let it go, says
    off_place, so the calibration of Fea^m counts the place as failed. At its place, both
    stay done."""
    target = PlaceTarget("apple", "apple", "dining", (4.95, 3.75), 0.775, onto="plate")
    place = dataclasses.replace(RECORDS[0], dish="apple__place", kind="apple")
    progress = dataclasses.replace(DONE, pickups=(place, RECORDS[1],
                                                  dataclasses.replace(place, attempt=2)))
    monitor = TaskMonitor(places=[target], fixtures=["plate"])
    context = monitor.CreateDefaultContext()
    for x, outcome in ((4.97, "done"), (4.99, OFF_PLACE)):
        _fixed(monitor, context, progress, DishStates({"apple": DishState.PLACED,
                                                       "plate": DishState.TABLE}))
        monitor.GetInputPort("dish_poses").FixValue(context, DishPoses({
            "apple": RigidTransform([x, 3.75, 0.775]),
            "plate": RigidTransform([4.95, 3.75, 0.75])}))
        records = monitor.GetOutputPort("report").Eval(context).pickups
        assert [r.outcome for r in records] == ["done", "missed", outcome]


def test_execution_time_is_when_the_plan_finished():
    monitor = TaskMonitor()
    context = monitor.CreateDefaultContext()
    _fixed(monitor, context, DONE)
    context.SetTime(12.5)
    _force_check(monitor, context)
    context.SetTime(14.0)
    report = monitor.GetOutputPort("report").Eval(context)
    assert report.finished and report.reason == "plan ended"
    assert report.execution_time == pytest.approx(12.5)
    assert report.to_dict()["outcomes"] == [["goto", "l1", "done"], ["pickup", "plate_a", "done"],
                                  ["pickup", "cup_b", "failed: missed"]]


def test_report_carries_the_pickup_records_as_plain_json():
    monitor = TaskMonitor()
    context = monitor.CreateDefaultContext()
    _fixed(monitor, context, DONE)
    pickups = monitor.GetOutputPort("report").Eval(context).to_dict()["pickups"]
    assert pickups[1] == {"dish": "cup_b", "kind": "cup", "method": "S3O-GROP*",
                          "predicted": 0.6, "source": "fcn", "planned_pose": [1.0, 2.0, 0.5],
                          "actual_pose": [1.05, 1.9, 0.8], "outcome": "missed",
                          "reach_noise": [0.03, 0.02], "attempt": 1, "planned": None}
    # Through JSON and back: the same records.
    again = json.loads(json.dumps(pickups))
    assert tuple(PickupRecord.from_dict(p) for p in again) == RECORDS
    assert [r.succeeded for r in RECORDS] == [True, False]


def test_report_carries_the_recoveries_and_the_unreachable_dishes():
    monitor = TaskMonitor()
    context = monitor.CreateDefaultContext()
    correction = RecoveryRecord("correction", "cup_b", "stop check at (1.00, 2.00): not "
                                "feasible", "moved 0.10 m to (1.10, 2.00)", "done", 20.0, 24.5)
    replan = RecoveryRecord("replan", "", "goto l2 failed: blocked", "planned 1 dish from "
                            "(1.10, 2.00): 2 actions", "done", 30.0, 30.0, planning_time=2.5)
    _fixed(monitor, context, dataclasses.replace(DONE, recoveries=(correction, replan),
                                                 unreachable=("bowl_c",)))
    report = monitor.GetOutputPort("report").Eval(context).to_dict()
    assert report["unreachable"] == ["bowl_c"]
    first, second = json.loads(json.dumps(report["recoveries"]))
    assert first["kind"] == "correction" and first["cost"] == pytest.approx(4.5)
    assert second["kind"] == "replan" and second["cost"] == 0.0
    assert second["planning_time"] == 2.5


def test_simulation_ends_settle_time_after_the_plan_finishes():
    monitor = TaskMonitor(settle_time=0.5)
    simulator = Simulator(monitor)
    context = simulator.get_mutable_context()
    _fixed(monitor, context, PlanProgress(step=1, total=4))
    status = simulator.AdvanceTo(1.0)
    assert status.reason() == status.ReturnReason.kReachedBoundaryTime

    _fixed(monitor, context, DONE)
    status = simulator.AdvanceTo(100.0)
    assert status.reason() == status.ReturnReason.kReachedTerminationCondition
    assert context.get_time() == pytest.approx(1.5, abs=0.011)
    report = monitor.GetOutputPort("report").Eval(context)
    assert report.execution_time == pytest.approx(1.0, abs=0.011)
    assert report.collected == 2 and report.finished
    assert [p.outcome for p in report.pickups] == ["done", "missed"]


def test_simulation_ends_at_the_time_limit():
    builder = DiagramBuilder()
    monitor = builder.AddNamedSystem("monitor", TaskMonitor(time_limit=2.0))
    progress = builder.AddSystem(ConstantValueSource(AbstractValue.Make(
        PlanProgress(step=1, total=3))))
    states = builder.AddSystem(ConstantValueSource(AbstractValue.Make(STATES)))
    builder.Connect(progress.get_output_port(), monitor.GetInputPort("progress"))
    builder.Connect(states.get_output_port(), monitor.GetInputPort("dish_states"))
    diagram = builder.Build()
    simulator = Simulator(diagram)
    status = simulator.AdvanceTo(1000.0)
    assert status.reason() == status.ReturnReason.kReachedTerminationCondition
    assert "time limit" in status.message()
    context = monitor.GetMyContextFromRoot(simulator.get_context())
    assert context.get_time() == pytest.approx(2.0, abs=0.011)
    report = monitor.GetOutputPort("report").Eval(context)
    assert report.reason == "time limit" and not report.finished
    assert report.execution_time == pytest.approx(2.0, abs=0.011)


@pytest.mark.parametrize("change, field", [
    ({"predicted": 1.2}, "predicted"), ({"predicted": "0.9"}, "predicted"),
    ({"actual_pose": [1.0, 2.0]}, "actual_pose"), ({"reach_noise": [0.1]}, "reach_noise"),
    ({"outcome": None}, "outcome"), ({"dish": None}, "dish"),
])
def test_a_bad_pickup_record_is_refused_by_field(change, field):
    data = {**RECORDS[0].to_dict(), **change}
    with pytest.raises(ValueError, match=field):
        PickupRecord.from_dict(data)
    del data[field]
    if field != "reach_noise":  # optional: None when no noise was drawn
        with pytest.raises(ValueError, match=field):
            PickupRecord.from_dict(data)


def test_a_status_carries_a_command_state_that_prints_as_its_word():
    status = Status(3, "done")  # a word is taken as its state
    assert status.state is CommandState.DONE and status.finished
    assert status == Status(3, CommandState.DONE) and not Status(4).finished
    assert str(status.state) == f"{status.state}" == "done"
    assert json.dumps(status.state) == '"done"'
    with pytest.raises(ValueError):
        Status(3, "finished")


def test_bad_arguments_are_refused():
    with pytest.raises(ValueError, match="settle_time"):
        TaskMonitor(settle_time=-1.0)


def test_the_referee_joins_each_sightings_error_to_its_record():
    """The controller's records name the arm command that aimed with a sighting; the
    monitor, on the simulation's side, fills in that sighting's error, and leaves the
    records that aimed with none."""
    errors = {3: (0.004, -0.01), 5: (0.03, 0.02)}
    aimed = (dataclasses.replace(RECORDS[0], reach_noise=None, sighting=3),
             dataclasses.replace(RECORDS[1], reach_noise=None, sighting=5),
             dataclasses.replace(RECORDS[1], reach_noise=None, outcome="turn blocked"))
    monitor = TaskMonitor(sensing_error=errors.get)
    context = monitor.CreateDefaultContext()
    _fixed(monitor, context, dataclasses.replace(DONE, pickups=aimed))
    pickups = monitor.GetOutputPort("report").Eval(context).pickups
    assert [p.reach_noise for p in pickups] == [errors[3], errors[5], None]
    # Exact sightings have no error.
    monitor = TaskMonitor(sensing_error=lambda request: None)
    context = monitor.CreateDefaultContext()
    _fixed(monitor, context, dataclasses.replace(DONE, pickups=aimed))
    assert all(p.reach_noise is None
               for p in monitor.GetOutputPort("report").Eval(context).pickups)
