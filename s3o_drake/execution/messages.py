"""The messages the execution systems pass on their abstract-valued ports.

The executive (`ExecutiveSystem`) numbers its commands 1, 2, ... and emits at most one
command per controller at a time; a controller starts a command when its `id` changes and
reports on its status port, with the same `id`, when the command is done or has failed. The
executive advances when the status of its current command says it ended (the `Executive`
decides what follows: the next action, a retry, a replan or the end). Id 0 means "no
command": controllers hold still.

`PickupRecord` is what the executive learns of each executed pickup (for the calibration of
Fea^m, s3o_drake.experiments.calibration); it travels in `PlanProgress` to the task monitor,
whose `RunReport` is what a run reports (its `to_dict()` is report.json's data).

All are frozen dataclasses: a port value is copied by Drake, and nothing may change it in
place.
"""

import math
from dataclasses import dataclass, field
from enum import Enum
from typing import TYPE_CHECKING, Any

from s3o_drake.world.placing import PLACE_TOLERANCE, SURFACE_TOLERANCE

if TYPE_CHECKING:  # the Executive, which reads these messages, imports no Drake
    from s3o_drake.feasibility.scene import FeasibilityScene

NO_COMMAND = 0

PLAN_ENDED = "plan ended"
"""`PlanProgress.reason` when the plan ran to its last action (or nothing was left to
plan). Not "complete": pickups may have failed on the way; the outcomes say which."""
_PLAN_ENDED_BEFORE = "plan complete"  # PLAN_ENDED as results written before issue 18 say it


def ran_to_end(reason: str | None) -> bool:
    """Whether a run's `reason` says its plan ran to the end (rather than a blocked drive,
    no plan, the time limit or a failed simulation); reads earlier results' word too."""
    return reason in (PLAN_ENDED, _PLAN_ENDED_BEFORE)


class CommandState(str, Enum):
    """Where a controller is with its latest command. A str Enum, so that a state compares
    and serialises as the plain word ("idle", "running", "done", "failed")."""

    IDLE = "idle"  # no command yet
    RUNNING = "running"
    DONE = "done"
    FAILED = "failed"

    def __str__(self) -> str:
        # The word, not "CommandState.DONE": str() of a mixed-in Enum, and since Python 3.11
        # also format() and f-strings, would otherwise name the class and the member.
        return self.value


@dataclass(frozen=True)
class KnownScene:
    """The Drake scene of what the robot knows (the latest plan's KnownWorld: its map, the
    chairs it perceived, the objects left and their place targets): what the controllers
    check their motions in. `scene` None: no plan yet."""

    scene: "FeasibilityScene | None" = None

    def __deepcopy__(self, memo: dict) -> "KnownScene":
        # Shared, not copied: Drake deep-copies a port's Python value where it keeps one,
        # and the scene (a plant and its collision checker) is the planner's own, never
        # changed after it was built.
        return self


@dataclass(frozen=True)
class BaseCommand:
    """Drive along `path` (the navigation map's waypoints, m; the first is where the base
    is) and end at `pose` = (x, y, yaw); `id` 0 is no command. A `turn` turns in place to
    the pose's yaw (its x, y are where the base stands) and lands without the navigation
    noise T^n, which models arriving from a drive."""

    id: int = NO_COMMAND
    path: tuple[tuple[float, float], ...] = ()
    pose: tuple[float, float, float] = (0.0, 0.0, 0.0)
    turn: bool = False
    face: tuple[float, float] | None = None
    """Land facing this point (x, y) from where the base really lands, instead of at the
    pose's yaw (which faces it from the pose): the heading error of the landing noise
    stays, its drift in x, y no longer turns the base away."""


