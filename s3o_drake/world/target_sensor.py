"""TargetSensor: where the robot's sensors see what the arm reaches for.

A robot finds the dish it picks, or the spot it puts an object down at, with a sensor near
its hand, and sees it off by that sensor's error. This system is that sensor in the
simulated world: asked for a target (`TargetRequest`), it answers with the target's true
position plus the sensing error T^m, `reach_std` per axis, drawn from the reach command's
own stream (`robot_messages.REACH_STREAM`): a seed fixes each sighting, whatever ran before.

The sensor sees the target from the robot's base: where the robot's localisation is off
(`localisation_error` connected), it places what it sees where that error puts it
(`localisation.sighting_as_believed`), so that an arm that reaches from the base as
localised reaches the target as sensed.

The error belongs to the simulation. The controllers see only the sighting; the grasp
rules (`ObjectTracker`: whether the fingers catch the dish) and the run's referee (the
report's pickups, for the calibration of Fea^m) read the error itself (`error`).
"""

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import Context, LeafSystem

from s3o_drake.world.dish_messages import DishPoses
from s3o_drake.world.localisation import sighting_as_believed
from s3o_drake.world.robot_messages import REACH_STREAM, TargetRequest, TargetSighting
from s3o_drake.world.system_lifetime import weak_callback


@dataclass(frozen=True)
class SensingError:
    """The error of the sighting of `target` for request `id`: (dx, dy) m, the sighting
    minus where the target really is; `target` "" while nothing is asked."""

    id: int = 0
    target: str = ""
    error: tuple[float, float] = (0.0, 0.0)


def sensing_error(*, seed: int, reach_std: float, request: int) -> tuple[float, float]:
    """The sensing error (dx, dy) m of request `request` of a run seeded `seed`: normal, of
    `reach_std` per axis (zeros with `reach_std` 0)."""
    rng = np.random.default_rng([seed, REACH_STREAM, request])
    dx, dy = rng.normal(0.0, 1.0, 2) * reach_std
    return float(dx), float(dy)


class TargetSensor(LeafSystem):
    """Answers the arm's requests for where its target is, with the sensing error.

    `places`: the place targets' true positions (x, y), by target name; the dishes' come
    from `dish_poses`. `seed` and `reach_std` (m; 0: exact sightings) set the error.

    Input ports:
        target_request: abstract TargetRequest.
        dish_poses: abstract DishPoses, X_WD of each dish where it really is.
        base_pose: vector (3, optional with the next), X_WB (x, y, yaw) where the base
            really stands.
        localisation_error: vector (3, optional: unconnected, the localisation is exact),
            the error of the robot's localisation (`Localisation`'s).
    Output ports:
        target_sighting: abstract TargetSighting, the answer to the request: where the
            sensor sees the target (None for a target it does not know).
        sensing_error: abstract SensingError, the error of that sighting (the
            simulation's, not for the controllers).
    """

    def __init__(self, *, places: Mapping[str, tuple[float, float]], seed: int,
                 reach_std: float) -> None:
        super().__init__()
        if reach_std < 0:
            raise ValueError(f"reach_std: expected a standard deviation >= 0, got {reach_std}")
        self._places = {name: (float(x), float(y)) for name, (x, y) in places.items()}
        self._seed = int(seed)
        self._reach_std = float(reach_std)
        self._request_port = self.DeclareAbstractInputPort(
            "target_request", AbstractValue.Make(TargetRequest()))
        self._dish_poses_port = self.DeclareAbstractInputPort(
            "dish_poses", AbstractValue.Make(DishPoses()))
        self._base_pose_port = self.DeclareVectorInputPort("base_pose", 3)
        self._localisation_port = self.DeclareVectorInputPort("localisation_error", 3)
        self.DeclareAbstractOutputPort(
            "target_sighting", lambda: AbstractValue.Make(TargetSighting()),
            weak_callback(self._calc_sighting))
        # The error is the request's alone (not where the target is): the object tracker
        # reads it, and what the tracker outputs, the target's pose, must not loop back.
        self.DeclareAbstractOutputPort(
            "sensing_error", lambda: AbstractValue.Make(SensingError()),
            weak_callback(self._calc_error),
            prerequisites_of_calc={self._request_port.ticket()})

    def error(self, request: int) -> tuple[float, float] | None:
        """The error of request `request`'s sighting (None with exact sightings)."""
        if self._reach_std == 0:
            return None
        return sensing_error(seed=self._seed, reach_std=self._reach_std, request=request)

    def _request(self, context: Context) -> TargetRequest:
        if not self._request_port.HasValue(context):
            return TargetRequest()
        return self._request_port.Eval(context)

    def _true_position(self, context: Context, target: str) -> np.ndarray | None:
        if target in self._places:
            return np.array(self._places[target])
        poses: DishPoses = self._dish_poses_port.Eval(context)
        X_WD = poses.get(target)
        return None if X_WD is None else np.asarray(X_WD.translation()[:2], dtype=float)

    def _calc_sighting(self, context: Context, output: AbstractValue) -> None:
        request = self._request(context)
        p_WT = self._true_position(context, request.target) if request.target else None
        if p_WT is not None:
            error = self.error(request.id)
            if error is not None:
                p_WT = p_WT + error
            if self._localisation_port.HasValue(context):
                p_WT = sighting_as_believed(p_WT, X_WB=self._base_pose_port.Eval(context),
                                            e=self._localisation_port.Eval(context))
        output.set_value(TargetSighting(request.id, request.target,
                                        None if p_WT is None else (float(p_WT[0]),
                                                                   float(p_WT[1]))))

    def _calc_error(self, context: Context, output: AbstractValue) -> None:
        request = self._request(context)
        error = self.error(request.id) if request.target else None
        output.set_value(SensingError(request.id, request.target,
                                      (0.0, 0.0) if error is None else error))
