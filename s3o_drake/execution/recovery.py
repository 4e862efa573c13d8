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
  With `detour` (`execution.detour`), when no stop within the radius reaches the threshold
  (`execution.min_feasibility`), the same choice is made over the dish's whole heatmap,
  timed along the navigation map: the robot drives round to the dish's own best stop. A
  plan that merges dishes may stand where one of them is out of reach (S3O's utility can
  accept a pickup rated 0.2 to save a drive), and such a pickup, with nothing better
  nearby, mostly fails, each failure costing tries and a replan that may choose the same
  stop again.

The oracle is built on first use for each KnownWorld (about a second: the known world's
plant and collision checker), and only when the robot has to judge a stop.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from s3o_drake.belief.known_world import KnownWorld
from s3o_drake.execution.executive import Assessment
from s3o_drake.feasibility.oracle import Heatmap
from s3o_drake.feasibility.planning_scene import PlanningScene
from s3o_drake.planning.navigation.map import NavigationMap
from s3o_drake.planning.time_model import base_profile
from s3o_drake.world.angles import facing_yaw
from s3o_drake.world.choices import Localization
from s3o_drake.world.settings import Uncertainty

#: Stream tag of the localisation noise in `numpy.random.default_rng([seed, tag, command
#: id])`: its own numbers, apart from the landing's (1) and the reach's (2).
LOCALIZATION_STREAM = 3
#: Stops within this much of the best Fea^m nearby are as good: the quickest to reach wins.
CORRECTION_SLACK = 0.02
#: A detour tests the pickup on the heatmap's best cells this many at a time, best first,
#: and stops at the first batch with a cell that passes (the test costs a few ms a cell).
DETOUR_BATCH = 24


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


def localiser(*, uncertainty: Uncertainty, seed: int,
              noise: bool = True) -> Callable[[np.ndarray, int], np.ndarray]:
    """The robot's belief of where it stands, as a function of the pose the robot reports
    after command `command_id`: with `uncertainty.localization` "reported" the report
    itself (the robot's localisation already erred), else `localise`'s."""
    if uncertainty.localization == Localization.REPORTED:
        return lambda pose, command_id: np.asarray(pose, dtype=float)[:3].copy()
    return lambda pose, command_id: localise(pose, uncertainty=uncertainty, seed=seed,
                                             command_id=command_id, noise=noise)


