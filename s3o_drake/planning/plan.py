"""The task-motion plan every method returns and its JSON form.

A `TaskMotionPlan` is what execution and the benchmark read: the state space it was
planned in, the actions in order (each `goto` with the base pose it drives to and the
collision-free path there, each `pickup` with its dish and Fea^m from where it is
picked, each `place` likewise), the expected utility and predicted execution time, and
where the planning time went. It is plain data so that a plan can be written by one
process and executed or compared by another: `to_json`/`from_json` round-trip it exactly
(Python's float repr is exact, tuples come back as tuples), and `write` writes it
atomically.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from s3o_drake.world.files import write_atomically

FORMAT = "s3o_drake.TaskMotionPlan/1"
"""Tag of the JSON form, so that a reader can tell a plan file from another JSON file."""


@dataclass(frozen=True)
class Goto:
    """Drive to `location`, ending at `pose`, along `path`."""

    location: str
    pose: tuple[float, float, float]
    """Base pose (x, y, yaw) at the end: yaw faces the next dish to pick (m, m, rad)."""
    path: tuple[tuple[float, float], ...]
    """Waypoints from the previous pose's position to `pose`'s position (m)."""
    length: float
    """Collision-free path length (m), as the utility counted it."""


@dataclass(frozen=True)
class Pickup:
    """Pick `dish` from where the latest goto (or the start) left the base."""

    dish: str
    location: str
    """The location the robot stands in ("start" before any goto)."""
    feasibility: float
    """Fea^m of the pick from the goto's position: the expected success."""


@dataclass(frozen=True)
class Place:
    """Put `dish`, held in the gripper, down at its place, from where the latest goto left
    the base (world/goals.py)."""

    dish: str
    location: str
    feasibility: float
    """Fea^m of putting it down from the goto's position: the expected success."""


PlanAction = Goto | Pickup | Place


@dataclass(frozen=True)
class TaskOrder:
    """What the task planner could say of the plan's order (its navigation cost is
    clingo's integer objective: the drive time at the planner's speed x COST_SCALE,
    planning/motion/petlon.py)."""

    cost: int
    """The order's navigation cost."""
    optimal: bool
    """clingo proved it optimal in its rank (the best order, or for the k-th order found
    the best but the k - 1 before it; the motion search may choose any of them)."""
    lower_bound: int
    """No order of the state space costs less (the best order's cost when proven)."""
    found: int
    """Distinct orders found in the state space, of `asked`."""
    asked: int

    @property
    def gap(self) -> float:
        """How far the order's cost may lie above the best order's, at most, as a share
        of its cost (0 when proven optimal)."""
        return 0.0 if self.cost <= 0 else max(self.cost - self.lower_bound, 0) / self.cost

    def describe(self) -> str:
        """One line for a person: proven or not, the gap, and how many orders were found."""
        if self.optimal and self.gap == 0:
            what = "proven optimal"
        elif self.optimal:
            what = f"{self.gap:.0%} above the best order (proven; its stops won)"
        else:
            what = f"not proven optimal (at most {self.gap:.0%} above the best order)"
        found = "" if self.found >= self.asked else (
            f"; {self.found} of {self.asked} orders found")
        return f"task order {what}{found}"


