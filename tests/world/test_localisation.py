"""Localisation: the robot reports its base pose off by an error that stays while it stands
and drifts as it travels, and drives to its commanded poses as it estimates them."""

import math

import numpy as np
import pytest
from pydrake.math import RigidTransform
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, Integrator

from s3o_drake.world.base_scanner import BaseScan
from s3o_drake.world.builder import build_world_diagram, robot_hold_state
from s3o_drake.world.dish_messages import DishPoses
from s3o_drake.world.localisation import (
    MIN_TRAVEL,
    ODOMETRY_XY_DRIFT,
    ODOMETRY_YAW_DRIFT,
    TURN_TRAVEL,
    Localisation,
    LocalisationError,
    believed,
    corrected,
    initial_error,
    odometry_drift,
    sighting_as_believed,
    travel,
    true_goal,
)
from s3o_drake.world.robot_messages import TargetRequest
from s3o_drake.world.scan_matching import RoomSection, range_points
from s3o_drake.world.scenario import parse_scenario, with_overrides
from s3o_drake.world.scenario_checks import ScenarioError
from s3o_drake.world.target_sensor import TargetSensor
from tests.world.test_scan_matching import BEARINGS, CHAIR, MAX_RANGE, ROOM, TABLES, TRUE
from tests.world.test_scan_matching import _scan as ray_cast

ERROR = LocalisationError(0.02, 0.02)
N = 4  # a base (x, y, yaw) and one arm joint


def test_odometry_walks_off_with_the_square_root_of_the_travel():
    starts = np.array([initial_error(ERROR, seed=s) for s in range(4000)])
    np.testing.assert_allclose(starts.std(axis=0), ERROR.std, rtol=0.05)
    for metres in (1.0, 4.0):
        walked = np.array([odometry_drift(np.zeros(3), error=ERROR, travelled=metres, seed=s,
                                          step=1) for s in range(4000)])
        np.testing.assert_allclose(walked.std(axis=0), math.sqrt(metres) * np.array(
            [ODOMETRY_XY_DRIFT, ODOMETRY_XY_DRIFT, ODOMETRY_YAW_DRIFT]), rtol=0.05)
    # The same seed and step, the same draw; an exact localisation, none.
    assert np.array_equal(odometry_drift(starts[0], error=ERROR, travelled=0.5, seed=0, step=1),
                          odometry_drift(starts[0], error=ERROR, travelled=0.5, seed=0, step=1))
    assert not odometry_drift(np.zeros(3), error=LocalisationError.exact(), travelled=3.0,
                              seed=0, step=1).any()
    assert LocalisationError.exact().is_exact and not ERROR.is_exact
    with pytest.raises(ValueError, match="xy_std"):
        LocalisationError(-0.01, 0.0)


def test_travel_counts_a_turn_in_place():
    assert travel(np.zeros(3), np.array([0.3, 0.4, 0.0])) == pytest.approx(0.5)
    assert travel(np.zeros(3), np.array([0.0, 0.0, -2.0])) == pytest.approx(2 * TURN_TRAVEL)


def test_a_base_driven_by_its_estimate_stands_where_the_estimate_is_off():
    e = np.array([0.02, -0.01, 0.03])
    X_WB = np.array([1.0, 2.0, 0.5])
    np.testing.assert_allclose(believed(true_goal(X_WB, e), e), X_WB)
    # What the base's sensor sees, placed from the base as believed: the base's own
    # estimate of a point at the base is that estimate, and a point 1 m ahead lies 1 m
    # ahead along the believed heading.
    np.testing.assert_allclose(sighting_as_believed(X_WB[:2], X_WB=X_WB, e=e),
                               believed(X_WB, e)[:2])
    ahead = X_WB[:2] + np.array([math.cos(0.5), math.sin(0.5)])
    B = believed(X_WB, e)
    np.testing.assert_allclose(sighting_as_believed(ahead, X_WB=X_WB, e=e),
                               B[:2] + np.array([math.cos(B[2]), math.sin(B[2])]))
    np.testing.assert_allclose(sighting_as_believed(ahead, X_WB=X_WB, e=np.zeros(3)), ahead)