class StopCheck:
    """Judges and corrects stops on one KnownWorld with its plan's heatmaps (see the module):
    the Executive's `StopChecker`."""

    def __init__(self, known: KnownWorld, heatmaps: tuple[Heatmap, ...],
                 navigation: NavigationMap | None = None, *,
                 model_heatmaps: tuple[Heatmap, ...] = (),
                 scene: PlanningScene | None = None):
        """`heatmaps`: the plan's (corrective stops are chosen on them); `model_heatmaps`:
        the same before the free-stop rule (rating where the robot stands; default
        `heatmaps`); `scene`: the plan's Drake scene of `known` (made when first needed if
        not given)."""
        self._known = known
        self._scene = scene
        self._navigation = navigation
        self._profile = base_profile(known.planner, known.settings.execution.motion,
                                     robot=known.robot)
        self._heatmaps = {h.dish: h for h in heatmaps}
        self._model = {h.dish: h for h in (model_heatmaps or heatmaps)}
        self._dish_xy = {d.name: np.asarray(d.position, dtype=float) for d in known.dishes}

    @property
    def known(self) -> KnownWorld:
        return self._known

    def _success(self, positions: np.ndarray, dish: str) -> np.ndarray:
        if self._scene is None:
            self._scene = PlanningScene(self._known)
        positions = np.asarray(positions, dtype=float).reshape(-1, 2)
        poses = np.column_stack([positions, facing_yaw(positions, self._dish_xy[dish])])
        return self._scene.oracle.success(poses, dish)

    def feasibility(self, position: np.ndarray, dish: str) -> float:
        """The model's Fea^m of `dish` from base position `position` (0 off its heatmap)."""
        heatmap = self._model.get(dish)
        return 0.0 if heatmap is None else heatmap.value_at(np.asarray(position, float)[:2])

    def assess(self, position: np.ndarray, dish: str) -> Assessment:
        """The verdict on picking `dish` from the believed `position` (x, y[, yaw])."""
        position = np.asarray(position, dtype=float)[:2]
        return Assessment(feasible=bool(self._success(position, dish)[0]),
                          feasibility=self.feasibility(position, dish))

    def correction(self, position: np.ndarray, dish: str, radius: float, *,
                   threshold: float = 0.0, detour: bool = False
                   ) -> tuple[np.ndarray, float] | None:
        """The best stop for `dish` within `radius` of the believed pose `position` (x, y,
        yaw), and its Fea^m: among the cells whose centre passes the pickup test, those
        within CORRECTION_SLACK of the highest Fea^m, the one the base reaches soonest
        (turns included: a move along its heading beats one across it); None when no cell
        there passes. With `detour`, when that stop's Fea^m is below `threshold` (or there
        is none), the best stop of the dish's whole heatmap with Fea^m >= `threshold`,
        chosen the same way, when the base can drive to one."""
        heatmap = self._heatmaps.get(dish)
        if heatmap is None:
            return None
        here = np.asarray(position, dtype=float)
        centers = heatmap.centers().reshape(-1, 2)
        values = heatmap.values.ravel()
        near = None
        verdicts: dict[int, bool] = {}
        if radius > 0.0:
            distance = np.linalg.norm(centers - here[:2], axis=1)
            cells = self._drivable(centers, np.flatnonzero((distance <= radius) & (values > 0)))
            passing = self._passing(centers, cells, dish, verdicts)
            if passing.size:
                near = self._soonest(here, dish, centers, values, passing, routed=False)
        if not detour or (near is not None and near[1] >= threshold):
            return near
        far = self._detour(here, dish, centers, values, max(threshold, 1e-9), verdicts)
        return far if far is not None else near

    def _passing(self, centers: np.ndarray, cells: np.ndarray, dish: str,
                 verdicts: dict[int, bool]) -> np.ndarray:
        """The `cells` whose centre passes the pickup test. `verdicts` keeps each cell's
        answer, so a detour does not test again the cells within the radius."""
        ask = np.asarray([c for c in cells.tolist() if c not in verdicts], dtype=int)
        if ask.size:
            verdicts.update(zip(ask.tolist(), self._success(centers[ask], dish).tolist(),
                                strict=True))
        return cells[np.asarray([verdicts[c] for c in cells.tolist()], dtype=bool)]

    def _drivable(self, centers: np.ndarray, cells: np.ndarray) -> np.ndarray:
        # Only stops the base can drive off from again: a pocket it squeezed into by the
        # known map would trap it for the rest of the plan.
        if cells.size and self._navigation is not None:
            cells = cells[self._navigation.drivable_from(centers[cells])]
        return cells

    def _detour(self, here: np.ndarray, dish: str, centers: np.ndarray, values: np.ndarray,
                threshold: float, verdicts: dict[int, bool]) -> tuple[np.ndarray, float] | None:
        """The best stop of the whole heatmap with Fea^m >= `threshold` that the base can
        drive to (see `correction`): cells tested best first, DETOUR_BATCH at a time."""
        cells = np.flatnonzero(values >= threshold)
        cells = cells[np.argsort(-values[cells], kind="stable")]
        if self._navigation is not None and cells.size:
            cells = self._drivable(centers, cells)
            cells = cells[self._navigation.reachable(here[:2], centers[cells])]
        passing: list[int] = []
        for start in range(0, cells.size, DETOUR_BATCH):
            batch = cells[start:start + DETOUR_BATCH]
            if passing and values[batch[0]] < values[passing[0]] - CORRECTION_SLACK:
                break
            passing.extend(self._passing(centers, batch, dish, verdicts).tolist())
        if not passing:
            return None
        return self._soonest(here, dish, centers, values, np.asarray(passing), routed=True)

    def _soonest(self, here: np.ndarray, dish: str, centers: np.ndarray, values: np.ndarray,
                 passing: np.ndarray, *, routed: bool) -> tuple[np.ndarray, float]:
        """Of the `passing` cells within CORRECTION_SLACK of their highest Fea^m, the one
        the base reaches soonest: straight (a short move), or along the navigation map
        (`routed`: a detour)."""
        best = values[passing].max()
        good = passing[values[passing] >= best - CORRECTION_SLACK]
        yaw = float(here[2]) if here.size > 2 else 0.0
        yaw_to = np.asarray(facing_yaw(centers[good], self._dish_xy[dish]), dtype=float)
        if routed and self._navigation is not None:
            _, times, _ = self._navigation.path_times(
                np.broadcast_to(here[:2], (good.size, 2)), centers[good],
                np.full(good.size, yaw), yaw_to, self._profile)
        else:
            times = [self._profile.motion_time([here[:2], centers[i]], yaw, float(t))
                     for i, t in zip(good, yaw_to, strict=True)]
        chosen = good[int(np.argmin(times))]
        return centers[chosen].copy(), float(values[chosen])

