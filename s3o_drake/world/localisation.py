"""Localisation: the robot's estimate of its own base pose, as its localisation reports it.

A mobile base knows where it stands only from its localisation: its odometry, which drifts
as it travels, corrected by its laser scanner's view of the room matched to its map, as a
scan-matching localisation (AMCL, for one) does on a real base. Here:

- at the start, the estimate is off by an error drawn with the scenario's standard
  deviations (`localization_xy_std` per axis, `localization_yaw_std`), until the first scan
  places it;
- as the base travels, odometry adds to the error: a random walk of ODOMETRY_XY_DRIFT and
  ODOMETRY_YAW_DRIFT per square root of a metre (a turn in place counts as TURN_TRAVEL
  metres a radian);
- every MATCH_TRAVEL of travel, and when the base comes to rest, the scan of the base's
  scanner (`base_scanner`) is matched to the map from the estimate
  (`scan_matching.match_scan`), and the estimate becomes the match. What is left of the
  error is the match's: the map's tables and mapped chairs, against a room that has
  unmapped chairs too.

The robot reports its pose with this error, and its base controller drives to the poses it
is commanded as it estimates them: where the controllers command the pose X, the base comes
to stand at X less the error. So controllers that act on the robot's reports see the error
only through what the robot's own sensors tell them. The functions are the policy, in plain
Python; `Localisation` is its adapter between the world's ports and the plant's.
"""

import math
from dataclasses import dataclass

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import BasicVector, Context, DiscreteValues, LeafSystem

from s3o_drake.world.base_scanner import BaseScan
from s3o_drake.world.scan_matching import RoomSection, match_scan
from s3o_drake.world.system_lifetime import weak_callback

ODOMETRY_XY_DRIFT = 0.01
"""How far (m per square root of a metre of travel, per axis) odometry's estimate walks off:
a centimetre over a metre, about the 1-2 % of a wheeled base's odometry."""
ODOMETRY_YAW_DRIFT = 0.01
"""The same for the heading (rad per square root of a metre)."""
TURN_TRAVEL = 0.5
"""Travel (m) a radian of turning counts for: a wheel of a base half a metre across rolls
about that far."""
MATCH_TRAVEL = 0.25
"""Travel (m) after which a scan corrects the estimate, and when the base comes to rest."""
MIN_TRAVEL = 0.005
"""Travel (m) below which the error stays: a base held at a stop moves a few millimetres
about it as the arm swings, and its localisation does not drift for that."""
REST_SPEED = 1e-3
"""Below this speed (m/s, and rad/s), the base is at rest."""
DRIFT_STREAM = 6
"""The error's random stream: `numpy.random.default_rng([seed, DRIFT_STREAM, step])`, step 0
the error at the start, then one per update in which the base travelled."""


@dataclass(frozen=True)
class LocalisationError:
    """How far off the robot's localisation is: `xy_std` (m, per axis) and `yaw_std` (rad),
    the standard deviations of its error at the start, before a scan places it; and its
    odometry's drift, `odometry_xy` (m) and `odometry_yaw` (rad) per square root of a metre
    of travel. Zeros: it reports the truth."""

    xy_std: float
    yaw_std: float
    odometry_xy: float = ODOMETRY_XY_DRIFT
    odometry_yaw: float = ODOMETRY_YAW_DRIFT

    def __post_init__(self) -> None:
        for name in ("xy_std", "yaw_std", "odometry_xy", "odometry_yaw"):
            if not getattr(self, name) >= 0.0:
                raise ValueError(f"{name}: expected a standard deviation >= 0, "
                                 f"got {getattr(self, name)}")

    @classmethod
    def exact(cls) -> "LocalisationError":
        """A localisation that reports the truth (the noise turned off)."""
        return cls(0.0, 0.0, 0.0, 0.0)

    @property
    def std(self) -> np.ndarray:
        return np.array([self.xy_std, self.xy_std, self.yaw_std])

    @property
    def is_exact(self) -> bool:
        """It reports the truth: no error to start with, no drift, nothing to correct."""
        return not (self.xy_std or self.yaw_std or self.odometry_xy or self.odometry_yaw)


def travel(before: np.ndarray, after: np.ndarray) -> float:
    """How far (m) the base travelled from pose `before` to `after` (x, y, yaw), its turn
    counted at TURN_TRAVEL a radian."""
    dx, dy = after[0] - before[0], after[1] - before[1]
    return math.hypot(dx, dy) + TURN_TRAVEL * abs(after[2] - before[2])


