"""ProtectiveStop: in the simulated world, a base commanded into a chair stops short of it and
says so on `base_bumper`; commanded away, it drives again."""

import dataclasses

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import TrajectorySource
from pydrake.trajectories import PiecewisePolynomial

from s3o_drake.execution.escape import BaseSegment
from s3o_drake.planning.navigation.base_motion import YAW_ACCELERATION, YAW_RATE
from s3o_drake.world.builder import build_world_diagram, robot_hold_state
from s3o_drake.world.clearance_monitor import proximity_geometries
from s3o_drake.world.map import Chair
from s3o_drake.world.protective_stop import PROTECTIVE_FIELD

V = 0.4  # m/s, the planner's default speed


def _drive(scenario, xs, times):
    """The world with the base commanded along x (`xs` at `times`, y and yaw held), exact
    localisation; the simulator, advanced to the last time, and the world."""
    start = scenario.robot.start
    return _command(scenario, [(x, start[1], start[2]) for x in xs], times)


def _command(scenario, poses, times):
    """The world with the base commanded through `poses` (x, y, yaw) at `times`, exact
    localisation; the simulator and the world."""
    hold = robot_hold_state(scenario)
    n = len(hold) // 2
    states = []
    for i, pose in enumerate(poses):
        state = hold.copy()
        state[:3] = pose
        if i + 1 < len(poses):
            state[n:n + 3] = (np.subtract(poses[i + 1], pose)) / (times[i + 1] - times[i])
        states.append(state)
    builder = DiagramBuilder()
    world = builder.AddNamedSystem("world", build_world_diagram(scenario, noise=False))
    source = builder.AddSystem(TrajectorySource(PiecewisePolynomial.ZeroOrderHold(
        list(times), np.column_stack(states))))
    builder.Connect(source.get_output_port(), world.GetInputPort("robot_desired_state"))
    simulator = Simulator(builder.Build())
    return simulator, world


def _closest(scenario, simulator, world, chair: str, times) -> list[float]:
    """The robot's distance (m) to `chair` at each of `times`, advancing `simulator`."""
    context = world.GetMyContextFromRoot(simulator.get_context())
    plant, scene_graph = world.GetSubsystemByName("plant"), world.GetSubsystemByName("scene_graph")
    robot = proximity_geometries(plant, scene_graph,
                                 scenario.robot_value.instances_in(plant).instances)
    seat = proximity_geometries(plant, scene_graph, [plant.GetModelInstanceByName(chair)])
    closest = []
    for t in times:
        simulator.AdvanceTo(t)
        query = world.GetOutputPort("query_object").Eval(context)
        closest.append(min(query.ComputeSignedDistancePairClosestPoints(a, b).distance
                           for a in robot for b in seat))
    return closest


def test_a_base_driven_into_a_chair_stops_short_and_reports_it_then_backs_away(scenario):
    """A chair 1.2 m ahead of the base, on no map: commanded straight through it at 0.4 m/s,
    the base stops clear of it, the bumper says where; commanded back, it backs away."""
    start = (0.6, 1.0, 0.0)
    chair = Chair(name="chair_ahead", pose=[1.8, 1.0, 0.0], mapped=False)
    world_scenario = dataclasses.replace(
        scenario, chairs=[chair],
        robot=dataclasses.replace(scenario.robot, start=list(start)))
    times = np.arange(0.0, 6.01, 0.01)
    xs = np.minimum(start[0] + V * times, 2.6)  # through the chair, to its far side
    back = times >= 5.0
    xs[back] = 1.3 - V * (times[back] - 5.0)  # then back, from behind where it stopped
    simulator, world = _drive(world_scenario, xs, times)
    context = world.GetMyContextFromRoot(simulator.get_context())
    closest = _closest(scenario, simulator, world, "chair_ahead", np.arange(0.5, 4.95, 0.05))
    assert min(closest) > 0.0  # never touched
    bumper = world.GetOutputPort("base_bumper").Eval(context)
    stopped_x = float(world.GetOutputPort("robot_state").Eval(context)[0])
    assert bumper[0] == 1.0
    assert bumper[1] == pytest.approx(1.8 - 0.25, abs=0.1) and bumper[2] == pytest.approx(
        1.0, abs=0.3)  # the chair's near side
    assert stopped_x < 1.8 - 0.3  # well short of the chair's centre
    simulator.AdvanceTo(6.0)
    assert world.GetOutputPort("base_bumper").Eval(context)[0] == 0.0  # backing away
    assert float(world.GetOutputPort("robot_state").Eval(context)[0]) < stopped_x - 0.1


def test_a_base_turned_into_a_chair_stops_short(scenario):
    """A chair on no map beside the base; the base turns in place at the navigator's rate
    and acceleration, its corner into the chair's leg. The stop looks ahead along the
    turn: the base stops clear of the leg (judged at the commanded yaw alone, it touched
    it, -0.17 cm) and stays held."""
    start = (0.6, 1.0, 0.0)
    chair = Chair(name="chair_beside", pose=[0.6, 1.55, -np.pi / 2], mapped=False)
    world_scenario = dataclasses.replace(
        scenario, chairs=[chair],
        robot=dataclasses.replace(scenario.robot, start=list(start)))
    turn = BaseSegment.make(start, (*start[:2], 0.5), turn=True, length=0.5,
                            max_speed=YAW_RATE, accel=YAW_ACCELERATION)
    times = np.arange(0.0, 2.0, 0.01)
    simulator, world = _command(world_scenario, [turn.state(t)[:3] for t in times], times)
    closest = _closest(scenario, simulator, world, "chair_beside", times[1:])
    context = world.GetMyContextFromRoot(simulator.get_context())
    assert min(closest) > 0.0
    assert world.GetOutputPort("base_bumper").Eval(context)[0] == 1.0
    assert float(world.GetOutputPort("robot_state").Eval(context)[2]) < 0.4  # held short


def test_a_base_driven_clear_of_everything_is_not_stopped(scenario):
    times = np.arange(0.0, 3.01, 0.01)
    simulator, world = _drive(scenario, 0.6 + 0.25 * times, times)
    context = world.GetMyContextFromRoot(simulator.get_context())
    for t in np.arange(0.1, 3.5, 0.1):
        simulator.AdvanceTo(t)
        assert world.GetOutputPort("base_bumper").Eval(context)[0] == 0.0
    assert float(world.GetOutputPort("robot_state").Eval(context)[0]) > 1.3  # drove on
    assert PROTECTIVE_FIELD < 0.01  # inside the padding the controllers keep
