"""The controllers of a scenario: the executive, the base navigator and the arm controller,
with the parameters each is given (`executive_params`, `navigator_params`, `arm_params`,
`make_executive_system`), wired by `add_controllers` to what they read of a robot and to
what they command it: the world's ports in one process (`diagram`), or the robot's
messages (`controller_lcm`, `controller_process`).

This side never imports the simulated world: it is given the scenario's briefing and
settings, and reads the robot's reports.

    robot_state ──> executive, base_navigator, arm_controller
    overhead images ──> executive (perception)
    target_sighting, gripper_status ──> arm_controller ── target_request, grip ──> robot
    executive ── base_command ──> base_navigator ── status ──> executive
              ── pick_command ──> arm_controller ── status ──> executive
              ── known_scene ──> base_navigator, arm_controller (what they check in)
    base_navigator (6) + arm_controller (16 for the UR5e) ── desired_state_mux
      ──> robot_desired_state

The navigator drives the base's three positions and the arm controller the arm's joints
and the fingers (of `scenario.robot_value`, which every system is given);
`desired_state_mux` interleaves their [q, v] into the plant's [q, v] with a permutation
(a Multiplexer and a MatrixGain: no code of ours in the loop).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from pydrake.systems.framework import DiagramBuilder, InputPort, OutputPort
from pydrake.systems.primitives import MatrixGain, Multiplexer

from s3o_drake.belief import Perceive, perceive_known_world
from s3o_drake.belief.known_world import Briefing, KnownWorld
from s3o_drake.execution.arm_controller import ArmController, ArmParams
from s3o_drake.execution.base_navigator import BaseNavigator, NavigatorParams
from s3o_drake.execution.escape import MotionProfile
from s3o_drake.execution.executive import ExecutiveParams, TaskObject
from s3o_drake.execution.executive_system import (
    ExecutiveSystem,
    ExecutiveSystemParams,
    PlanFrom,
)
from s3o_drake.world.choices import Recovery
from s3o_drake.world.goals import place_target_name, place_targets
from s3o_drake.world.robot import CONTROL_PERIOD, Robot
from s3o_drake.world.scenario import Scenario

ROBOT_READINGS = ("robot_state", "overhead_color_image", "overhead_depth_image",
                  "overhead_label_image", "target_sighting", "gripper_status", "base_bumper")
"""The world's outputs the controllers read: what a robot and its sensors report."""
ROBOT_COMMANDS = ("robot_desired_state", "grip", "target_request")
"""The world's inputs the controllers command: what a robot obeys."""

def desired_state_permutation(*, robot: Robot) -> np.ndarray:
    """P with [q, v] (2 n) = P @ [base q, base v, arm and finger q, arm and finger v], for
    `robot`'s n positions."""
    n, b = robot.num_positions, robot.num_base_joints
    order = [*range(0, b), *range(2 * b, b + n),  # positions: base, then arm and fingers
             *range(b, 2 * b), *range(b + n, 2 * n)]  # velocities, the same way
    P = np.zeros((2 * n, 2 * n))
    P[np.arange(2 * n), order] = 1.0
    return P


def executive_params(scenario: Scenario, *, method: str) -> ExecutiveParams:
    """The Executive's params: `scenario`'s objects, targets and execution settings."""
    settings = scenario.execution
    return ExecutiveParams(
        objects=tuple(TaskObject(d.name, d.kind, d.goal) for d in scenario.dishes),
        # Where each pick and each place is: the dish, or the object's place target.
        targets={d.name: tuple(d.position) for d in scenario.dishes}
        | {t.target: t.position for t in place_targets(scenario)},
        place_targets={t.name: place_target_name(t.name) for t in place_targets(scenario)},
        method=method, recovery=Recovery(settings.recovery),
        time_budget=scenario.planner.time_budget, replan_budget=settings.replan_budget,
        min_feasibility=settings.min_feasibility, correction_radius=settings.correction_radius,
        detour=settings.detour, max_corrections=settings.max_corrections,
        max_tries=settings.max_tries, max_replans=settings.max_replans,
        motion=settings.motion)


def make_executive_system(scenario: Scenario, *, method: str | None = None,
                          seed: int | None = None, perceive: Perceive | None = None,
                          workers: int | None = None, noise: bool = True,
                          robot_labels: frozenset[int] = frozenset(),
                          progress_bar: bool = False,
                          control_period: float = CONTROL_PERIOD,
                          plan_from: PlanFrom | None = None) -> ExecutiveSystem:
    """The ExecutiveSystem of `scenario`: planning with `method` (default the scenario's),
    from `seed` (default the scenario's), perceiving the chairs with `perceive` (default
    `belief.ChairPerception`); `robot_labels`: the robot's own pixels, for the FCN's view;
    `noise=False`: exact localisation; `plan_from`: what makes each plan (default the
    planning pipeline's)."""
    method = method or scenario.planner.method
    params = ExecutiveSystemParams(
        executive=executive_params(scenario, method=method), method=method,
        seed=scenario.seed if seed is None else int(seed),
        workers=scenario.planner.workers if workers is None else workers,
        feasibility=scenario.planner.feasibility, uncertainty=scenario.uncertainty,
        noise=noise)

    # The system is given what the robot is given, never the true world's chairs.
    briefing = Briefing.of(scenario)

    def perceive_world(images: tuple[np.ndarray, np.ndarray, np.ndarray], *,
                       pose: Sequence[float], dishes: Sequence[str], held: str) -> KnownWorld:
        return perceive_known_world(briefing, images, pose=pose, dishes=dishes,
                                    perceive=perceive, robot_labels=robot_labels, held=held)

    return ExecutiveSystem(robot=scenario.robot_value, params=params,
                           perceive_world=perceive_world,
                           control_period=control_period, progress_bar=progress_bar,
                           **({} if plan_from is None else {"plan_from": plan_from}))


