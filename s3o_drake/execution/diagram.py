"""The execution diagram: the simulated restaurant, the S3O planner and the controllers.

`build_execution_diagram(scenario, ...)` returns the Diagram "s3o_execution":

    world (plant, scene graph, overhead camera, object tracker, Meshcat)
      robot_state ──> planner, base_navigator, arm_controller
      overhead images ──> planner (perception)
      dish_poses ──> arm_controller, task_monitor     dish_states ──> task_monitor
    planner ── base_command ──> base_navigator ── status ──> planner
            ── pick_command ──> arm_controller ── status ──> planner
            ── progress ──> task_monitor (ends the simulation)
    arm_controller ── grip ──> world (the tracker moves the held dish)
    base_navigator (6) + arm_controller (16) ── desired_state_mux ──> world.robot_desired_state

The navigator drives the base's three positions and the arm controller the six arm joints
and the two fingers; `desired_state_mux` interleaves their [q, v] into the plant's [q(11),
v(11)] with a permutation (a Multiplexer and a MatrixGain: no code of ours in the loop).

The controllers take small parameter dataclasses, which `navigator_params` and `arm_params`
make from the Scenario.
"""

from __future__ import annotations

import numpy as np
from pydrake.geometry import Meshcat
from pydrake.systems.framework import Diagram, DiagramBuilder
from pydrake.systems.primitives import MatrixGain, Multiplexer

from s3o_drake.execution.arm_controller import ArmController, ArmParams
from s3o_drake.execution.base_navigator import BaseNavigator, NavigatorParams
from s3o_drake.execution.escape import MotionProfile
from s3o_drake.execution.executive_system import Perceive, S3OPlanner
from s3o_drake.execution.task_monitor import TaskMonitor
from s3o_drake.feasibility.check import FeasibilityChecker
from s3o_drake.feasibility.scene import FeasibilityScene
from s3o_drake.world.builder import build_world_diagram, robot_render_labels
from s3o_drake.world.goals import place_targets, with_place_targets
from s3o_drake.world.robot import CONTROL_PERIOD, NUM_POSITIONS
from s3o_drake.world.scenario import Scenario

TIME_LIMIT = 1800.0
"""Simulated seconds after which an execution is stopped whatever its state."""
BASE_DOFS = 3
ARM_DOFS = NUM_POSITIONS - BASE_DOFS  # six arm joints and two fingers


def desired_state_permutation() -> np.ndarray:
    """P with [q, v] (22) = P @ [base q (3), base v (3), arm q (8), arm v (8)]."""
    n = NUM_POSITIONS
    order = [*range(0, 3), *range(6, 14),  # positions: base, then arm and fingers
             *range(3, 6), *range(14, 22)]  # velocities, the same way
    P = np.zeros((2 * n, 2 * n))
    P[np.arange(2 * n), order] = 1.0
    return P


def navigator_params(scenario: Scenario, *, seed: int | None = None,
                     noise: bool = True) -> NavigatorParams:
    """The BaseNavigator's params: the planner's speed, the robot's start, the navigation
    noise (none without `noise`) and `seed` (default the scenario's)."""
    u = scenario.uncertainty
    return NavigatorParams(
        profile=MotionProfile(speed=scenario.planner.speed),
        start=tuple(float(v) for v in scenario.robot.start),
        seed=scenario.seed if seed is None else seed,
        nav_xy_std=u.nav_xy_std if noise else 0.0, nav_yaw_std=u.nav_yaw_std if noise else 0.0)


def arm_params(scenario: Scenario, *, seed: int | None = None, noise: bool = True) -> ArmParams:
    """The ArmController's params: the reach and navigation noise (none without `noise`),
    the objects to place and `seed` (default the scenario's)."""
    u = scenario.uncertainty
    return ArmParams(seed=scenario.seed if seed is None else int(seed),
                     reach_std=u.reach_std if noise else 0.0,
                     nav_std=(u.nav_xy_std, u.nav_xy_std, u.nav_yaw_std) if noise else None,
                     to_place=frozenset(d.name for d in scenario.dishes if d.goal == "place"))


