"""The contact solver failing on a robot at rest is restarted; any other failure is reported."""

import numpy as np
import pytest
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph
from pydrake.multibody.tree import PrismaticJoint, SpatialInertia
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from s3o_drake.execution import execute as execute_module

END = 1.0


class _Flaky:
    """A Simulator that raises `error` once, at t = 0.5 s, and otherwise stops at END."""

    def __init__(self, simulator: Simulator, error: BaseException):
        self._simulator, self._error, self.initialized = simulator, error, 0

    def get_mutable_context(self):
        return self._simulator.get_mutable_context()

    def Initialize(self, params):
        self.initialized += 1
        return self._simulator.Initialize(params)

    def AdvanceTo(self, t):
        if self._error is not None:
            self._simulator.AdvanceTo(0.5)
            error, self._error = self._error, None
            raise error
        return self._simulator.AdvanceTo(min(t, END))


def _slider(speed: float):
    """A discrete plant of one body on a frictionless x slider, moving at `speed`."""
    builder = DiagramBuilder()
    plant, _ = AddMultibodyPlantSceneGraph(builder, time_step=0.01)
    body = plant.AddRigidBody("box", SpatialInertia.SolidBoxWithMass(1.0, 0.1, 0.1, 0.1))
    plant.AddJoint(PrismaticJoint("x", plant.world_frame(), body.body_frame(), [1, 0, 0]))
    plant.mutable_gravity_field().set_gravity_vector([0, 0, 0])
    plant.Finalize()
    simulator = Simulator(builder.Build())
    context = plant.GetMyMutableContextFromRoot(simulator.get_mutable_context())
    plant.SetVelocities(context, [speed])
    simulator.Initialize()
    return plant, simulator


SAP = RuntimeError("The SAP solver failed to converge at simulation time = 0.5.\nReasons...")


def test_a_solver_failure_at_rest_is_restarted_from_exactly_zero_velocity():
    plant, simulator = _slider(1e-12)
    flaky = _Flaky(simulator, SAP)
    failure, restarts = execute_module._simulate(flaky, plant)
    assert failure is None and restarts == 1 and flaky.initialized == 1
    context = simulator.get_context()
    assert context.get_time() == pytest.approx(END)
    assert np.array_equal(plant.GetVelocities(plant.GetMyContextFromRoot(context)), [0.0])


@pytest.mark.parametrize(("speed", "error"), [(0.3, SAP), (0.0, RuntimeError("other")),
                                              (0.0, SystemExit("Failure at ..."))])
def test_a_failure_in_motion_or_of_another_kind_ends_the_run_and_says_why(speed, error):
    plant, simulator = _slider(speed)
    failure, restarts = execute_module._simulate(_Flaky(simulator, error), plant)
    assert restarts == 0
    assert failure.startswith("the simulation failed at t = 0.50 s: ")
    assert str(error).splitlines()[0] in failure
