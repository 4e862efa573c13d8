"""Localisation: the robot's estimate of its own base pose, as its localisation reports it.

A mobile base knows where it stands only from its localisation (a laser scan matched to the
map, fused with its odometry), and that is off by a few centimetres. The error does not jump
from one message to the next: it stays while the base stands, and changes as the base
travels and its localisation sees the room from elsewhere. Here it is a Gauss-Markov
process in the distance travelled: after a travel of s metres the error keeps
exp(-s / DRIFT_DISTANCE) of itself and draws the rest afresh, so that it is always
normal with the scenario's standard deviations (`localization_xy_std` per axis,
`localization_yaw_std`), and two errors DRIFT_DISTANCE apart are nearly independent. A turn
in place counts as travel, TURN_TRAVEL metres a radian.

The robot reports its pose with this error, and its base controller drives to the poses
it is commanded as it estimates them: where the controllers command the pose X, the base
comes to stand at X less the error. So controllers that act on the robot's reports see
the error only through what the robot's own sensors tell them. `drift` and `believed` are
the policy, in plain Python; `Localisation` is its adapter between the world's ports and the
plant's.
"""

import math
from dataclasses import dataclass

import numpy as np
from pydrake.systems.framework import BasicVector, Context, DiscreteValues, LeafSystem

from s3o_drake.world.system_lifetime import weak_callback

DRIFT_DISTANCE = 1.0
"""Travel (m) over which the localisation error keeps 1/e of itself: a scan-matching
localisation sees most of a room anew a metre away."""
TURN_TRAVEL = 0.5
"""Travel (m) a radian of turning counts for: a turn shows the scanner the room from
another side, as a drive does."""
MIN_TRAVEL = 0.005
"""Travel (m) below which the error stays: a base held at a stop moves a few millimetres
about it as the arm swings, and its localisation does not start over for that."""
DRIFT_STREAM = 6
"""The error's random stream: `numpy.random.default_rng([seed, DRIFT_STREAM, step])`, step 0
the error at the start, then one per update in which the base travelled."""


@dataclass(frozen=True)
class LocalisationError:
    """How far off the robot's localisation is: `xy_std` (m, per axis) and `yaw_std` (rad),
    the standard deviations of its error at any time; zeros: it reports the truth."""

    xy_std: float
    yaw_std: float

    def __post_init__(self) -> None:
        for name in ("xy_std", "yaw_std"):
            if not getattr(self, name) >= 0.0:
                raise ValueError(f"{name}: expected a standard deviation >= 0, "
                                 f"got {getattr(self, name)}")

    @property
    def std(self) -> np.ndarray:
        return np.array([self.xy_std, self.xy_std, self.yaw_std])


def travel(before: np.ndarray, after: np.ndarray) -> float:
    """How far (m) the base travelled from pose `before` to `after` (x, y, yaw), its turn
    counted at TURN_TRAVEL a radian."""
    dx, dy = after[0] - before[0], after[1] - before[1]
    return math.hypot(dx, dy) + TURN_TRAVEL * abs(after[2] - before[2])


def initial_error(error: LocalisationError, *, seed: int) -> np.ndarray:
    """The error (dx, dy, dyaw) at the start of a run seeded `seed`."""
    rng = np.random.default_rng([seed, DRIFT_STREAM, 0])
    return rng.normal(0.0, 1.0, 3) * error.std


def drift(e: np.ndarray, *, error: LocalisationError, travelled: float, seed: int,
          step: int) -> np.ndarray:
    """The error after the base travelled `travelled` m with error `e`: it keeps
    exp(-travelled / DRIFT_DISTANCE) of itself, and draws the rest from stream `step` of
    `seed`, so that it keeps its standard deviations."""
    keep = math.exp(-travelled / DRIFT_DISTANCE)
    rng = np.random.default_rng([seed, DRIFT_STREAM, step])
    fresh = rng.normal(0.0, 1.0, 3) * error.std
    return keep * np.asarray(e, dtype=float) + math.sqrt(1.0 - keep * keep) * fresh


def believed(X_WB: np.ndarray, e: np.ndarray) -> np.ndarray:
    """Where the robot believes it stands (x, y, yaw) when it stands at `X_WB` with error
    `e`."""
    return np.asarray(X_WB, dtype=float)[:3] + e


def true_goal(X_WG: np.ndarray, e: np.ndarray) -> np.ndarray:
    """Where a base whose localisation is off by `e` comes to stand when commanded to the
    pose `X_WG` (x, y, yaw): it drives until it believes it stands there."""
    return np.asarray(X_WG, dtype=float)[:3] - e


