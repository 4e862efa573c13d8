"""The simulated robot on an LCM bus (memq://): it publishes its state, obeys the commands
that come, and holds where it stands before the first and when they stop."""

import numpy as np
import pytest
from pydrake.lcm import DrakeLcm
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.lcm import LcmInterfaceSystem

from s3o_drake.world import robot_channels as ch
from s3o_drake.world.builder import build_world_diagram
from s3o_drake.world.lcmtypes.s3o_lcm import robot_state_t
from s3o_drake.world.robot_lcm import (
    COMMAND_FRESH,
    COMMAND_TIMEOUT,
    CommandWatchdog,
    add_robot_lcm,
)


class _Bus:
    """The simulated robot on a memq bus, and what it published on ROBOT_STATE."""

    def __init__(self, scenario):
        self.lcm = DrakeLcm("memq://")
        builder = DiagramBuilder()
        interface = builder.AddSystem(LcmInterfaceSystem(self.lcm))
        world = builder.AddNamedSystem("world", build_world_diagram(scenario, track_dishes=True,
                                                                    noise=False))
        self.robot = scenario.robot_value
        add_robot_lcm(builder, world, robot=self.robot, lcm=interface)
        self.simulator = Simulator(builder.Build())
        self.states: list[robot_state_t] = []
        self.lcm.Subscribe(ch.ROBOT_STATE,
                           lambda data: self.states.append(robot_state_t.decode(data)))

    def command(self, positions, t):
        n = self.robot.num_positions
        desired = np.concatenate([positions, np.zeros(n)])
        self.lcm.Publish(ch.ROBOT_COMMAND, ch.command_message(
            desired, joints=self.robot.joints, t=t).encode())

    def advance(self, t):
        self.simulator.AdvanceTo(t)
        self.lcm.HandleSubscriptions(0)

    def positions(self):
        return ch.positions_of(self.states[-1], joints=self.robot.joints)


def test_the_robot_publishes_its_state_and_obeys_commands_while_they_come(scenario):
    bus = _Bus(scenario)
    start = np.asarray(scenario.robot.start, dtype=float)
    bus.advance(0.5)  # no command yet: it holds where it stands
    assert bus.states and bus.states[-1].utime == ch.utime(0.5)
    np.testing.assert_allclose(bus.positions()[:3], start, atol=1e-4)
    goal = bus.positions().copy()
    goal[0] += 0.2
    for t in np.arange(0.5, 2.5, 0.1):  # a controller commanding every 0.1 s
        bus.command(goal, t)
        bus.advance(t + 0.1)
    np.testing.assert_allclose(bus.positions()[:3], goal[:3], atol=2e-3)


def test_the_robot_holds_where_it_stands_when_commands_stop(scenario):
    bus = _Bus(scenario)
    bus.advance(0.1)
    far = bus.positions().copy()
    far[0] += 1.0
    bus.command(far, 0.1)  # one command, then silence
    bus.advance(0.1 + COMMAND_TIMEOUT + 1.5)  # came to rest
    held = bus.positions()[0]
    bus.advance(0.1 + COMMAND_TIMEOUT + 3.0)
    assert bus.positions()[0] == pytest.approx(held, abs=1e-3)  # stopped
    assert held < far[0] - 0.1  # short of the stale command's goal


def test_the_watchdog_alone(scenario):
    """A command is fresh for COMMAND_TIMEOUT after it came, whatever its stamp says: the
    controllers' clock need not be the robot's."""
    n = scenario.robot_value.num_positions
    watchdog = CommandWatchdog(num_positions=n)
    simulator = Simulator(watchdog)
    context = simulator.get_mutable_context()
    true = np.arange(2 * n, dtype=float)
    desired = -np.arange(2 * n, dtype=float)
    watchdog.GetInputPort("desired_state").FixValue(context, desired)
    watchdog.GetInputPort("true_state").FixValue(context, true)
    held = np.concatenate([true[:n], np.zeros(n)])
    late = np.concatenate([desired[:n], np.zeros(n)])
    stamp = watchdog.GetInputPort("command_stamp")
    # The watchdog sees a new command at its next update (every 0.05 s), here 0.55 s.
    for sent, until, expected in ((-1.0, 0.51, held),  # none yet
                                  (0.7, 0.57, desired),  # one came
                                  (0.7, 0.57 + COMMAND_FRESH, late),  # late: go there, stop
                                  (0.7, 0.57 + COMMAND_TIMEOUT, held),  # none since
                                  (0.3, 1.13, desired)):  # a new one, stamped earlier
        stamp.FixValue(context, [sent])
        simulator.AdvanceTo(until)
        np.testing.assert_array_equal(watchdog.get_output_port().Eval(context), expected)
