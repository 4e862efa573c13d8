"""The execution diagram: the simulated restaurant, the executive and the controllers.

`build_execution_diagram(scenario, ...)` returns the Diagram "s3o_execution": the world
(plant, scene graph, overhead camera, object tracker, target sensor, Meshcat) and the
controllers (`controllers.add_controllers`: the executive, the base navigator and the arm
controller), which read the world's outputs and command its inputs, directly or over an
LCM bus; and the referee:

    world ── dish_poses, dish_states ──> task_monitor
          ── query_object ──> clearance_monitor ── closest_approach ──> task_monitor
    executive ── progress ──> task_monitor (ends the simulation)

`add_task_monitor` wires the referee the same way in the controllers' own process
(`controller_process`), where the truth comes from the simulation's referee channel.
"""

from __future__ import annotations

from pydrake.geometry import Meshcat
from pydrake.lcm import DrakeLcm
from pydrake.systems.framework import Diagram, DiagramBuilder
from pydrake.systems.lcm import LcmInterfaceSystem
from pydrake.systems.primitives import VectorLogSink

from s3o_drake.belief import Perceive
from s3o_drake.execution.controller_lcm import add_controller_lcm
from s3o_drake.execution.controllers import ROBOT_COMMANDS, ROBOT_READINGS, add_controllers
from s3o_drake.execution.executive_system import PlanFrom
from s3o_drake.execution.task_monitor import TIME_LIMIT, add_task_monitor
from s3o_drake.world.builder import build_world_diagram, robot_render_labels
from s3o_drake.world.clearance_monitor import add_clearance_monitor
from s3o_drake.world.robot import CONTROL_PERIOD
from s3o_drake.world.robot_lcm import add_robot_lcm
from s3o_drake.world.scenario import Scenario


def build_execution_diagram(scenario: Scenario, *, method: str | None = None,
                            seed: int | None = None, meshcat: Meshcat | None = None,
                            perceive: Perceive | None = None, noise: bool = True,
                            progress_bar: bool = False, time_limit: float = TIME_LIMIT,
                            show_collisions: bool = False,
                            plan_from: PlanFrom | None = None,
                            bus: str | None = None) -> Diagram:
    """The whole system (see the module docstring), named "s3o_execution".

    `noise=False` turns off the simulated navigation, reaching and localisation noise (the
    planner still plans with the scenario's noise model). `perceive` replaces the
    executive's perception of the chairs.
    `show_collisions` adds Meshcat's (hidden) collision-geometry view, for live watching.
    `bus` (an LCM URL, "memq://" in one process): the controllers and the robot talk over
    it, by the robot's messages (`world.robot_lcm`, `controller_lcm`), rather than through
    the world's ports; the referee still reads the simulation.
    The task monitor ends the simulation `scenario.simulation.hold_time` after the plan has
    ended, or at `time_limit` simulated seconds.
    """
    seed = scenario.seed if seed is None else int(seed)
    robot = scenario.robot_value
    builder = DiagramBuilder()
    world = builder.AddNamedSystem("world", build_world_diagram(
        scenario, meshcat=meshcat, track_dishes=True, show_collisions=show_collisions,
        seed=seed, noise=noise))
    # What the controllers read of the robot and what they command it: the world's own
    # ports, or, over a message bus, the robot's messages and theirs.
    if bus is None:
        reads = {name: world.GetOutputPort(name) for name in ROBOT_READINGS}
        commands = {name: world.GetInputPort(name) for name in ROBOT_COMMANDS}
    else:
        lcm = builder.AddNamedSystem("lcm", LcmInterfaceSystem(DrakeLcm(bus)))
        add_robot_lcm(builder, world, robot=robot, lcm=lcm)
        ports = add_controller_lcm(builder, robot=robot, lcm=lcm, start=scenario.robot.start)
        reads, commands = ports.reads, ports.commands
    executive = add_controllers(
        builder, scenario, reads=reads, commands=commands, method=method, seed=seed,
        perceive=perceive, noise=noise, progress_bar=progress_bar,
        robot_labels=robot_render_labels(world, robot), plan_from=plan_from)
    add_task_monitor(
        builder, scenario, progress=executive.GetOutputPort("progress"),
        dish_states=world.GetOutputPort("dish_states"),
        dish_poses=world.GetOutputPort("dish_poses"),
        closest_approach=add_clearance_monitor(
            builder, world, robot=robot, period=CONTROL_PERIOD,
            furniture=[f.name for f in (*scenario.tables, *scenario.chairs)]),
        time_limit=time_limit, sensing_error=world.GetSubsystemByName("target_sensor").error)
    # What the robot did, for the run's timeline.
    states = builder.AddNamedSystem("robot_state_log", VectorLogSink(
        2 * robot.num_positions, publish_period=CONTROL_PERIOD))
    builder.Connect(world.GetOutputPort("robot_state"), states.get_input_port())
    diagram = builder.Build()
    diagram.set_name("s3o_execution")
    return diagram