def sighting_as_believed(p_WT: np.ndarray, *, X_WB: np.ndarray,
                         e: np.ndarray) -> np.ndarray:
    """Where in the world the robot places a point it sees at the true `p_WT` (x, y) from
    its base at the true `X_WB`: its sensor sees the point in the base's frame, and the
    robot puts that frame where it believes the base stands."""
    X_WB = np.asarray(X_WB, dtype=float)
    c, s = math.cos(X_WB[2]), math.sin(X_WB[2])
    d = np.asarray(p_WT, dtype=float)[:2] - X_WB[:2]
    p_BT = np.array([c * d[0] + s * d[1], -s * d[0] + c * d[1]])
    B = believed(X_WB, e)
    c, s = math.cos(B[2]), math.sin(B[2])
    return B[:2] + np.array([c * p_BT[0] - s * p_BT[1], s * p_BT[0] + c * p_BT[1]])


class Localisation(LeafSystem):
    """The robot's localisation between its controllers and its plant (module docstring):
    reports the base pose with the error, and drives the base to its commanded poses as
    estimated.

    `num_positions` of the robot's, the first `num_base` the base's (x, y, yaw); `error`
    and `seed` set the error; every `period` s the error drifts by the travel since.

    Input ports:
        true_state: vector (2 num_positions), the plant's positions then velocities.
        desired_state: vector (2 num_positions), the commanded state, its base pose as
            the robot believes it.
    Output ports:
        reported_state: vector (2 num_positions), the true state with the base pose as the
            localisation reports it.
        plant_desired_state: vector (2 num_positions), the desired state with the base pose
            where the base really comes to stand.
        error: vector (3), the localisation's error (dx, dy, dyaw): the simulation's, not
            for the controllers.
    """

    def __init__(self, *, num_positions: int, num_base: int, error: LocalisationError,
                 seed: int, period: float) -> None:
        super().__init__()
        if num_base != 3:
            raise ValueError(f"num_base: expected a planar base of 3 positions, got {num_base}")
        self._n = int(num_positions)
        self._error = error
        self._seed = int(seed)
        self._true = self.DeclareVectorInputPort("true_state", 2 * self._n)
        self._desired = self.DeclareVectorInputPort("desired_state", 2 * self._n)
        # [error (3), the base pose it was last updated at (3), the draws so far (1)]
        self._state = self.DeclareDiscreteState(7)
        self.DeclareVectorOutputPort("reported_state", 2 * self._n,
                                     weak_callback(self._calc_reported),
                                     prerequisites_of_calc={self._true.ticket(),
                                                            self.xd_ticket()})
        self.DeclareVectorOutputPort("plant_desired_state", 2 * self._n,
                                     weak_callback(self._calc_plant_desired),
                                     prerequisites_of_calc={self._desired.ticket(),
                                                            self.xd_ticket()})
        self.DeclareVectorOutputPort("error", 3, weak_callback(self._calc_error),
                                     prerequisites_of_calc={self.xd_ticket()})
        self.DeclareInitializationDiscreteUpdateEvent(weak_callback(self._start))
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, weak_callback(self._update))

    def _start(self, context: Context, state: DiscreteValues) -> None:
        pose = self._true.Eval(context)[:3]
        state.set_value(self._state, np.concatenate(
            [initial_error(self._error, seed=self._seed), pose, [0.0]]))

    def _update(self, context: Context, state: DiscreteValues) -> None:
        x = context.get_discrete_state(self._state).get_value()
        pose = self._true.Eval(context)[:3]
        travelled = travel(x[3:6], pose)
        if travelled < MIN_TRAVEL:
            return
        step = int(x[6]) + 1
        e = drift(x[:3], error=self._error, travelled=travelled, seed=self._seed, step=step)
        state.set_value(self._state, np.concatenate([e, pose, [step]]))

    def _e(self, context: Context) -> np.ndarray:
        return context.get_discrete_state(self._state).get_value()[:3]

    def _calc_reported(self, context: Context, output: BasicVector) -> None:
        x = self._true.Eval(context).copy()
        x[:3] = believed(x[:3], self._e(context))
        output.SetFromVector(x)

    def _calc_plant_desired(self, context: Context, output: BasicVector) -> None:
        x = self._desired.Eval(context).copy()
        x[:3] = true_goal(x[:3], self._e(context))
        output.SetFromVector(x)

    def _calc_error(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(self._e(context))
