"""The plan's time model: what the simulated execution will take, and the utility's costs.

A plan runs as a chain of commands, one at a time (execution/executive.py): a base command
per `goto`, a turn in place before a pickup whose dish the base does not face (a stop that
serves several dishes faces the first), and an arm command per `pickup`. Its simulated
execution time is predicted as

    T = Σ_gotos (t_drive + γ) + Σ_turns (t_turn + γ) + Σ_pickups δ(kind, d) + T_0

- t_drive: the BaseNavigator's motion along the navigation map's path, from the yaw the base
  left its previous stop with to the stop's yaw (facing its first dish): turns in place,
  trapezoidal drives, backing away from a stop (`base_motion`, `NavigationMap.path_times`);
- t_turn: a turn in place before a further pickup at a stop, when the dish is more than
  TURN_TOLERANCE off the base's heading (the Executive's rule);
- γ: the fixed time of a base command that its motion does not cover: the navigator's
  settle time, and the hand-over between commands (see `command_overheads`);
- δ(kind, d): a pickup: the ArmController's motion, a fitted function of the dish's kind,
  its distance d from the base and the grasp the arm takes there, plus the arm command's
  hand-over;
- T_0: the start and the end of the run (the first command starts a control period after
  t = 0; the run ends when the planner reads the last report, without the next hand-over).

γ, δ and T_0 are derived by `s3o build time-model` and recorded in the robot's
models/<robot>/time_model.yaml (`TimeModel`), which everything reads: the pickup's duration
is the arm's, and changes with it (re-run the command after changing the arm's motion).

The utility keeps the paper's form, R(goto) = -Cst(goto) with Cst = time + γ, and
R(pickup) = -δ + λ Fea^m, under one of two cost profiles (`PlanningSettings.cost_profile`):

- "robot": the terms above: Cst(goto) = t_drive + γ + Σ_turns at its stop (t_turn + γ), δ
  the recorded pickup time; the utility's costs are then the predicted time;
- "paper": the paper's values: Cst(goto) = len / v + γ, δ constant (the scenario's
  planner.delta, gamma, speed: 5, 20, 0.4 by default), len the path length on the map.

With smooth motion (`execution.motion: smooth`) the drives are smooth
(`base_motion.smooth_chain_time`), and the arm's motions overlap the base's
(execution/arm_controller.py): the arm reaches the first dish's pre-grasp while the base
drives in (its motion is hidden in the drive), a pickup is done once its dish is lifted,
and the arm takes the dish to the tray while the base turns to the next dish or leaves.
The terms (`SmoothArm`, recorded with the model) are then

- a stop's first pickup onto the tray: δ = grasp(kind, d) (the descent, the fingers
  closing and the lift) plus the hand-over, and the arm's lateness where the drive was too
  short to hide its way there: the previous dish's tail and the stow, and prepare(kind, d)
  (from the stow to the pre-grasp), less the goto's time;
- a further one at the stop: the previous dish's tail(kind, d) (to the tray and letting go)
  or the turn to this dish with its γ, whichever is longer, then from_tray(kind, d) (the
  arm from the tray to this dish's pre-grasp) and grasp(kind, d) and the hand-over;
- a goto after a stop's pickups: drive + γ + `departure`, the base's wait for the arm to
  rise clear of the table (measured in simulations, with whatever else the terms leave
  out), and at the plan's end the last dish's tail and the arm's stow(kind, d);
- objects to place, their places, and a pickup at the start (no drive to hide the arm's
  approach in) keep the stop-and-go terms.

Either way the plan's `predicted_time` is T above (for the paper profile too, since it is a
prediction of the execution, not a cost), as planned: every landing exact, every action
done. With the navigation and reaching noise on, the landings differ: the base turns to
face the dish when its heading is off by more than the tolerance, the arm's approach starts
from a pre-grasp made for the planned stop, and the last leg of a drive bends to where the
base lands. The plan's `expected_time` is T plus what the noise adds on average per goto and
per pickup (`NoiseTerms`, one pair per motion), measured in paired simulations with the noise
off and on by `s3o build time-model` at the scenario noise it records; a scenario with other
noise has no expected time. The utility's costs are T alone (see docs/planning.md).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import yaml

from s3o_drake.belief.known_world import KnownWorld
from s3o_drake.feasibility.landing import TURN_TOLERANCE
from s3o_drake.planning.navigation.base_motion import SETTLE_TIME, STOP_AND_GO, BaseProfile
from s3o_drake.planning.plan import Goto, Pickup
from s3o_drake.world.angles import facing_yaw, wrap
from s3o_drake.world.robot import CONTROL_PERIOD, Robot
from s3o_drake.world.settings import PlanningSettings

if TYPE_CHECKING:  # only for hints: the systems import this module for their period
    from s3o_drake.planning.navigation.map import NavigationMap

FORMAT = "s3o_drake.TimeModel/1"
PICKUP_FORMS = ("constant", "per_kind", "linear", "per_kind_linear", "per_kind_grasp",
                "per_kind_grasp_linear", "per_kind_grasp_quadratic")
"""Pickup-duration models, polynomials in d (the base-dish distance) per group: one for all,
per dish kind, or per kind and grasp (the grasp predicted from the distance: `PickupModel`)."""
GRASPS = ("top", "side")


@dataclass(frozen=True)
class Overheads:
    """The fixed times of the command chain (s), from the systems' control period."""

    gamma: float
    """Per base command: settle time, reading the report, sending the next command."""
    pickup: float
    """Per arm command: its end, reading its report, sending the next command."""
    plan: float
    """Once per plan: the first command's start minus the last command's hand-over."""


