"""ProtectiveStop: the base's safety layer, which stops it short of what it would run into.

A mobile base carries a safety scanner or bumpers that stop it, whatever its controller
commands, before it runs into something; the robot then reports the stop. The controllers
check their motions in what the robot knows (its map and the chairs it perceived), and a
chair the camera missed is not in it. This system is that safety layer in the simulated
world: every `period` it measures, in the simulation's SceneGraph, the distance between the
robot's geometry (all but the hand's, which touches what it grasps) and the room's walls,
tables and chairs, and where the base's commanded motion would bring it within
PROTECTIVE_FIELD of one of them, moving towards it (its commanded travel LOOK_AHEAD ahead,
its turn its period and TURN_STOP_TIME ahead), it holds the base where it stands. It
judges the base's motion only: the arm's own motions are its controller's to check. It lets
go once the command no longer moves the base towards what stopped it.
"""

import math
from collections.abc import Iterable

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.geometry import GeometryId, QueryObject
from pydrake.systems.framework import BasicVector, Context, DiscreteValues, LeafSystem

from s3o_drake.world.clearance_monitor import NearPairs
from s3o_drake.world.system_lifetime import weak_callback

PROTECTIVE_FIELD = 0.002
"""How close (m) the base may come to the world while moving towards it: less than the
padding the controllers keep from what they know (1 cm), so that a motion planned clear of
the known world is never stopped by its own approach."""
LOOK_AHEAD = 0.1
"""How far ahead (s) of the commanded position the base's travel is judged: the plant's lag
behind its set point and the distance it takes to stop."""
TURN_STOP_TIME = 0.02
"""How long (s) the base takes to stop turning once held (from 0.8 rad/s: 0.03 s, most of the
angle in the first 0.02 s). A turn is judged this much and the watch's period ahead of the
commanded yaw. Shorter than LOOK_AHEAD: the corners of a turning base move across what they
pass, and a turn looked far ahead swings them into what its path clears by 1 cm."""
WATCH_PERIOD = 0.01
"""The watch's period (s), a safety scanner's cycle: between two watches the corners of a base
turning at 0.8 rad/s swing 4 mm. At 0.05 s they swung 1.8 cm, and a turn looked ahead far
enough to cover that held moving turns that pass a table by 1 cm."""
REST_OFFSET = 0.01
"""A base commanded to stay (no velocity) within this (m, and rad for its yaw) of where it
stands is not judged: held there, it moves towards nothing its command does not, and the arm's
swings push it a few millimetres about its set point."""
_REACH = 0.1  # pairs further apart than this (m) cannot come within the field in LOOK_AHEAD


