"""TaskMonitor: the run's report, and the end of the simulation."""

import dataclasses
import math
from collections.abc import Callable, Sequence

from pydrake.common.value import AbstractValue
from pydrake.systems.framework import (
    Context,
    DiagramBuilder,
    DiscreteValues,
    EventStatus,
    LeafSystem,
    OutputPort,
)

from s3o_drake.execution.messages import PickupRecord, Placement, PlanProgress, RunReport
from s3o_drake.world.dish_messages import DishPoses, DishState, DishStates
from s3o_drake.world.goals import PlaceTarget, place_target_name, place_targets
from s3o_drake.world.object_tracker import STANDING_TILT, tilt
from s3o_drake.world.robot import CONTROL_PERIOD
from s3o_drake.world.scenario import Scenario
from s3o_drake.world.system_lifetime import weak_callback

TIME_LIMIT = 1800.0
"""Simulated seconds after which an execution is stopped whatever its state."""
TIME_LIMIT_REASON = "time limit"
#: The outcome of a put-down that left its object standing off its place (`_judged`).
OFF_PLACE = "off_place"


class TaskMonitor(LeafSystem):
    """Reports how many dishes are on the tray, and where each object to place stands
    against its place target (`places`; `fixtures` names the objects that stay, which have
    no goal), and stops the simulation when the plan is over. It is the referee, on the
    simulation's side: each pickup record gets the error of the sighting its arm command
    aimed with from `sensing_error` (`TargetSensor.error`; None: no sensing errors).

    A periodic check (`period`; also a forced discrete update) records the simulated time at
    which `progress.finished` first holds, and ends the simulation once it has held for
    `settle_time` (which lets the last dish come to rest on the tray), or as soon as the
    simulated time reaches `time_limit` (reason "time limit"): the check returns
    EventStatus.ReachedTermination, so `Simulator.AdvanceTo` returns early with
    kReachedTerminationCondition.

    Input ports:
        progress: abstract PlanProgress (from the planner).
        dish_states: abstract DishStates, the DishState of each dish (from the
            ObjectTracker).
        dish_poses: abstract DishPoses, X_WD of each dish (from the ObjectTracker; read
            for the objects to place only).
        closest_approach (vector 1, optional): the robot's closest approach to the world so
            far (m, from a ClearanceMonitor).
    Output ports:
        report: abstract RunReport: the dishes, those on the tray, the placements, the
            execution time (the
            simulated time the plan finished, else the current time), whether and why the
            plan finished, and progress's outcomes, pickup and recovery records and
            unreachable dishes, and the closest approach (`to_dict()` gives
            the plain JSON data that report.json holds).
    """

    def __init__(self, *, settle_time: float = 0.5, time_limit: float = 600.0,
                 period: float = 0.01, places: Sequence[PlaceTarget] = (),
                 fixtures: Sequence[str] = (),
                 sensing_error: Callable[[int], tuple[float, float] | None] | None = None
                 ) -> None:
        super().__init__()
        if settle_time < 0 or time_limit <= 0 or period <= 0:
            raise ValueError("settle_time must be >= 0, time_limit and period > 0")
        self._settle_time = settle_time
        self._time_limit = time_limit
        self._places = tuple(places)
        self._place_names = frozenset(p.name for p in self._places)
        self._fixtures = frozenset(fixtures)
        self._sensing_error = sensing_error
        self._progress_port = self.DeclareAbstractInputPort(
            "progress", AbstractValue.Make(PlanProgress()))
        self._dish_states_port = self.DeclareAbstractInputPort(
            "dish_states", AbstractValue.Make(DishStates()))
        self._dish_poses_port = self.DeclareAbstractInputPort(
            "dish_poses", AbstractValue.Make(DishPoses()))
        self._closest_port = self.DeclareVectorInputPort("closest_approach", 1)
        # The simulated time at which progress first said finished; NaN while it has not.
        self._finished_at_index = self.DeclareDiscreteState([math.nan])
        self.DeclareAbstractOutputPort("report", lambda: AbstractValue.Make(RunReport()),
                                       weak_callback(self._calc_report))
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, weak_callback(self._check))
        self.DeclareForcedDiscreteUpdateEvent(weak_callback(self._check))

    @property
    def settle_time(self) -> float:
        return self._settle_time

    @property
    def time_limit(self) -> float:
        return self._time_limit

    def _finished_at(self, context: Context) -> float:
        return float(context.get_discrete_state(self._finished_at_index).GetAtIndex(0))

    def _check(self, context: Context, discrete_state: DiscreteValues) -> EventStatus:
        t = context.get_time()
        finished_at = self._finished_at(context)
        if math.isnan(finished_at) and self._progress_port.Eval(context).finished:
            finished_at = t
            discrete_state.get_mutable_vector(self._finished_at_index).SetAtIndex(0, t)
        if t - finished_at >= self._settle_time:  # False while finished_at is NaN
            return EventStatus.ReachedTermination(self, "plan finished")
        if t >= self._time_limit:
            return EventStatus.ReachedTermination(self, TIME_LIMIT_REASON)
        return EventStatus.Succeeded()

    def _calc_report(self, context: Context, output: AbstractValue) -> None:
        progress = self._progress_port.Eval(context)
        dish_states: DishStates = self._dish_states_port.Eval(context)
        finished_at = self._finished_at(context)
        t = context.get_time()
        if not progress.finished and t >= self._time_limit:
            reason = TIME_LIMIT_REASON
        else:
            reason = progress.reason
        placements = self._placements(context, dish_states)
        output.set_value(RunReport(
            dishes=len(set(dish_states) - self._fixtures),
            # An object to place that ended on the tray (its place failed) is not collected.
            collected_dishes=tuple(d for d in dish_states.named(DishState.TRAY)
                                   if d not in self._place_names),
            placements=placements,
            execution_time=t if math.isnan(finished_at) else finished_at,
            finished=bool(progress.finished), reason=reason, outcomes=progress.outcomes,
            pickups=_judged(self._sensed(progress.pickups), placements),
            recoveries=progress.recoveries,
            unreachable=progress.unreachable, plans=progress.plans,
            closest_approach=(float(self._closest_port.Eval(context)[0])
                              if self._closest_port.HasValue(context) else math.nan)))

    def _sensed(self, records: tuple[PickupRecord, ...]) -> tuple[PickupRecord, ...]:
        """The records with the error of the sighting each aimed with."""
        if self._sensing_error is None:
            return records
        return tuple(dataclasses.replace(r, reach_noise=self._sensing_error(r.sighting))
                     if r.sighting else r for r in records)

    def _placements(self, context: Context, dish_states: DishStates) -> tuple[Placement, ...]:
        if not self._places:
            return ()
        poses: DishPoses = self._dish_poses_port.Eval(context)
        out = []
        for place in self._places:
            if place.name not in poses:  # a referee on a bus that has not spoken yet
                continue
            X_WD = poses[place.name]
            out.append(Placement(
                object=place.name, target=(*place.position, place.surface),
                state=str(dish_states[place.name]),
                final=tuple(float(v) for v in X_WD.translation()),
                upright=tilt(X_WD.rotation()) <= STANDING_TILT))
        return tuple(out)


