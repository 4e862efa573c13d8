"""TargetSensor: where the robot's sensor sees what the arm reaches for, off by the sensing
error drawn from the reach command's own stream."""

import numpy as np
import pytest
from pydrake.common.value import AbstractValue
from pydrake.math import RigidTransform
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantValueSource

from s3o_drake.world.dish_messages import DishPoses
from s3o_drake.world.robot_messages import REACH_STREAM, TargetRequest, TargetSighting
from s3o_drake.world.target_sensor import SensingError, TargetSensor

DISHES = DishPoses({"plate_a": RigidTransform([1.85, 2.3, 0.75]),
                    "cup_b": RigidTransform([2.15, 2.3, 0.75])})
PLACES = {"cup_b@place": (1.85, 2.3)}


def _sensor(reach_std=0.01, seed=3):
    sensor = TargetSensor(places=PLACES, seed=seed, reach_std=reach_std)
    context = sensor.CreateDefaultContext()
    sensor.GetInputPort("dish_poses").FixValue(context, DISHES)
    return sensor, context


def _ask(sensor, context, request):
    sensor.GetInputPort("target_request").FixValue(context, request)
    return (sensor.GetOutputPort("target_sighting").Eval(context),
            sensor.GetOutputPort("sensing_error").Eval(context))


def test_a_sighting_is_the_truth_plus_the_commands_own_draw():
    sensor, context = _sensor()
    sighting, error = _ask(sensor, context, TargetRequest(7, "plate_a"))
    draw = np.random.default_rng([3, REACH_STREAM, 7]).normal(0.0, 1.0, 2) * 0.01
    assert sighting.id == 7 and sighting.target == "plate_a"
    np.testing.assert_allclose(sighting.p_WT, np.array([1.85, 2.3]) + draw, atol=1e-15)
    assert error == SensingError(7, "plate_a", tuple(draw))
    assert sensor.error(7) == tuple(draw)
    # The same request, the same answer; another command, another draw.
    assert _ask(sensor, context, TargetRequest(7, "plate_a"))[0] == sighting
    assert _ask(sensor, context, TargetRequest(8, "plate_a"))[1].error != error.error
    # A place target is seen too; one it does not know is not.
    place, _ = _ask(sensor, context, TargetRequest(9, "cup_b@place"))
    np.testing.assert_allclose(place.p_WT, np.array([1.85, 2.3]) + sensor.error(9))
    assert _ask(sensor, context, TargetRequest(10, "teapot"))[0] == TargetSighting(
        10, "teapot", None)
    # Nothing asked, nothing seen.
    assert _ask(sensor, context, TargetRequest()) == (TargetSighting(), SensingError())


def test_without_noise_a_sighting_is_exact_and_has_no_error():
    sensor, context = _sensor(reach_std=0.0)
    sighting, error = _ask(sensor, context, TargetRequest(7, "cup_b"))
    assert sighting.p_WT == (2.15, 2.3) and error.error == (0.0, 0.0)
    assert sensor.error(7) is None
    with pytest.raises(ValueError, match="reach_std"):
        TargetSensor(places={}, seed=0, reach_std=-0.01)


def test_the_error_does_not_depend_on_where_the_target_is():
    # The object tracker reads the error, and its output is the dishes' poses: a
    # dependence would loop.
    sensor, _ = _sensor()
    error = sensor.GetOutputPort("sensing_error")
    assert not sensor.HasDirectFeedthrough(sensor.GetInputPort("dish_poses").get_index(),
                                           error.get_index())
    assert sensor.HasDirectFeedthrough(sensor.GetInputPort("target_request").get_index(),
                                       error.get_index())


def test_a_sensor_in_a_short_simulation_answers_the_request_it_is_given():
    builder = DiagramBuilder()
    sensor = builder.AddSystem(TargetSensor(places=PLACES, seed=1, reach_std=0.01))
    request = builder.AddSystem(ConstantValueSource(AbstractValue.Make(
        TargetRequest(4, "cup_b"))))
    dishes = builder.AddSystem(ConstantValueSource(AbstractValue.Make(DISHES)))
    builder.Connect(request.get_output_port(), sensor.GetInputPort("target_request"))
    builder.Connect(dishes.get_output_port(), sensor.GetInputPort("dish_poses"))
    diagram = builder.Build()
    simulator = Simulator(diagram)
    simulator.AdvanceTo(0.1)
    sighting = sensor.GetOutputPort("target_sighting").Eval(
        sensor.GetMyContextFromRoot(simulator.get_context()))
    np.testing.assert_allclose(sighting.p_WT, np.array([2.15, 2.3]) + sensor.error(4))