def command_overheads(control_period: float = CONTROL_PERIOD,
                      settle_time: float = SETTLE_TIME) -> Overheads:
    """The command chain's fixed times for the execution diagram's timing.

    The planner and the controllers update every `control_period`, at the same ticks, and
    Drake computes a tick's updates from the state before it, so a message written at one
    tick is read at the next. A base command starts at a tick; the navigator reports done
    `settle_time` after its motion ends (a function of time: readable at once), the planner
    reads it at the first tick after that (half a period later on average), writes the next
    command one tick later, and the next controller starts it one tick after that:
    γ = settle + 2.5 periods. An arm command's motion ends at the first tick after its
    trajectory (half a period on average), its report is state (read one tick later), then
    the same two ticks: 3.5 periods. The first command is written at t = 0 and started one
    tick later; the run's execution time is the tick at which the planner reads the last
    report, so the last command's two hand-over ticks do not happen: -1 period per plan.
    (Measured against full simulations in tests/planning/test_time_model.py.)
    """
    p = float(control_period)
    return Overheads(gamma=settle_time + 2.5 * p, pickup=3.5 * p, plan=-p)


@dataclass(frozen=True)
class PickupModel:
    """The arm's pickup motion duration (s) as a polynomial in d, the horizontal distance (m)
    from the base's centre to the dish: `coefficients[key]` lowest degree first, the key the
    dish's kind and grasp ("cup/side"), else its kind ("cup"), else "*" (every dish).

    The grasp is the one the arm takes: the top grasp where it reaches, else the side grasp
    (`feasibility.grasps`: cups only); from the planner's side that is a distance per kind,
    `side_beyond[kind]` (m), beyond which the top grasp no longer reaches."""

    form: str
    coefficients: Mapping[str, tuple[float, ...]]
    side_beyond: Mapping[str, float] = field(default_factory=dict)

    def grasp(self, kind: str, distance) -> np.ndarray:
        """The grasp ("top" or "side") expected at `distance` (array)."""
        d = np.asarray(distance, dtype=float)
        return np.where(d > self.side_beyond.get(kind, math.inf), "side", "top")

    def coefficients_for(self, kind: str, grasp: str) -> tuple[float, ...]:
        for key in (f"{kind}/{grasp}", kind, "*"):
            if key in self.coefficients:
                return self.coefficients[key]
        raise KeyError(f"the pickup time model has no coefficients for a {kind!r} "
                       f"({grasp} grasp)")

    def duration(self, kind: str, distance) -> np.ndarray:
        d = np.asarray(distance, dtype=float)
        grasp = self.grasp(kind, d)
        out = np.zeros(d.shape)
        for g in GRASPS:
            where = grasp == g
            if where.any():
                c = self.coefficients_for(kind, g)
                out = np.where(where, np.polynomial.polynomial.polyval(d, c), out)
        return out