@dataclass(frozen=True)
class ArmMotion:
    """What the arm does over time (the ArmController's `arm_motion` port): the robot's
    positions along `trajectory` from time `t_start` (s, simulated; None: no motion), and
    the arm's and fingers' positions `hold` before it and after it ends (where it ends);
    during a pickup, the `dish` picked, until it is let go at `release_time`."""

    trajectory: Any = None
    t_start: float = 0.0
    hold: tuple[float, ...] = ()
    dish: str = ""
    """The dish the gripper reaches for, holds or lets go of until `release_time`."""
    release_time: float = -math.inf

    def touching(self, t: float) -> str:
        """The dish the gripper may touch at time `t` ("" for none)."""
        return self.dish if t <= self.release_time else ""

    @property
    def end_time(self) -> float:
        """When the motion ends (its start when there is none)."""
        return self.t_start + (0.0 if self.trajectory is None else
                               float(self.trajectory.end_time()))

    def arm_at(self, t: float) -> tuple[float, ...]:
        """The arm's and fingers' positions at time `t`."""
        if self.trajectory is None or t >= self.end_time:
            return self.final
        tau = min(max(t - self.t_start, 0.0), float(self.trajectory.end_time()))
        return tuple(float(v) for v in self.trajectory.value(tau).ravel()[3:])

    @property
    def final(self) -> tuple[float, ...]:
        """Where the arm is once its motion ends."""
        if self.trajectory is None:
            return self.hold
        end = float(self.trajectory.end_time())
        return tuple(float(v) for v in self.trajectory.value(end).ravel()[3:])


@dataclass(frozen=True)
class PickCommand:
    """Pick `dish` from where the base stands and put it on the tray (an object whose goal
    is place: hold it above the tray); with `place`, put `dish`, held in the gripper, down
    at its place target (`goals.place_target_name`); naming the object held, without
    `place`, let it go over the tray (its place failed for good). `id` 0 is none."""

    id: int = NO_COMMAND
    dish: str = ""
    place: bool = False
    place_from: tuple[float, float, float] | None = None
    """For the pickup of an object to place: the base pose (x, y, yaw) the plan puts it
    down from. The hand never re-grasps, so the pickup prefers a grasp that can put the
    object down there."""
    stow: bool = True
    """After a pickup onto the tray: the arm returns to its stow (the base drives next);
    False: it stays over the tray, fingers open (another pickup follows at this stop, and
    its approach starts there)."""
    prepare: tuple[float, float, float] | None = None
    """Instead of a pickup, bring the arm from where it is to `dish`'s pre-grasp as seen
    from this base pose (x, y, yaw: the stop the base drives to), arriving as the base
    command `base_id`'s motion ends, where the arm's motion along the base's is
    collision-free (later where it is not; not at all where nothing is)."""
    base_id: int = NO_COMMAND
    """With `prepare`: the base command whose motion the arm's is timed and checked
    against."""
    to_stow: bool = False
    """Instead of a pickup, bring the arm to its stow (the base is to move with it)."""


@dataclass(frozen=True)
class Status:
    """A controller's report on command `id`: its `state` (a CommandState: idle before any
    command, running, done or failed), with the failure's `reason` (e.g. "no_ik",
    "no_path", "missed", "base_collision", "blocked").

    `sighted`: on the arm's reports of a pick or a place, whether it aimed where the
    robot's sensor saw its target (the referee joins the sensing error to it).

    `contact`: on the base's report of a blocked drive, the plan-view point (x, y) where the
    base touched what blocked it (a bumper's reading, `BaseClearance.contact`)."""

    id: int = NO_COMMAND
    state: CommandState = CommandState.IDLE
    reason: str = ""
    sighted: bool = False
    contact: tuple[float, float] | None = None
    until: float = field(default=0.0, compare=False)
    """When the controller's motion for the command ends (s, simulated). The arm reports a
    pickup done once the object is lifted, while its motion to the tray plays on: the
    base may leave then, and the run ends only when the arm is done. Timing, not what the
    report says: two reports that differ only in it are equal."""

    def __post_init__(self) -> None:
        # A state given as its word ("done") is stored as the CommandState, so that the
        # port always carries the enum; a word that is no state is a ValueError.
        if not isinstance(self.state, CommandState):
            object.__setattr__(self, "state", CommandState(self.state))

    @property
    def finished(self) -> bool:
        return self.state in (CommandState.DONE, CommandState.FAILED)