def _system(error=ERROR, seed=5):
    return Localisation(num_positions=N, num_base=3, error=error, seed=seed, period=0.01)


def test_the_system_reports_the_error_and_drives_the_base_against_it():
    system = _system()
    context = system.CreateDefaultContext()
    true = np.array([1.0, 2.0, 0.5, 0.3, 0.1, 0.0, 0.0, 0.0])
    system.GetInputPort("true_state").FixValue(context, true)
    desired = np.array([1.5, 2.0, 0.0, 0.2, 0.0, 0.0, 0.0, 0.0])
    system.GetInputPort("desired_state").FixValue(context, desired)
    system.ExecuteInitializationEvents(context)
    e = initial_error(ERROR, seed=5)
    np.testing.assert_allclose(system.GetOutputPort("error").Eval(context), e)
    reported = system.GetOutputPort("reported_state").Eval(context)
    np.testing.assert_allclose(reported[:3], true[:3] + e)
    np.testing.assert_allclose(reported[3:], true[3:])  # the arm and the velocities
    plant = system.GetOutputPort("plant_desired_state").Eval(context)
    np.testing.assert_allclose(plant[:3], desired[:3] - e)
    np.testing.assert_allclose(plant[3:], desired[3:])
    with pytest.raises(ValueError, match="num_base"):
        Localisation(num_positions=N, num_base=2, error=ERROR, seed=0, period=0.01)


def _drive(speed):
    """The system in a short simulation, on a base that drives along x at `speed` m/s."""
    builder = DiagramBuilder()
    system = builder.AddSystem(_system())
    # The true state: the base's pose integrates its velocity.
    pose = builder.AddSystem(Integrator(2 * N))
    velocity = np.zeros(2 * N)
    velocity[0] = speed
    source = builder.AddSystem(ConstantVectorSource(velocity))
    builder.Connect(source.get_output_port(), pose.get_input_port())
    builder.Connect(pose.get_output_port(), system.GetInputPort("true_state"))
    builder.Connect(pose.get_output_port(), system.GetInputPort("desired_state"))
    diagram = builder.Build()
    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    errors = []
    for t in np.arange(0.0, 2.01, 0.25):
        simulator.AdvanceTo(t)
        errors.append(system.GetOutputPort("error").Eval(
            system.GetMyContextFromRoot(context)).copy())
    return np.array(errors)


def test_in_a_simulation_the_error_stays_at_rest_and_drifts_as_the_base_drives():
    at_rest = _drive(0.0)
    assert np.array_equal(at_rest, np.repeat(at_rest[:1], len(at_rest), axis=0))
    np.testing.assert_allclose(at_rest[0], initial_error(ERROR, seed=5))
    driving = _drive(0.5)
    steps = np.abs(np.diff(driving, axis=0)).max(axis=1)
    assert (steps > 0).all()  # every quarter second, 12.5 cm: odometry drifts
    # Slowly: over 12.5 cm, by a few millimetres.
    assert steps.max() < 4.0 * ODOMETRY_XY_DRIFT * math.sqrt(0.125)
    assert MIN_TRAVEL < 0.5 * 0.01 * 2  # the drive's travel over two periods counts


def test_the_sensor_places_what_it_sees_as_the_localisation_does():
    sensor = TargetSensor(places={}, seed=3, reach_std=0.0)
    context = sensor.CreateDefaultContext()
    sensor.GetInputPort("dish_poses").FixValue(
        context, DishPoses({"cup": RigidTransform([2.0, 2.0, 0.75])}))
    sensor.GetInputPort("target_request").FixValue(context, TargetRequest(1, "cup"))
    exact = sensor.GetOutputPort("target_sighting").Eval(context).p_WT
    assert exact == (2.0, 2.0)
    X_WB, e = np.array([1.4, 2.0, 0.0]), np.array([0.02, 0.0, 0.05])
    sensor.GetInputPort("base_pose").FixValue(context, X_WB)
    sensor.GetInputPort("localisation_error").FixValue(context, e)
    seen = sensor.GetOutputPort("target_sighting").Eval(context).p_WT
    np.testing.assert_allclose(seen, sighting_as_believed((2.0, 2.0), X_WB=X_WB, e=e))
    # An arm that reaches from the base as believed, to where it saw the cup, reaches the
    # cup: the sighting in the believed base frame is the cup in the true one.
    B = believed(X_WB, e)
    c, s = math.cos(B[2]), math.sin(B[2])
    d = np.asarray(seen) - B[:2]
    p_BT = [c * d[0] + s * d[1], -s * d[0] + c * d[1]]
    np.testing.assert_allclose(p_BT, [0.6, 0.0], atol=1e-12)


