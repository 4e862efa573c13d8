"""How closely a robot's PD-held joints follow a planned pickup, in the simulated world.

A robot's description gives its actuators' PD gains (models/<robot>/robot.yaml, or the
model's own). `pickup_tracking` plans a pickup of the small scene's plate from a stop the
feasibility check accepts (`plan_pickup`), plays the plan's positions and velocities as
the world's desired state (`world.builder.build_world_diagram`), and compares the simulated
arm with the plan: the joints' largest error, and the grasp point's (through the arm's
kinematics) over the whole pickup and where the fingers close. Gains too soft lag the
plan and miss the grasp; too stiff ones oscillate.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import TrajectorySource, VectorLogSink
from pydrake.trajectories import PiecewisePolynomial

from s3o_drake.execution.arm.pickup import plan_pickup
from s3o_drake.feasibility.check import FeasibilityChecker
from s3o_drake.feasibility.kinematics import arm_kinematics
from s3o_drake.feasibility.scene import FeasibilityScene
from s3o_drake.world.angles import facing_yaw
from s3o_drake.world.builder import build_world_diagram
from s3o_drake.world.scenario import Scenario

SAMPLE = 0.01
"""The period (s) at which the plan is played and the simulated state logged."""
STOP_DISTANCE = 0.75
"""The stops tried: a ring this far (m) from the dish, facing it."""


@dataclass(frozen=True)
class Tracking:
    """A pickup's plan against its simulation: `duration` (s), the arm joints' largest
    |error| (rad), the grasp point's largest error (m), and its error where the fingers
    close (m: the grasp itself)."""

    robot: str
    duration: float
    joint_error: float
    grasp_error: float
    error_at_grasp: float


def pickup_tracking(scenario: Scenario, *, seed: int = 0) -> Tracking:
    """`scenario`'s robot picking its first dish (see the module docstring); raises
    ValueError when no stop around the dish is feasible or the pickup is not planned."""
    robot = scenario.robot_value
    scene = FeasibilityScene(scenario.contents)
    checker = FeasibilityChecker(scene)
    dish = scenario.dishes[0]
    p_WD = np.asarray(dish.position, dtype=float)
    bearings = np.linspace(-np.pi, np.pi, 24, endpoint=False)
    xy = p_WD + STOP_DISTANCE * np.column_stack([np.cos(bearings), np.sin(bearings)])
    stops = np.column_stack([xy, facing_yaw(xy, p_WD)])
    feasible = np.flatnonzero(checker.check_many(stops, dish.name))
    if feasible.size == 0:
        raise ValueError(f"no stop {STOP_DISTANCE} m from {dish.name} is feasible")
    stop = stops[feasible[0]]
    plan = plan_pickup(scene, checker, stop, dish.name, seed=seed)
    if not plan.ok:
        raise ValueError(f"the pickup of {dish.name} is not planned: {plan.reason}")
    q_plan = plan.trajectory()
    v_plan = q_plan.MakeDerivative()
    times = np.arange(0.0, q_plan.end_time() + SAMPLE / 2, SAMPLE)
    desired = np.column_stack([np.concatenate([q_plan.value(t).ravel(), v_plan.value(t).ravel()])
                               for t in times])

    # The world with the robot at the plan's start, standing at the stop.
    at_stop = dataclasses.replace(scenario, robot=dataclasses.replace(
        scenario.robot, start=[float(v) for v in stop]))
    builder = DiagramBuilder()
    world = builder.AddSystem(build_world_diagram(at_stop, track_dishes=True))
    source = builder.AddSystem(TrajectorySource(
        PiecewisePolynomial.FirstOrderHold(times, desired)))
    builder.Connect(source.get_output_port(), world.GetInputPort("robot_desired_state"))
    n = robot.num_positions
    log = builder.AddSystem(VectorLogSink(2 * n, publish_period=SAMPLE))
    builder.Connect(world.GetOutputPort("robot_state"), log.get_input_port())
    diagram = builder.Build()
    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    plant = world.GetSubsystemByName("plant")
    robot.instances_in(plant).set_positions(plant.GetMyMutableContextFromRoot(context),
                                            q_plan.value(0.0).ravel())
    simulator.AdvanceTo(q_plan.end_time())

    sampled = log.FindLog(context)
    t, q = sampled.sample_times(), sampled.data()[:n]
    planned = np.column_stack([q_plan.value(s).ravel() for s in t])
    arm = robot.arm_positions
    kinematics = arm_kinematics(robot)
    _, p_sim = kinematics.forward(q[arm].T)
    _, p_plan = kinematics.forward(planned[arm].T)
    grasp = np.linalg.norm(p_sim - p_plan, axis=1)
    # The fingers close at the end of the descend: approach and descend come first.
    closing = sum(segment.duration for segment in plan.segments[:2])
    return Tracking(robot=robot.name, duration=plan.duration,
                    joint_error=float(np.abs(q[arm] - planned[arm]).max()),
                    grasp_error=float(grasp.max()),
                    error_at_grasp=float(grasp[int(np.argmin(np.abs(t - closing)))]))