@dataclass(frozen=True)
class PickupRecord:
    """One executed pickup, as calibration of Fea^m needs it: what the plan predicted from
    where, where the base really stood, and what happened.

    `dish`, `kind` (plate, bowl, cup); `method` that planned it; `predicted`: the plan's
    Fea^m of the pickup (`Pickup.feasibility`) from its planned stop; `source`: the model
    that gave it (`planner.feasibility`: "fcn" or "oracle"); `planned_pose`: the stop as
    planned, (x, y, yaw) of the goto before the pickup (the plan's start pose when there
    was none); `actual_pose`: the base's (x, y, yaw) when the pickup was commanded, after
    any turn to face the dish (where a turn failed: where it stopped); `outcome`: "done",
    or the failure's reason ("no_ik", "missed", "turn blocked", ...); `reach_noise`: the
    reach error, (dx, dy) m: the error of the robot's sighting of the target that the arm
    aimed at (None where it aimed at none, or the sighting was exact), which the referee
    fills in from `sighting`, the arm command that asked for it (0: none; not kept in the
    plain data); `attempt`: 1 for the plan's
    pickup, 2, 3, ... for the recovery's retries of it (whose `planned_pose` and
    `predicted` are those of the corrected stop, where there was a correction); `planned`:
    the plan's Fea^m of the action whatever corrections did (None in records written
    before it was kept): what the plan priced its chance of failing at.
    """

    dish: str
    kind: str
    method: str
    predicted: float
    source: str
    planned_pose: tuple[float, float, float]
    actual_pose: tuple[float, float, float]
    outcome: str
    reach_noise: tuple[float, float] | None = None
    attempt: int = 1
    planned: float | None = None
    sighting: int = field(default=0, compare=False)

    @property
    def succeeded(self) -> bool:
        return self.outcome == "done"

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON data (lists for the tuples)."""
        return {"dish": self.dish, "kind": self.kind, "method": self.method,
                "predicted": self.predicted, "source": self.source,
                "planned_pose": list(self.planned_pose), "actual_pose": list(self.actual_pose),
                "outcome": self.outcome,
                "reach_noise": None if self.reach_noise is None else list(self.reach_noise),
                "attempt": self.attempt, "planned": self.planned}

    @classmethod
    def from_dict(cls, data: Any) -> "PickupRecord":
        """The record of `to_dict`'s data; ValueError naming the field when it is not one."""
        if not isinstance(data, dict):
            raise ValueError(f"expected a pickup record (an object), got {data!r:.60}")
        missing = [f for f in ("dish", "kind", "method", "predicted", "source",
                               "planned_pose", "actual_pose", "outcome") if f not in data]
        if missing:
            raise ValueError(f"pickup record without {missing[0]!r}")
        for name in ("dish", "kind", "method", "source", "outcome"):
            if not isinstance(data[name], str):
                raise ValueError(f"{name}: expected a string, got {data[name]!r:.60}")
        predicted = data["predicted"]
        if (isinstance(predicted, bool) or not isinstance(predicted, int | float)
                or not 0.0 <= predicted <= 1.0):
            raise ValueError(f"predicted: expected a probability in [0, 1], got {predicted!r}")
        noise = data.get("reach_noise")
        attempt = data.get("attempt", 1)  # records written before retries existed: 1
        if isinstance(attempt, bool) or not isinstance(attempt, int) or attempt < 1:
            raise ValueError(f"attempt: expected a positive integer, got {attempt!r:.60}")
        planned = data.get("planned")
        if planned is not None and (isinstance(planned, bool)
                                    or not isinstance(planned, int | float)
                                    or not 0.0 <= planned <= 1.0):
            raise ValueError(f"planned: expected a probability in [0, 1], got {planned!r:.60}")
        return cls(dish=data["dish"], kind=data["kind"], method=data["method"],
                   predicted=float(predicted), source=data["source"],
                   planned_pose=_numbers(data["planned_pose"], 3, "planned_pose"),
                   actual_pose=_numbers(data["actual_pose"], 3, "actual_pose"),
                   outcome=data["outcome"],
                   reach_noise=None if noise is None else _numbers(noise, 2, "reach_noise"),
                   attempt=attempt, planned=None if planned is None else float(planned))