@dataclass(frozen=True)
class TaskMotionPlan:
    """One method's plan for one task (see the module docstring)."""

    method: str
    seed: int
    groups: tuple[tuple[str, ...], ...]
    """The state space: the dishes of each location, location k named `locations[k]`."""
    locations: tuple[str, ...]
    actions: tuple[PlanAction, ...]
    utility: float
    """Σ R(a) (GROP*'s utility) of the plan: expected, with Fea^m as the pickup success."""
    predicted_time: float
    """The simulated execution time the plan should take (s), as planned: exact landings,
    every action done (planning/time_model.py)."""
    planning_time: float
    """Wall time of `plan` (s), plus `timing["feasibility"]` if the caller passed it."""
    timing: dict[str, float] = field(default_factory=dict)
    """Breakdown of the planning time (s): feasibility, navigation, abstraction,
    task_planning, motion_search."""
    unreachable: tuple[str, ...] = ()
    """Dishes no plan can pick (empty Voronoi cell or no drivable way there)."""
    score: float | None = None
    """The chosen state space's Score Σ Fea^t (None where a method does not score it)."""
    searches: int = 0
    """Motion searches run (one per task-level sequence searched)."""
    samples: int = 0
    """Base-pose samples evaluated over all searches."""
    complete: bool = True
    """False if the time budget cut the search short (the plan is the best so far)."""
    early_samples: tuple[tuple[tuple[float, float], ...], ...] = ()
    """The winning search's first generation: per sample, one (x, y) per goto (m); empty
    for methods that run no search (the paper's Fig. 4, left)."""
    late_samples: tuple[tuple[tuple[float, float], ...], ...] = ()
    """Its last generation (Fig. 4, right)."""
    order: TaskOrder | None = None
    """What clingo proved of the order (None: no task planning, or an older plan file)."""
    expected_time: float | None = None
    """The execution time to expect with the scenario's noise (s): `predicted_time` plus what
    the noise adds on average per goto and pickup (planning/time_model.py); None where the
    time model has no such terms for this noise and motion."""

    @property
    def gotos(self) -> tuple[Goto, ...]:
        return tuple(a for a in self.actions if isinstance(a, Goto))

    @property
    def pickups(self) -> tuple[Pickup, ...]:
        return tuple(a for a in self.actions if isinstance(a, Pickup))

    @property
    def places(self) -> tuple[Place, ...]:
        return tuple(a for a in self.actions if isinstance(a, Place))

    @property
    def task_actions(self) -> tuple[tuple[str, str], ...]:
        """The task-level sequence (("goto", location) / ("pickup", dish) / ("place",
        dish)), as the task planner writes it, for `check_plan`."""
        return tuple(("goto", a.location) if isinstance(a, Goto) else
                     ("place" if isinstance(a, Place) else "pickup", a.dish)
                     for a in self.actions)

    @property
    def feasibility(self) -> dict[str, float]:
        """Fea^m per picked dish."""
        return {a.dish: a.feasibility for a in self.pickups}

    # ------------------------------------------------------------------------ JSON
    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-able data (lists and dicts of str, float, int, bool, None)."""
        actions: list[dict[str, Any]] = []
        for a in self.actions:
            if isinstance(a, Goto):
                actions.append({"action": "goto", "location": a.location,
                                "pose": list(a.pose), "path": [list(p) for p in a.path],
                                "length": a.length})
            else:
                actions.append({"action": "place" if isinstance(a, Place) else "pickup",
                                "dish": a.dish, "location": a.location,
                                "feasibility": a.feasibility})
        return {
            "format": FORMAT, "method": self.method, "seed": self.seed,
            "groups": [list(g) for g in self.groups], "locations": list(self.locations),
            "actions": actions, "utility": self.utility,
            "predicted_time": self.predicted_time, "expected_time": self.expected_time,
            "planning_time": self.planning_time,
            "timing": dict(self.timing), "unreachable": list(self.unreachable),
            "score": self.score, "searches": self.searches, "samples": self.samples,
            "complete": self.complete,
            "early_samples": _nested_lists(self.early_samples),
            "late_samples": _nested_lists(self.late_samples),
            "order": None if self.order is None else {
                "cost": self.order.cost, "optimal": self.order.optimal,
                "lower_bound": self.order.lower_bound, "gap": self.order.gap,
                "found": self.order.found, "asked": self.order.asked},
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> TaskMotionPlan:
        if data.get("format") != FORMAT:
            raise ValueError(f"not a task-motion plan (format {data.get('format')!r}, "
                             f"expected {FORMAT!r})")
        actions: list[PlanAction] = []
        for a in data["actions"]:
            if a["action"] == "goto":
                actions.append(Goto(location=a["location"],
                                    pose=tuple(float(v) for v in a["pose"]),
                                    path=tuple((float(x), float(y)) for x, y in a["path"]),
                                    length=float(a["length"])))
            elif a["action"] in ("pickup", "place"):
                kind = Pickup if a["action"] == "pickup" else Place
                actions.append(kind(dish=a["dish"], location=a["location"],
                                    feasibility=float(a["feasibility"])))
            else:
                raise ValueError(f"unknown action {a['action']!r} in a plan")
        score = data.get("score")
        order = data.get("order")
        if order is not None:
            order = TaskOrder(cost=int(order["cost"]), optimal=bool(order["optimal"]),
                              lower_bound=int(order["lower_bound"]),
                              found=int(order["found"]), asked=int(order["asked"]))
        return cls(method=data["method"], seed=int(data["seed"]),
                   groups=tuple(tuple(g) for g in data["groups"]),
                   locations=tuple(data["locations"]), actions=tuple(actions),
                   utility=float(data["utility"]), predicted_time=float(data["predicted_time"]),
                   planning_time=float(data["planning_time"]),
                   timing={k: float(v) for k, v in data["timing"].items()},
                   unreachable=tuple(data["unreachable"]),
                   score=None if score is None else float(score),
                   searches=int(data["searches"]), samples=int(data["samples"]),
                   complete=bool(data["complete"]),
                   early_samples=samples_tuple(data.get("early_samples", [])),
                   late_samples=samples_tuple(data.get("late_samples", [])),
                   order=order, expected_time=(None if data.get("expected_time") is None
                                               else float(data["expected_time"])))

    def to_json(self, indent: int | None = 1) -> str:
        """Strict JSON (no NaN or Infinity: a plan's numbers are all finite)."""
        return json.dumps(self.to_dict(), indent=indent, allow_nan=False)

    @classmethod
    def from_json(cls, text: str) -> TaskMotionPlan:
        return cls.from_dict(json.loads(text))

    def write(self, path: str | Path) -> None:
        write_atomically(Path(path), self.to_json() + "\n")

    @classmethod
    def read(cls, path: str | Path) -> TaskMotionPlan:
        return cls.from_json(Path(path).read_text())


def samples_tuple(samples: Any) -> tuple[tuple[tuple[float, float], ...], ...]:
    """A generation's samples, (pop, n_gotos, 2) array-like, as nested tuples of floats."""
    return tuple(tuple((float(p[0]), float(p[1])) for p in sample) for sample in samples)


def _nested_lists(samples: tuple) -> list:
    return [[list(p) for p in sample] for sample in samples]