SMOOTH_PARTS = ("grasp", "from_tray", "tail", "stow", "prepare")
"""The arm's motions a smooth plan is timed with (`SmoothArm`)."""


@dataclass(frozen=True)
class SmoothArm:
    """The arm's motions as a smooth plan overlaps them with the base's (module docstring):
    durations (s) by dish kind and distance d, each a `PickupModel` (`parts`: `grasp`,
    `from_tray`, `tail`, `stow`, `prepare`: from the stow to the pre-grasp), and the base's
    `departure` wait (s); `fit`: how they were made."""

    parts: Mapping[str, PickupModel]
    departure: float
    fit: Mapping[str, Any] = field(default_factory=dict)

    def duration(self, part: str, kind: str, distance) -> np.ndarray:
        return self.parts[part].duration(kind, distance)

    def to_dict(self) -> dict[str, Any]:
        return {**dict(self.fit), "departure": float(self.departure),
                **{name: _pickup_dict(self.parts[name]) for name in SMOOTH_PARTS}}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> SmoothArm:
        data = dict(data)
        parts = {name: _pickup_model(data.pop(name), f"smooth.{name}")
                 for name in SMOOTH_PARTS}
        return cls(parts=parts, departure=float(data.pop("departure")), fit=data)


def _pickup_dict(model: PickupModel) -> dict[str, Any]:
    return {"model": model.form,
            "coefficients": {k: [float(c) for c in v]
                             for k, v in sorted(model.coefficients.items())},
            "side_beyond": {k: float(v) for k, v in sorted(model.side_beyond.items())}}


def _pickup_model(data: Mapping[str, Any], path: str) -> PickupModel:
    """A `PickupModel` from its record; the record's other keys are left out."""
    form = data["model"]
    if form not in PICKUP_FORMS:
        raise ValueError(f"{path}.model: unknown form {form!r}")
    coefficients = {str(k): tuple(float(c) for c in v)
                    for k, v in data["coefficients"].items()}
    side_beyond = {str(k): float(v) for k, v in data.get("side_beyond", {}).items()}
    return PickupModel(form, coefficients, side_beyond)


@dataclass(frozen=True)
class NoiseTerms:
    """What the simulated noise adds on average (s) to each goto and each pickup of a plan
    executed as planned, with one motion (`TimeModel.noise`), at the noise in `uncertainty`
    (`Uncertainty`'s nav_xy_std, nav_yaw_std, reach_std); `fit`: how they were measured."""

    goto: float
    pickup: float
    uncertainty: Mapping[str, float]
    fit: Mapping[str, Any] = field(default_factory=dict)

    def applies(self, uncertainty: Any) -> bool:
        """Whether `uncertainty` (an `Uncertainty`) is the noise these terms were measured
        at."""
        return all(math.isclose(float(getattr(uncertainty, name)), float(value),
                                rel_tol=1e-9, abs_tol=1e-12)
                   for name, value in self.uncertainty.items())

    def to_dict(self) -> dict[str, Any]:
        return {"goto": float(self.goto), "pickup": float(self.pickup),
                "uncertainty": {k: float(v) for k, v in self.uncertainty.items()},
                **dict(self.fit)}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> NoiseTerms:
        data = dict(data)
        return cls(goto=float(data.pop("goto")), pickup=float(data.pop("pickup")),
                   uncertainty={str(k): float(v) for k, v in data.pop("uncertainty").items()},
                   fit=data)


NOISE_FIELDS = ("nav_xy_std", "nav_yaw_std", "reach_std")
"""The simulated noise that `NoiseTerms` are measured at: the landing's and the reach's."""