def build_execution_diagram(scenario: Scenario, *, method: str | None = None,
                            seed: int | None = None, meshcat: Meshcat | None = None,
                            perceive: Perceive | None = None, noise: bool = True,
                            progress_bar: bool = False, time_limit: float = TIME_LIMIT,
                            show_collisions: bool = False) -> Diagram:
    """The whole system (see the module docstring), named "s3o_execution".

    `noise=False` turns off the simulated navigation, reaching and localisation noise (the
    planner still plans with the scenario's noise model). `perceive` replaces the planner's
    perception.
    `show_collisions` adds Meshcat's (hidden) collision-geometry view, for live watching.
    The task monitor ends the simulation `scenario.simulation.hold_time` after the plan has
    ended, or at `time_limit` simulated seconds.
    """
    seed = scenario.seed if seed is None else int(seed)
    builder = DiagramBuilder()
    world = builder.AddNamedSystem("world", build_world_diagram(
        scenario, meshcat=meshcat, track_dishes=True, show_collisions=show_collisions))
    # The controllers act in the true world: their collision checks see every chair, and
    # the arm's the place targets it puts objects down at.
    truth = FeasibilityScene(with_place_targets(scenario))
    planner = builder.AddNamedSystem("planner", S3OPlanner(
        scenario=scenario, method=method, seed=seed, perceive=perceive,
        progress_bar=progress_bar, control_period=CONTROL_PERIOD,
        robot_labels=robot_render_labels(world), noise=noise))
    navigator = builder.AddNamedSystem("base_navigator", BaseNavigator(
        params=navigator_params(scenario, seed=seed, noise=noise), scene=truth,
        control_period=CONTROL_PERIOD))
    arm = builder.AddNamedSystem("arm_controller", ArmController(
        params=arm_params(scenario, seed=seed, noise=noise), scene=truth,
        checker=FeasibilityChecker(truth), control_period=CONTROL_PERIOD))
    monitor = builder.AddNamedSystem("task_monitor", TaskMonitor(
        period=CONTROL_PERIOD, settle_time=scenario.simulation.hold_time,
        time_limit=time_limit, places=place_targets(scenario),
        fixtures=[d.name for d in scenario.dishes if d.goal == "stay"]))
    mux = builder.AddNamedSystem("desired_state_mux",
                                 Multiplexer([2 * BASE_DOFS, 2 * ARM_DOFS]))
    permute = builder.AddNamedSystem("desired_state_order",
                                     MatrixGain(desired_state_permutation()))

    for name in ("overhead_color_image", "overhead_depth_image", "overhead_label_image"):
        builder.Connect(world.GetOutputPort(name), planner.GetInputPort(name))
    for system in (planner, navigator, arm):
        builder.Connect(world.GetOutputPort("robot_state"), system.GetInputPort("robot_state"))
    builder.Connect(world.GetOutputPort("dish_poses"), arm.GetInputPort("dish_poses"))
    builder.Connect(world.GetOutputPort("dish_states"), monitor.GetInputPort("dish_states"))
    builder.Connect(world.GetOutputPort("dish_poses"), monitor.GetInputPort("dish_poses"))
    builder.Connect(arm.GetOutputPort("grip"), world.GetInputPort("grip"))
    builder.Connect(planner.GetOutputPort("base_command"), navigator.GetInputPort("base_command"))
    builder.Connect(planner.GetOutputPort("pick_command"), arm.GetInputPort("pick_command"))
    builder.Connect(navigator.GetOutputPort("status"), planner.GetInputPort("base_status"))
    builder.Connect(arm.GetOutputPort("status"), planner.GetInputPort("arm_status"))
    builder.Connect(planner.GetOutputPort("progress"), monitor.GetInputPort("progress"))
    builder.Connect(navigator.GetOutputPort("base_desired_state"), mux.get_input_port(0))
    builder.Connect(arm.GetOutputPort("arm_desired_state"), mux.get_input_port(1))
    builder.Connect(mux.get_output_port(), permute.get_input_port())
    builder.Connect(permute.get_output_port(), world.GetInputPort("robot_desired_state"))
    diagram = builder.Build()
    diagram.set_name("s3o_execution")
    return diagram