class ProtectiveStop(LeafSystem):
    """Holds the base where it stands when the commanded motion would run it into the
    world (module docstring).

    `base` and `world`: the robot's proximity geometries that the base carries (moved with
    it) and the room's; `num_positions` of the robot's, the first `num_base` the base's
    (x, y, yaw).

    Input ports:
        query_object: abstract QueryObject, the simulation's SceneGraph.
        desired_state: vector (2 num_positions, optional), the plant's desired state;
            unconnected: the robot holds where it stands.
        true_state: vector (2 num_positions), the robot's state as it is.
    Output ports:
        plant_desired_state: vector (the same): desired_state, or while stopped the base
            held where it stopped (its velocities zero).
        bumper: vector 3: 1 while stopped (else 0), then x, y (m) of the point of the world
            it stopped short of (NaN while not stopped).
    """

    def __init__(self, *, base: Iterable[GeometryId], world: Iterable[GeometryId],
                 num_positions: int, num_base: int, period: float) -> None:
        super().__init__()
        if period <= 0:
            raise ValueError(f"period: expected a positive period, got {period}")
        self._base = frozenset(base)
        self._near = NearPairs(robot=self._base, world=frozenset(world), reach=_REACH)
        self._n, self._b = num_positions, num_base
        self._turn_ahead = period + TURN_STOP_TIME
        self._query_port = self.DeclareAbstractInputPort(
            "query_object", AbstractValue.Make(QueryObject()))
        self._desired_port = self.DeclareVectorInputPort("desired_state", 2 * num_positions)
        self._true_port = self.DeclareVectorInputPort("true_state", 2 * num_positions)
        # Stopped (1/0), the pose held, the point stopped short of.
        self._stop = self.DeclareDiscreteState(
            np.concatenate([[0.0], np.zeros(num_base), [math.nan, math.nan]]))
        self.DeclareVectorOutputPort("plant_desired_state", 2 * num_positions,
                                     weak_callback(self._calc_plant_desired_state))
        self.DeclareVectorOutputPort("bumper", 3, weak_callback(self._calc_bumper),
                                     prerequisites_of_calc={self.xd_ticket()})
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, weak_callback(self._watch))

    def _watch(self, context: Context, state: DiscreteValues) -> None:
        if not self._desired_port.HasValue(context):
            return
        stop = np.array(context.get_discrete_state(self._stop).get_value())
        true = np.asarray(self._true_port.Eval(context))
        desired = np.asarray(self._desired_port.Eval(context))
        b, n = self._b, self._n
        if (stop[0] == 0.0 and not desired[n:n + b].any()
                and np.abs(desired[:b] - true[:b]).max() < REST_OFFSET):
            return
        ahead = desired[:b].copy()
        ahead[:2] += LOOK_AHEAD * desired[n:n + 2]
        ahead[2] += self._turn_ahead * desired[n + 2]
        hit = self._towards(self._query_port.Eval(context), true[:b], ahead)
        if hit is None:
            stop[0] = 0.0
            stop[1 + b:] = math.nan
        else:
            if stop[0] == 0.0:  # held where it stands when first stopped
                stop[1:1 + b] = true[:b]
            stop[0] = 1.0
            stop[1 + b:] = hit
        state.get_mutable_vector(self._stop).SetFromVector(stop)

    def _towards(self, query: QueryObject, here: np.ndarray, ahead: np.ndarray
                 ) -> np.ndarray | None:
        """The point (x, y) of the world that the base, moving from `here` to `ahead` (x,
        y, yaw), comes within PROTECTIVE_FIELD of, moving towards it; None for none."""
        turn = ahead[2] - here[2]
        c, s = math.cos(turn), math.sin(turn)
        closest, hit = math.inf, None
        for a, b in self._near.pairs(query):
            pair = query.ComputeSignedDistancePairClosestPoints(a, b)
            # The robot's closest point and the direction that takes it away from the world.
            if a in self._base:
                p_base = query.GetPoseInWorld(a) @ pair.p_ACa
                p_world = query.GetPoseInWorld(b) @ pair.p_BCb
                away = np.asarray(pair.nhat_BA_W)[:2]
            else:
                p_base = query.GetPoseInWorld(b) @ pair.p_BCb
                p_world = query.GetPoseInWorld(a) @ pair.p_ACa
                away = -np.asarray(pair.nhat_BA_W)[:2]
            r = p_base[:2] - here[:2]
            moved = ahead[:2] + np.array([c * r[0] - s * r[1], s * r[0] + c * r[1]])
            approach = float((moved - p_base[:2]) @ away)
            if approach < 0.0 and pair.distance + approach < PROTECTIVE_FIELD \
                    and pair.distance < closest:
                closest, hit = pair.distance, np.asarray(p_world[:2], dtype=float)
        return hit

    def _calc_plant_desired_state(self, context: Context, output: BasicVector) -> None:
        if not self._desired_port.HasValue(context):
            held = np.array(self._true_port.Eval(context), dtype=float)
            held[self._n:] = 0.0
            output.SetFromVector(held)
            return
        desired = np.array(self._desired_port.Eval(context), dtype=float)
        stop = context.get_discrete_state(self._stop).get_value()
        if stop[0] != 0.0:
            b, n = self._b, self._n
            desired[:b] = stop[1:1 + b]
            desired[n:n + b] = 0.0
        output.SetFromVector(desired)

    def _calc_bumper(self, context: Context, output: BasicVector) -> None:
        stop = context.get_discrete_state(self._stop).get_value()
        output.SetFromVector([stop[0], *stop[1 + self._b:]])