def initial_error(error: LocalisationError, *, seed: int) -> np.ndarray:
    """The error (dx, dy, dyaw) at the start of a run seeded `seed`."""
    rng = np.random.default_rng([seed, DRIFT_STREAM, 0])
    return rng.normal(0.0, 1.0, 3) * error.std


def odometry_drift(e: np.ndarray, *, error: LocalisationError, travelled: float, seed: int,
                   step: int) -> np.ndarray:
    """The error after the base travelled `travelled` m with error `e`: odometry's random
    walk (`error`'s drift), drawn from stream `step` of `seed`."""
    rng = np.random.default_rng([seed, DRIFT_STREAM, step])
    walk = rng.normal(0.0, 1.0, 3) * [error.odometry_xy, error.odometry_xy, error.odometry_yaw]
    return np.asarray(e, dtype=float) + math.sqrt(travelled) * walk


def corrected(e: np.ndarray, *, X_WB: np.ndarray, section: RoomSection,
              scan: BaseScan) -> np.ndarray:
    """The error once `scan`, seen from the base at the true `X_WB`, is matched to the map
    `section` from the estimate X_WB + `e`; `e` where the match finds no pose."""
    found = match_scan(section, np.array(scan.points_B).reshape(-1, 2),
                       prior=np.asarray(X_WB, dtype=float)[:3] + e)
    return np.asarray(e, dtype=float) if found is None else found.X_WB - X_WB[:3]


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
    reports the base pose with its error, and drives the base to its commanded poses as
    estimated.

    `num_positions` of the robot's, the first `num_base` the base's (x, y, yaw); `error`
    the error at the start and `seed` its draws; `section` the robot's map at its scanner's
    height (None: no scan corrects the estimate). Every `period` s the error drifts by the
    travel since, and a scan corrects it when due.

    Input ports:
        true_state: vector (2 num_positions), the plant's positions then velocities.
        desired_state: vector (2 num_positions), the commanded state, its base pose as the
            robot believes it.
        base_scan: abstract BaseScan, the base's scanner's returns (read when a match is
            due; unconnected: none).
    Output ports:
        reported_state: vector (2 num_positions), the true state with the base pose as the
            localisation reports it.
        plant_desired_state: vector (2 num_positions), the desired state with the base pose
            where the base really comes to stand.
        error: vector (3), the localisation's error (dx, dy, dyaw): the simulation's, not
            for the controllers.
    """

    def __init__(self, *, num_positions: int, num_base: int, error: LocalisationError,
                 seed: int, period: float, section: RoomSection | None = None) -> None:
        super().__init__()
        if num_base != 3:
            raise ValueError(f"num_base: expected a planar base of 3 positions, got {num_base}")
        self._n = int(num_positions)
        self._error = error
        self._seed = int(seed)
        self._section = section
        self._true = self.DeclareVectorInputPort("true_state", 2 * self._n)
        self._desired = self.DeclareVectorInputPort("desired_state", 2 * self._n)
        self._scan = self.DeclareAbstractInputPort("base_scan", AbstractValue.Make(BaseScan()))
        # [error (3), the base pose it was last updated at (3), the draws so far (1),
        #  the travel since the last match (1)]
        self._state = self.DeclareDiscreteState(8)
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

    def _corrected(self, context: Context, e: np.ndarray, pose: np.ndarray) -> np.ndarray:
        # An exact localisation stays exact: a match would leave its own sub-millimetre.
        if self._section is None or self._error.is_exact or not self._scan.HasValue(context):
            return e
        return corrected(e, X_WB=pose, section=self._section, scan=self._scan.Eval(context))

    def _start(self, context: Context, state: DiscreteValues) -> None:
        pose = self._true.Eval(context)[:3]
        e = self._corrected(context, initial_error(self._error, seed=self._seed), pose)
        state.set_value(self._state, np.concatenate([e, pose, [0.0, 0.0]]))

    def _update(self, context: Context, state: DiscreteValues) -> None:
        x = context.get_discrete_state(self._state).get_value().copy()
        true = self._true.Eval(context)
        pose = true[:3]
        travelled = travel(x[3:6], pose)
        if travelled >= MIN_TRAVEL:
            x[6] += 1
            x[:3] = odometry_drift(x[:3], error=self._error, travelled=travelled,
                                   seed=self._seed, step=int(x[6]))
            x[3:6] = pose
            x[7] += travelled
        at_rest = np.abs(true[self._n:self._n + 3]).max() < REST_SPEED
        if x[7] >= MATCH_TRAVEL or (x[7] > 0.0 and at_rest):
            x[:3] = self._corrected(context, x[:3], pose)
            x[7] = 0.0
        state.set_value(self._state, x)

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