@dataclass(frozen=True)
class TimeModel:
    """The recorded time model (a robot's models/<robot>/time_model.yaml): the command
    overheads, the pickup model, the arm's motions of a smooth plan (`smooth`; None in
    models made before it), what the noise adds per motion (`noise`, by `choices.Motion`
    value) and how they were made (`provenance`, `fit`)."""

    overheads: Overheads
    pickup: PickupModel
    turn_tolerance: float = TURN_TOLERANCE
    provenance: Mapping[str, Any] = field(default_factory=dict)
    fit: Mapping[str, Any] = field(default_factory=dict)
    smooth: SmoothArm | None = None
    noise: Mapping[str, NoiseTerms] = field(default_factory=dict)

    def noise_time(self, motion: str, uncertainty: Any, *, gotos: int,
                   pickups: int) -> float | None:
        """What the noise adds on average (s) to a plan of `gotos` and `pickups` executed
        with `motion` at `uncertainty`; None where the model has no terms measured there."""
        terms = self.noise.get(motion)
        if terms is None or not terms.applies(uncertainty):
            return None
        return gotos * terms.goto + pickups * terms.pickup

    def pickup_time(self, kind: str, distance) -> np.ndarray:
        """δ: a pickup command's time (s), the arm's motion and its hand-over."""
        return self.pickup.duration(kind, distance) + self.overheads.pickup

    def to_dict(self) -> dict[str, Any]:
        out = {"format": FORMAT, **dict(self.provenance),
               "gamma": self.overheads.gamma, "pickup_overhead": self.overheads.pickup,
               "plan_offset": self.overheads.plan, "turn_tolerance": self.turn_tolerance,
               "pickup": {**_pickup_dict(self.pickup), **dict(self.fit)}}
        if self.smooth is not None:
            out["smooth"] = self.smooth.to_dict()
        if self.noise:
            out["noise"] = {m: terms.to_dict() for m, terms in sorted(self.noise.items())}
        return out

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> TimeModel:
        if data.get("format") != FORMAT:
            raise ValueError(f"not a time model (format {data.get('format')!r}, expected "
                             f"{FORMAT!r})")
        pickup = _pickup_model(data["pickup"], "pickup")
        fit = {k: v for k, v in data["pickup"].items()
               if k not in ("model", "coefficients", "side_beyond")}
        known = {"format", "gamma", "pickup_overhead", "plan_offset", "turn_tolerance",
                 "pickup", "smooth", "noise"}
        return cls(overheads=Overheads(gamma=float(data["gamma"]),
                                       pickup=float(data["pickup_overhead"]),
                                       plan=float(data["plan_offset"])),
                   pickup=pickup, turn_tolerance=float(data["turn_tolerance"]),
                   provenance={k: v for k, v in data.items() if k not in known}, fit=fit,
                   smooth=(SmoothArm.from_dict(data["smooth"]) if "smooth" in data
                           else None),
                   noise={str(m): NoiseTerms.from_dict(t)
                          for m, t in (data.get("noise") or {}).items()})

    @classmethod
    def load(cls, path: str | Path) -> TimeModel:
        """The recorded model at `path` (a robot's: `Robot.files.time_model`; cached per
        path)."""
        return _load(str(Path(path).resolve()))


@functools.lru_cache(maxsize=4)
def _load(path: str) -> TimeModel:
    if not Path(path).is_file():
        raise FileNotFoundError(f"{path}: no time model; make it with "
                                "`s3o build time-model`")
    return TimeModel.from_dict(yaml.safe_load(Path(path).read_text()))


def base_profile(planner: PlanningSettings, motion: str = STOP_AND_GO, *,
                 robot: Robot | None) -> BaseProfile:
    """The base's motion profile as the navigator drives it: the planner's speed v, the
    navigator's other limits, the `motion` (`choices.Motion`) and whether `robot`'s base is
    holonomic (None: a differential base, as the paper's costs assume)."""
    holonomic = robot is not None and robot.description.base.holonomic
    return BaseProfile(speed=planner.speed, motion=motion, holonomic=holonomic)


@dataclass(frozen=True)
class DishPlace:
    """What the cost model needs of a dish: where it stands and its kind."""

    xy: tuple[float, float]
    kind: str
    collect: bool = True
    """Picked onto the tray (not an object to place, nor a place target)."""