def test_in_the_world_the_robot_reports_its_localised_pose_and_drives_by_it(scenario):
    """The simulated world with `uncertainty.localization: reported`: robot_state's base
    pose is the true one off by the localisation's error, which a scan of the room matched
    to the map has brought to within millimetres of the truth, and a base commanded to
    hold the pose it reports stands still; the default world reports the truth."""
    reported = with_overrides(scenario, ["uncertainty.localization=reported"])
    world = build_world_diagram(reported, seed=3)
    plant, localisation = (world.GetSubsystemByName(n) for n in ("plant", "localisation"))
    simulator = Simulator(world)
    context = simulator.get_mutable_context()
    world.GetInputPort("robot_desired_state").FixValue(context, robot_hold_state(scenario))
    simulator.Initialize()
    error = localisation.GetOutputPort("error").Eval(localisation.GetMyContextFromRoot(context))
    drawn = initial_error(LocalisationError(reported.uncertainty.localization_xy_std,
                                            reported.uncertainty.localization_yaw_std), seed=3)
    assert np.abs(drawn[:2]).max() > 0.005  # what the scan corrected
    assert np.abs(error).max() < 0.002
    true_start = np.array(scenario.robot.start)
    hold = robot_hold_state(scenario)
    hold[:3] = true_start + error  # where it believes it stands
    world.GetInputPort("robot_desired_state").FixValue(context, hold)
    simulator.AdvanceTo(0.5)
    true = plant.GetPositions(plant.GetMyContextFromRoot(context))[:3]
    np.testing.assert_allclose(true, true_start, atol=1e-3)
    state = world.GetOutputPort("robot_state").Eval(context)
    now = localisation.GetOutputPort("error").Eval(localisation.GetMyContextFromRoot(context))
    np.testing.assert_allclose(state[:3], true + now, atol=1e-12)
    assert np.abs(now).max() < 0.002
    assert not build_world_diagram(scenario).HasSubsystemNamed("localisation")
    # Without noise the robot knows where it stands, exactly.
    exact = build_world_diagram(reported, noise=False)
    context = exact.CreateDefaultContext()
    exact.GetInputPort("robot_desired_state").FixValue(context, robot_hold_state(scenario))
    exact.ExecuteInitializationEvents(context)
    localisation = exact.GetSubsystemByName("localisation")
    assert not localisation.GetOutputPort("error").Eval(
        localisation.GetMyContextFromRoot(context)).any()


def test_an_unknown_localization_is_refused_by_name():
    assert parse_scenario("uncertainty: {localization: reported}").uncertainty.localization \
        == "reported"
    assert parse_scenario("").uncertainty.localization == "at_stops"  # the paper's
    with pytest.raises(ScenarioError, match=r"uncertainty\.localization.*at_stops, reported"):
        parse_scenario("uncertainty: {localization: amcl}")


def test_a_scan_matched_to_the_map_takes_the_error_down_to_the_match():
    section = RoomSection(ROOM, TABLES, [CHAIR])
    scan = BaseScan(tuple(map(tuple, range_points(ray_cast(TRUE, [CHAIR]), BEARINGS,
                                                  max_range=MAX_RANGE))))
    e = np.array([0.03, -0.02, 0.02])
    np.testing.assert_allclose(corrected(e, X_WB=TRUE, section=section, scan=scan), 0.0,
                               atol=1e-3)
    # A scan that sees too little leaves the estimate as odometry has it.
    assert np.array_equal(corrected(e, X_WB=TRUE, section=section, scan=BaseScan()), e)