def _numbers(value: Any, count: int, name: str) -> tuple[float, ...]:
    if (not isinstance(value, list | tuple) or len(value) != count
            or not all(isinstance(v, int | float) and not isinstance(v, bool)
                       and math.isfinite(v) for v in value)):
        raise ValueError(f"{name}: expected {count} finite numbers, got {value!r:.60}")
    return tuple(float(v) for v in value)


@dataclass(frozen=True)
class RecoveryRecord:
    """One recovery of the run: what failed, what was done, and what it cost.

    `kind`: "correction" (a short move to a better stop before a pickup), "retry" (a failed
    pickup tried again), "replan" (the dishes that remain planned again) or "give_up" (a
    dish left after its tries and replans); `dish`: the dish concerned ("" for a replan
    after a blocked drive); `trigger`: what failed or what the stop check found; `action`:
    what was done; `result`: "done", or how it ended ("failed: blocked", "no plan: ...");
    `started`, `ended`: simulated time (s) of the recovery's own motion (equal for a replan,
    which takes no simulated time); `planning_time`: wall time (s) a replan took.
    """

    kind: str
    dish: str
    trigger: str
    action: str
    result: str
    started: float
    ended: float
    planning_time: float = 0.0

    @property
    def cost(self) -> float:
        """The simulated time (s) the recovery's motion took."""
        return self.ended - self.started

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON data, as report.json lists it (with `cost`)."""
        return {"kind": self.kind, "dish": self.dish, "trigger": self.trigger,
                "action": self.action, "result": self.result, "started": self.started,
                "ended": self.ended, "cost": self.cost, "planning_time": self.planning_time}


@dataclass(frozen=True)
class ActionOutcome:
    """How one action of the plan ended: `action` ("goto" or "pickup"), its `argument` (the
    location or the dish), whether it was `done`, and if not, the `reason`; `ended`: the
    simulated time (s) it ended, None where not known. It unpacks as (action, argument,
    result), result "done" or "failed: <reason>", as report.json lists it."""

    action: str
    argument: str
    done: bool
    reason: str = ""
    ended: float | None = None

    @property
    def result(self) -> str:
        return "done" if self.done else f"failed: {self.reason}"

    def __iter__(self):
        return iter((self.action, self.argument, self.result))


@dataclass(frozen=True)
class PlanTime:
    """One plan of a run (the first, then each replan), against its budget.

    `planning_time`: wall time (s) the plan took, perception and Fea^m included;
    `feasibility_time`: of that, the time Fea^m took, which comes before the budget starts
    (None when no plan was made: the planner then gives no breakdown); `budget`: the
    planner's time budget for this plan (s).
    """

    planning_time: float
    feasibility_time: float | None
    budget: float

    def to_dict(self) -> dict[str, Any]:
        return {"planning_time": self.planning_time,
                "feasibility_time": self.feasibility_time, "budget": self.budget}




@dataclass(frozen=True)
class Placement:
    """Where an object to place ended, against its place target.

    `target`: the place (x, y, surface z; m); `state`: the object's DishState word
    ("placed" once put down, "gripper" while held, ...); `final`: where it stands (x, y,
    z of its bottom); `error`: the horizontal distance (m) from the target; `upright`:
    it stands within the tracker's STANDING_TILT of upright. `placed`: put down within
    PLACE_TOLERANCE of the target, upright, on the target's surface.
    """

    object: str
    target: tuple[float, float, float]
    state: str
    final: tuple[float, float, float]
    upright: bool

    @property
    def error(self) -> float:
        return math.hypot(self.final[0] - self.target[0], self.final[1] - self.target[1])

    @property
    def placed(self) -> bool:
        return (self.state == "placed" and self.upright and self.error <= PLACE_TOLERANCE
                and abs(self.final[2] - self.target[2]) <= SURFACE_TOLERANCE)

    def to_dict(self) -> dict[str, Any]:
        return {"object": self.object, "target": list(self.target), "state": self.state,
                "final": list(self.final), "error": self.error, "upright": self.upright,
                "placed": self.placed}


@dataclass(frozen=True)
class PlanProgress:
    """The planner's progress through its plan, for the task monitor.

    `step`: the action being executed (1-based; 0 before a plan exists), of `total`.
    `finished`: nothing more will happen (plan done, or it cannot go on: `reason` says
    why: PLAN_ENDED, or e.g. "goto 3 failed: blocked", "no plan: ...").
    `outcomes`: per finished action, its ActionOutcome.
    `pickups`: per finished pickup, in order, its `PickupRecord`.
    `recoveries`: per recovery, in order, its `RecoveryRecord`.
    `unreachable`: dishes no free pose of the known world can pick (the plans' Fea^m is 0
    wherever the base may stand), sorted.
    `plans`: per plan made, in order, its `PlanTime`.
    """

    step: int = 0
    total: int = 0
    finished: bool = False
    reason: str = ""
    outcomes: tuple[ActionOutcome, ...] = ()
    pickups: tuple[PickupRecord, ...] = ()
    recoveries: tuple[RecoveryRecord, ...] = ()
    unreachable: tuple[str, ...] = ()
    plans: tuple[PlanTime, ...] = ()


@dataclass(frozen=True)
class RunReport:
    """What the task monitor reports of a run.

    `dishes`: how many objects the world has with a goal (to collect or to place; not
    those that stay); `collected_dishes`: those on the tray, sorted; `placements`: a
    Placement per object to place;
    `execution_time` (s): the simulated time at which the plan finished, else the time of
    the report; `finished`: the plan is over; `reason`: why (`PlanProgress.reason`, or
    "time limit"); `outcomes`, `pickups`, `recoveries`, `unreachable` and `plans`:
    `PlanProgress`'s; `closest_approach` (m): the smallest distance between the robot and
    the true world's walls, tables and chairs over the run, measured in the simulation
    (`world.clearance_monitor`; NaN where nothing measured it; below zero: in collision).
    """

    dishes: int = 0
    collected_dishes: tuple[str, ...] = ()
    execution_time: float = 0.0
    closest_approach: float = math.nan
    finished: bool = False
    reason: str = ""
    outcomes: tuple[ActionOutcome, ...] = ()
    pickups: tuple[PickupRecord, ...] = ()
    recoveries: tuple[RecoveryRecord, ...] = ()
    unreachable: tuple[str, ...] = ()
    plans: tuple[PlanTime, ...] = ()
    placements: tuple[Placement, ...] = ()

    @property
    def collected(self) -> int:
        """How many dishes are on the tray."""
        return len(self.collected_dishes)

    @property
    def placed(self) -> int:
        """How many objects stand at their places (`Placement.placed`)."""
        return sum(p.placed for p in self.placements)

    @property
    def completed(self) -> int:
        """How many objects' goals are met: collected, or placed."""
        return self.collected + self.placed

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON data, as report.json holds it (execute.py adds the timings): dishes,
        collected, placed, completed, collected_dishes (a list), placements
        (`Placement.to_dict()` each), execution_time, finished, reason, outcomes
        (a list of [action, argument, result] lists), outcome_times (the simulated time each
        of them ended, s: where the execution's time went, action by action), pickups
        (`PickupRecord.to_dict()` each), recoveries (`RecoveryRecord.to_dict()` each),
        unreachable (a list), plans
        (`PlanTime.to_dict()` each), closest_approach (None where nothing measured it)."""
        return {
            "dishes": self.dishes,
            "collected": self.collected,
            "placed": self.placed,
            "completed": self.completed,
            "collected_dishes": list(self.collected_dishes),
            "placements": [p.to_dict() for p in self.placements],
            "execution_time": self.execution_time,
            "finished": self.finished,
            "reason": self.reason,
            "outcomes": [list(outcome) for outcome in self.outcomes],
            "outcome_times": [outcome.ended for outcome in self.outcomes],
            "pickups": [record.to_dict() for record in self.pickups],
            "recoveries": [record.to_dict() for record in self.recoveries],
            "unreachable": list(self.unreachable),
            "plans": [plan.to_dict() for plan in self.plans],
            "closest_approach": (None if math.isnan(self.closest_approach)
                                 else self.closest_approach),
        }