class CostModel:
    """The utility's costs and the predicted time of one planning problem.

    `profile` "robot" or "paper" (module docstring). `dishes` and `start` (x, y, yaw) make
    the time prediction possible; without them (`CostModel.paper(planner)`, for library
    callers that have only the planner settings) the predicted time is the paper's
    estimate Σ len / v + δ per pickup.
    """

    def __init__(self, planner: PlanningSettings, *, robot: Robot | None,
                 profile: str | None = None, dishes: Mapping[str, DishPlace] | None = None,
                 start: Sequence[float] | None = None, time_model: TimeModel | None = None,
                 motion: str = STOP_AND_GO, uncertainty: Any = None):
        self.planner = planner
        self.robot = robot
        """The robot the costs are of (None: the paper's costs, which need none)."""
        self.uncertainty = uncertainty
        self.profile = planner.cost_profile if profile is None else profile
        if self.profile not in ("robot", "paper"):
            raise ValueError(f"unknown cost profile {self.profile!r}")
        self.dishes = dict(dishes or {})
        self.start = None if start is None else np.asarray(start, dtype=float)[:3]
        self.timed = bool(self.dishes) and self.start is not None
        if self.profile == "robot" and (not self.timed or robot is None):
            raise ValueError("the robot cost profile needs the robot, the dishes and the "
                             "start pose")
        if self.timed and time_model is None and robot is None:
            raise ValueError("a time prediction needs the robot or its time model")
        self.model = ((time_model or TimeModel.load(robot.files.time_model)) if self.timed
                      else None)
        self.base = base_profile(planner, motion, robot=robot)
        self.reward = planner.reward
        self.arm = None if self.model is None or not self.base.smooth else self.model.smooth
        if self.model is not None and self.base.smooth and self.arm is None:
            raise ValueError("the time model has no smooth section: make it again with "
                             "`s3o build time-model`")

    @classmethod
    def paper(cls, planner: PlanningSettings, robot: Robot | None = None) -> CostModel:
        """The paper's costs from the planner settings alone (no time prediction); `robot`,
        for the shares of its shared stops (`shared_stop: execution`)."""
        return cls(planner, robot=robot, profile="paper")

    @classmethod
    def for_known(cls, known: KnownWorld, time_model: TimeModel | None = None, *,
                  start: Sequence[float] | None = None) -> CostModel:
        """The planner's cost profile, with the dishes that remain and where the robot
        stands (or `start`, (x, y[, yaw]): where its plan starts) for the time prediction."""
        placing = set(known.places) | set(known.places.values())
        dishes = {d.name: DishPlace((float(d.position[0]), float(d.position[1])), d.kind,
                                    collect=d.name not in placing)
                  for d in known.dishes}
        pose = known.pose if start is None else (*np.asarray(start, float)[:2], known.pose[2])
        if time_model is None and known.planner.time_model:
            time_model = TimeModel.load(known.planner.time_model)
        return cls(known.planner, robot=known.robot, dishes=dishes, start=pose,
                   time_model=time_model,
                   motion=known.settings.execution.motion, uncertainty=known.uncertainty)

    @property
    def gamma(self) -> float:
        """γ of the utility: the paper's start cost, or the robot's per-command time."""
        return self.planner.gamma if self.profile == "paper" else self.model.overheads.gamma

    # ----------------------------------------------------------------------- the parts
    def pickup_times(self, dishes: Sequence[str], where: np.ndarray,
                     stops: Sequence[int] | None = None,
                     gotos: np.ndarray | None = None) -> np.ndarray:
        """δ (s) of picking each of `dishes` (k) from its base positions `where` (m, k, 2):
        (m, k). The dishes of a kind share one pickup model, so they go in one batch. With
        smooth motion, `stops` (k: the goto each pickup follows, -1 at the start, in the
        plan's order) and the gotos' times (m, n: `goto_times`') give the smooth terms
        (module docstring); the last pickup's then holds the arm's last motions, to the
        tray and to its stow."""
        where = np.asarray(where, float)
        where = where.reshape(len(where), len(dishes), 2)
        xy = np.array([self.dishes[d].xy for d in dishes], dtype=float).reshape(1, -1, 2)
        distance = np.linalg.norm(where - xy, axis=2)
        out = np.zeros(distance.shape)
        kinds = [self.dishes[d].kind for d in dishes]
        for kind in sorted(set(kinds)):
            cols = [j for j, k in enumerate(kinds) if k == kind]
            out[:, cols] = self.model.pickup_time(kind, distance[:, cols])
        if self.arm is None or stops is None:
            return out
        return self._smooth_pickup_times(dishes, where, distance, out, stops, gotos)

    def _smooth_pickup_times(self, dishes: Sequence[str], where: np.ndarray,
                             distance: np.ndarray, plain: np.ndarray,
                             stops: Sequence[int], gotos: np.ndarray | None) -> np.ndarray:
        arm, o = self.arm, self.model.overheads
        out = plain.copy()

        def part(name: str, j: int) -> np.ndarray:
            return arm.duration(name, self.dishes[dishes[j]].kind, distance[:, j])

        smooth = [False] * len(dishes)
        for j, dish in enumerate(dishes):
            first = j == 0 or stops[j] != stops[j - 1]
            if not self.dishes[dish].collect or (first and stops[j] < 0):
                continue  # the stop-and-go term: no drive hides the arm's approach
            if first:
                # The arm's way to the pre-grasp (from the last dish to the tray and the
                # stow) against the goto's: a short drive does not hide it all.
                way = part("prepare", j)
                if j > 0 and smooth[j - 1]:
                    way = way + part("tail", j - 1) + part("stow", j - 1)
                drive = 0.0 if gotos is None else np.asarray(gotos)[:, stops[j]]
                out[:, j] = part("grasp", j) + o.pickup + np.maximum(0.0, way - drive)
            elif smooth[j - 1]:
                # The base turns to this dish while the arm takes the last one to the tray.
                delta = wrap(self.facing(where[:, j], dish)
                             - self.facing(where[:, j - 1], dishes[j - 1]))
                turn = np.where(np.abs(delta) > self.model.turn_tolerance,
                                self.base.turn_time(delta) + o.gamma, 0.0)
                out[:, j] = (np.maximum(part("tail", j - 1), turn) + part("from_tray", j)
                             + part("grasp", j) + o.pickup)
            else:
                continue
            smooth[j] = True
        if dishes and smooth[-1]:
            out[:, -1] += part("tail", len(dishes) - 1) + part("stow", len(dishes) - 1)
        return out

    def pickup_costs(self, dishes: Sequence[str], where: np.ndarray,
                     stops: Sequence[int] | None = None,
                     gotos: np.ndarray | None = None) -> np.ndarray:
        """δ of the utility for picking each of `dishes` (k) from `where` (m, k, 2): (m, k)
        (`pickup_times`' `stops` and `gotos`)."""
        if self.profile == "paper":
            return np.full((len(where), len(dishes)), self.planner.delta)
        return self.pickup_times(dishes, where, stops, gotos)

    def facing(self, where: np.ndarray, dish: str) -> np.ndarray:
        """Yaw (m,) of base positions `where` (m, 2) facing `dish`."""
        return facing_yaw(np.asarray(where, float).reshape(-1, 2), self.dishes[dish].xy)

    def stop_turns(self, where: np.ndarray, yaw: np.ndarray,
                   dishes: Sequence[str]) -> tuple[np.ndarray, np.ndarray]:
        """The turns in place at a stop: base positions `where` (m, 2) arriving at `yaw`
        (m,) pick `dishes` in order, turning first to face each one that is more than the
        tolerance off. Returns their time Σ (t_turn + γ) (m,; with smooth motion the first
        turn's, the others being in the pickups' terms) and the yaw the base leaves with
        (m,)."""
        yaw = np.asarray(yaw, dtype=float).copy()
        total = np.zeros(len(yaw))
        for k, dish in enumerate(dishes):
            delta = wrap(self.facing(where, dish) - yaw)
            turn = np.abs(delta) > self.model.turn_tolerance
            # With smooth motion the turns after the first overlap the arm's motion: their
            # time is in the pickup's term.
            if k == 0 or self.arm is None or not self.dishes[dish].collect:
                total += np.where(turn, self.base.turn_time(delta)
                                  + self.model.overheads.gamma, 0.0)
            yaw = np.where(turn, yaw + delta, yaw)
        return total, yaw

    def goto_times(self, nav: NavigationMap, stops: np.ndarray,
                   stop_dishes: Sequence[Sequence[str]], start_dishes: Sequence[str] = ()
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """For samples of stops (m, n, 2) visited in order from the start, each followed by
        the pickups `stop_dishes[k]`: path lengths (m, n), goto times (m, n) (drive + γ +
        the turns at the stop) and the time of the turns at the start before its pickups
        `start_dishes` (m,). inf where a leg cannot be driven."""
        stops = np.asarray(stops, dtype=float)
        m, n = stops.shape[:2]
        start_xy = np.broadcast_to(self.start[:2], (m, 2))
        start_turns, yaw = self.stop_turns(start_xy, np.full(m, self.start[2]), start_dishes)
        if n == 0:
            return np.zeros((m, 0)), np.zeros((m, 0)), start_turns
        # Each stop's landing yaw faces its first dish; it leaves facing its last one picked
        # after a turn. Both depend on the stop alone, so every leg goes in one batch.
        flat = stops.reshape(m * n, 2)
        arrive = np.full((m, n), np.nan)
        turns = np.zeros((m, n))
        leave = np.full((m, n), np.nan)
        for k, dishes in enumerate(stop_dishes):
            if dishes:
                arrive[:, k] = self.facing(stops[:, k], dishes[0])
                turns[:, k], leave[:, k] = self.stop_turns(stops[:, k], arrive[:, k], dishes)
        depart = np.concatenate([yaw[:, None], leave[:, :-1]], axis=1)
        prev = np.concatenate([start_xy[:, None], stops[:, :-1]], axis=1).reshape(m * n, 2)
        lengths, drive, landing = nav.path_times(prev, flat, np.nan_to_num(depart).ravel(),
                                                 arrive.ravel(), self.base)
        unknown = np.isnan(depart).ravel()
        if unknown.any():
            # After a stop without pickups the base faces along the leg it came by (a
            # landing yaw that does not depend on where it left from): the next leg starts
            # from there.
            fix = np.flatnonzero(unknown)
            previous_landing = np.concatenate([np.full((m, 1), np.nan),
                                               landing.reshape(m, n)[:, :-1]], axis=1).ravel()
            _, drive[fix], _ = nav.path_times(prev[fix], flat[fix], previous_landing[fix],
                                              arrive.ravel()[fix], self.base)
        goto = drive.reshape(m, n) + self.model.overheads.gamma + turns
        if self.arm is not None:
            # A goto that leaves a stop with pickups onto the tray waits for the arm.
            before = [start_dishes, *stop_dishes[:-1]]
            leaving = np.array([any(self.dishes[d].collect for d in dishes)
                                for dishes in before], dtype=float)
            goto = goto + self.arm.departure * leaving[None, :]
        return lengths.reshape(m, n), goto, start_turns

    def expected_time(self, predicted_time: float, actions: Sequence[Any]) -> float | None:
        """A plan's expected execution time (s) with the scenario's noise: its
        `predicted_time` plus what the noise adds to its `actions`' gotos and pickups
        (`TimeModel.noise_time`); None without a time model, or without terms measured at
        this noise and motion."""
        if self.model is None or self.uncertainty is None:
            return None
        extra = self.model.noise_time(
            self.base.motion, self.uncertainty,
            gotos=sum(isinstance(a, Goto) for a in actions),
            pickups=sum(isinstance(a, Pickup) for a in actions))
        return None if extra is None else float(predicted_time) + extra

    def predicted_time(self, goto_times: np.ndarray, start_turns: np.ndarray,
                       pickup_times: np.ndarray) -> np.ndarray:
        """T (module docstring) from the parts (m, n), (m,), (m, pickups)."""
        return (goto_times.sum(axis=1) + start_turns + pickup_times.sum(axis=1)
                + self.model.overheads.plan)


def departures(actions: Sequence[Any]) -> int:
    """How many gotos of a plan's `actions` leave a stop (or the start) after pickups: those
    the smooth model's `departure` is charged to (`CostModel.goto_times`; for a plan of
    collecting, where every pickup goes onto the tray)."""
    count, picked = 0, False
    for action in actions:
        if isinstance(action, Goto):
            count += picked
            picked = False
        elif isinstance(action, Pickup):
            picked = True
    return count