def _judged(records: tuple[PickupRecord, ...],
            placements: tuple[Placement, ...]) -> tuple[PickupRecord, ...]:
    """The records with each put-down judged by where the object stands: the arm's motion
    that let an object go (its place's last record "done") failed OFF_PLACE when the object
    does not stand at its place, so that a place's Fea^m is calibrated against the place's
    goal, as a pick's is against the catch."""
    out = list(records)
    for p in placements:
        if p.state != str(DishState.PLACED) or p.placed:
            continue
        target = place_target_name(p.object)
        last = max((i for i, r in enumerate(out) if r.dish == target and r.succeeded),
                   default=None)
        if last is not None:
            out[last] = dataclasses.replace(out[last], outcome=OFF_PLACE)
    return tuple(out)


def add_task_monitor(builder: DiagramBuilder, scenario: Scenario, *, progress: OutputPort,
                     dish_states: OutputPort, dish_poses: OutputPort,
                     closest_approach: OutputPort, time_limit: float = TIME_LIMIT,
                     sensing_error: Callable[[int], tuple[float, float] | None] | None = None
                     ) -> TaskMonitor:
    """The referee ("task_monitor") of `scenario`, in `builder`: the executive's `progress`
    judged by the simulation's truth (`dish_states`, `dish_poses`, `closest_approach`)."""
    monitor = builder.AddNamedSystem("task_monitor", TaskMonitor(
        period=CONTROL_PERIOD, settle_time=scenario.simulation.hold_time,
        time_limit=time_limit, places=place_targets(scenario),
        fixtures=[d.name for d in scenario.dishes if d.goal == "stay"],
        sensing_error=sensing_error))
    for name, port in (("progress", progress), ("dish_states", dish_states),
                       ("dish_poses", dish_poses), ("closest_approach", closest_approach)):
        builder.Connect(port, monitor.GetInputPort(name))
    return monitor