def navigator_params(scenario: Scenario, *, seed: int | None = None,
                     noise: bool = True) -> NavigatorParams:
    """The BaseNavigator's params: the planner's speed, the robot's start, the navigation
    noise (none without `noise`) and `seed` (default the scenario's)."""
    u = scenario.uncertainty
    return NavigatorParams(
        profile=MotionProfile(speed=scenario.planner.speed, motion=scenario.execution.motion,
                              holonomic=scenario.robot_value.description.base.holonomic),
        start=tuple(float(v) for v in scenario.robot.start),
        seed=scenario.seed if seed is None else seed,
        nav_xy_std=u.nav_xy_std if noise else 0.0, nav_yaw_std=u.nav_yaw_std if noise else 0.0)


def arm_params(scenario: Scenario, *, seed: int | None = None, noise: bool = True) -> ArmParams:
    """The ArmController's params: the navigation noise its place grasps are rated with
    (none without `noise`), the objects to place, the motion and `seed` (default the
    scenario's)."""
    u = scenario.uncertainty
    return ArmParams(seed=scenario.seed if seed is None else int(seed),
                     nav_std=(u.nav_xy_std, u.nav_xy_std, u.nav_yaw_std) if noise else None,
                     to_place=frozenset(d.name for d in scenario.dishes if d.goal == "place"),
                     motion=scenario.execution.motion)


def add_controllers(builder: DiagramBuilder, scenario: Scenario, *,
                    reads: Mapping[str, OutputPort], commands: Mapping[str, InputPort],
                    method: str | None = None, seed: int, perceive: Perceive | None = None,
                    noise: bool = True, progress_bar: bool = False,
                    robot_labels: frozenset[int] = frozenset(),
                    plan_from: PlanFrom | None = None) -> ExecutiveSystem:
    """The executive, the base navigator and the arm controller of `scenario` ("executive",
    "base_navigator", "arm_controller"), in `builder`, wired to what they read of the robot
    (`reads`, by ROBOT_READINGS' names) and to what they command it (`commands`, by
    ROBOT_COMMANDS' names); the executive. The arguments are `build_execution_diagram`'s."""
    robot = scenario.robot_value
    executive = builder.AddNamedSystem("executive", make_executive_system(
        scenario, method=method, seed=seed, perceive=perceive, progress_bar=progress_bar,
        control_period=CONTROL_PERIOD, robot_labels=robot_labels, noise=noise,
        plan_from=plan_from))
    navigator = builder.AddNamedSystem("base_navigator", BaseNavigator(
        robot=robot, params=navigator_params(scenario, seed=seed, noise=noise),
        control_period=CONTROL_PERIOD))
    arm = builder.AddNamedSystem("arm_controller", ArmController(
        robot=robot, params=arm_params(scenario, seed=seed, noise=noise),
        control_period=CONTROL_PERIOD))
    mux = builder.AddNamedSystem(
        "desired_state_mux",
        Multiplexer([2 * robot.num_base_joints,
                     2 * (robot.num_positions - robot.num_base_joints)]))
    permute = builder.AddNamedSystem("desired_state_order",
                                     MatrixGain(desired_state_permutation(robot=robot)))
    for name in ("overhead_color_image", "overhead_depth_image", "overhead_label_image"):
        builder.Connect(reads[name], executive.GetInputPort(name))
    for system in (executive, navigator, arm):
        builder.Connect(reads["robot_state"], system.GetInputPort("robot_state"))
    builder.Connect(reads["target_sighting"], arm.GetInputPort("target_sighting"))
    builder.Connect(arm.GetOutputPort("target_request"), commands["target_request"])
    builder.Connect(reads["gripper_status"], arm.GetInputPort("gripper_status"))
    builder.Connect(arm.GetOutputPort("grip"), commands["grip"])
    builder.Connect(executive.GetOutputPort("base_command"),
                    navigator.GetInputPort("base_command"))
    builder.Connect(executive.GetOutputPort("pick_command"), arm.GetInputPort("pick_command"))
    # The controllers check their motions in what the robot knows, never in the true world.
    for system in (navigator, arm):
        builder.Connect(executive.GetOutputPort("known_scene"),
                        system.GetInputPort("known_scene"))
    # Each controller sees what the other's motion is: they move the robot together.
    builder.Connect(navigator.GetOutputPort("base_motion"), arm.GetInputPort("base_motion"))
    builder.Connect(arm.GetOutputPort("arm_motion"), navigator.GetInputPort("arm_motion"))
    builder.Connect(navigator.GetOutputPort("status"), executive.GetInputPort("base_status"))
    builder.Connect(arm.GetOutputPort("status"), executive.GetInputPort("arm_status"))
    builder.Connect(navigator.GetOutputPort("base_desired_state"), mux.get_input_port(0))
    builder.Connect(reads["base_bumper"], navigator.GetInputPort("bumper"))
    builder.Connect(arm.GetOutputPort("arm_desired_state"), mux.get_input_port(1))
    builder.Connect(mux.get_output_port(), permute.get_input_port())
    builder.Connect(permute.get_output_port(), commands["robot_desired_state"])
    return executive
