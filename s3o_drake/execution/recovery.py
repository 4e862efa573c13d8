"""What the robot does before and after a pickup when execution recovers (`execution.recovery`).

After each landing the robot localises: it believes it stands at its true pose plus the
localisation noise (`uncertainty.localization_xy_std`, `localization_yaw_std`), drawn from
the landing command's own random stream. `StopCheck` then judges the pickup from that belief,
on what the robot knows (the plan's KnownWorld: its map, the chairs it perceived, the dishes
left), never on the true world:

- `assess`: whether the ArmController's pickup test passes from the believed position,
  turned to face the dish (the Drake oracle's success test, `FeasibilityOracle.success`:
  grasp, pre-grasp, lift and tray, collision-free on the known map), and the model's Fea^m
  there (the dish's heatmap before the free-stop rule: the robot stands there already,
  so whether a stop *sent* there would collide is no longer the question);
- `correction`: where to move instead: among the heatmap cells within
  `execution.correction_radius` of the believed position that are free stops (Fea^m > 0
  in the plan's heatmaps, `feasibility/stops.py`) and whose centre passes the same test,
  facing the dish, and that the base can drive off from again on the plan's navigation
  map, those of (nearly) the highest Fea^m, and of these the one the base reaches soonest
  by the navigator's motion (turn, drive, turn). The corrective drive lands with the
  navigation noise like any other, which is what Fea^m, an expectation over it, rates.

The oracle is built on first use for each KnownWorld (about a second: the known world's
plant and collision checker), and only when the robot has to judge a stop.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from s3o_drake.angles import facing_yaw
from s3o_drake.feasibility.heatmaps import make_oracle
from s3o_drake.feasibility.oracle import FeasibilityOracle, Heatmap
from s3o_drake.known_world import KnownWorld
from s3o_drake.planning.base_motion import BaseProfile
from s3o_drake.planning.navigation import NavigationMap
from s3o_drake.scenario import Uncertainty

#: Stream tag of the localisation noise in `numpy.random.default_rng([seed, tag, command
#: id])`: its own numbers, apart from the landing's (1) and the reach's (2).
LOCALIZATION_STREAM = 3
#: A corrective move shorter than this (m) is not worth a drive: the stop stays.
MIN_CORRECTION = 0.02
#: Stops within this much of the best Fea^m nearby are as good: the quickest to reach wins.
CORRECTION_SLACK = 0.02


def localise(pose: np.ndarray, *, uncertainty: Uncertainty, seed: int, command_id: int,
             noise: bool = True) -> np.ndarray:
    """The robot's belief (x, y, yaw) of where it stands after command `command_id` landed
    at the true `pose`: the pose plus the localisation noise (none with `noise` off)."""
    pose = np.asarray(pose, dtype=float)[:3]
    if not noise:
        return pose.copy()
    rng = np.random.default_rng([seed, LOCALIZATION_STREAM, command_id])
    return pose + rng.normal(0.0, 1.0, 3) * [uncertainty.localization_xy_std,
                                             uncertainty.localization_xy_std,
                                             uncertainty.localization_yaw_std]


@dataclass(frozen=True)
class Assessment:
    """The stop check's verdict from a believed position: `feasible` (the pickup test
    passes, facing the dish) and the plan's `feasibility` (Fea^m) there."""

    feasible: bool
    feasibility: float

    def acceptable(self, threshold: float) -> bool:
        return self.feasible and self.feasibility >= threshold


class StopCheck:
    """Judges and corrects stops on one KnownWorld with its plan's heatmaps (see the module)."""

    def __init__(self, known: KnownWorld, heatmaps: tuple[Heatmap, ...],
                 navigation: NavigationMap | None = None, *,
                 model_heatmaps: tuple[Heatmap, ...] = ()):
        """`heatmaps`: the plan's (corrective stops are chosen on them); `model_heatmaps`:
        the same before the free-stop rule (rating where the robot stands; default
        `heatmaps`)."""
        self._known = known
        self._navigation = navigation
        self._profile = BaseProfile(speed=known.planner.speed)
        self._heatmaps = {h.dish: h for h in heatmaps}
        self._model = {h.dish: h for h in (model_heatmaps or heatmaps)}
        self._oracle: FeasibilityOracle | None = None
        self._dish_xy = {d.name: np.asarray(d.position, dtype=float) for d in known.dishes}

    @property
    def known(self) -> KnownWorld:
        return self._known

    def _success(self, positions: np.ndarray, dish: str) -> np.ndarray:
        if self._oracle is None:
            self._oracle = make_oracle(self._known.as_scenario(), obstacles=self._known.obstacles)
        positions = np.asarray(positions, dtype=float).reshape(-1, 2)
        poses = np.column_stack([positions, facing_yaw(positions, self._dish_xy[dish])])
        return self._oracle.success(poses, dish)

    def feasibility(self, position: np.ndarray, dish: str) -> float:
        """The model's Fea^m of `dish` from base position `position` (0 off its heatmap)."""
        heatmap = self._model.get(dish)
        return 0.0 if heatmap is None else heatmap.value_at(np.asarray(position, float)[:2])

    def assess(self, position: np.ndarray, dish: str) -> Assessment:
        """The verdict on picking `dish` from the believed `position` (x, y[, yaw])."""
        position = np.asarray(position, dtype=float)[:2]
        return Assessment(feasible=bool(self._success(position, dish)[0]),
                          feasibility=self.feasibility(position, dish))

    def correction(self, position: np.ndarray, dish: str, radius: float
                   ) -> tuple[np.ndarray, float] | None:
        """The best stop for `dish` within `radius` of the believed pose `position` (x, y,
        yaw), and its Fea^m: among the cells whose centre passes the pickup test, those
        within CORRECTION_SLACK of the highest Fea^m, the one the base reaches soonest
        (turns included: a move along its heading beats one across it); None when no cell
        there passes."""
        heatmap = self._heatmaps.get(dish)
        if heatmap is None or radius <= 0.0:
            return None
        here = np.asarray(position, dtype=float)
        centers = heatmap.centers().reshape(-1, 2)
        values = heatmap.values.ravel()
        distance = np.linalg.norm(centers - here[:2], axis=1)
        near = np.flatnonzero((distance <= radius) & (values > 0.0))
        if near.size and self._navigation is not None:
            # Only stops the base can drive off from again: a pocket it squeezed into by the
            # known map would trap it for the rest of the plan.
            near = near[self._navigation.drivable_from(centers[near])]
        if near.size == 0:
            return None
        passing = near[self._success(centers[near], dish)]
        if passing.size == 0:
            return None
        best = values[passing].max()
        good = passing[values[passing] >= best - CORRECTION_SLACK]
        yaw = float(here[2]) if here.size > 2 else 0.0
        dish_xy = self._dish_xy[dish]
        times = [self._profile.motion_time([here[:2], centers[i]], yaw,
                                           float(facing_yaw(centers[i], dish_xy)))
                 for i in good]
        chosen = good[int(np.argmin(times))]
        return centers[chosen].copy(), float(values[chosen])


def describe_move(start: np.ndarray, target: np.ndarray) -> str:
    """`moved 0.18 m to (3.42, 2.10)`: a corrective move, as the report says it."""
    length = math.dist(np.asarray(start)[:2], np.asarray(target)[:2])
    return f"moved {length:.2f} m to ({target[0]:.2f}, {target[1]:.2f})"
