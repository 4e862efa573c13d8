"""The controllers in a process of their own, driving whatever robot answers on an LCM bus.

`build_controller_diagram(scenario, lcm=...)` is the Diagram "s3o_controllers": the
controllers (`controllers.add_controllers`) reading the robot's messages and publishing
their commands (`controller_lcm`), and the referee (`diagram.add_task_monitor`), which
judges the run by the simulation's truth when a simulation publishes it on the referee's
channel (`world.referee_channel`; a real robot has no referee, and the report then holds
what the controllers know: the outcomes, no dishes counted).

`execute_on_bus(...)` runs it on the robot's clock (`RobotClock`):
- it waits up to `wait` s for the robot's first state;
- whenever the robot's state comes it advances to that state's time, less the time the
  robot waited for the controllers: a plan (or an arm's motion planned) takes wall time,
  during which the robot's clock runs on and the robot, without new commands, holds where
  it stands. When the controllers fall behind by more than CATCH_UP, that time is added to
  what the robot waited, and the controllers go on from where they stood, their motions
  unbroken. The report's `execution_time` is on the controllers' clock, as a run in one
  process is (its plans take no simulated time); `waited` is the rest of `robot_time`;
- a watchdog: when no robot state came for STATE_TIMEOUT s, the controllers command the
  base to stop and the arm to hold where the robot was last heard of, and the run ends
  (reason ROBOT_SILENT).
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from pydrake.lcm import DrakeLcm
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.analysis import (
    Simulator,
    SimulatorStatus,
)
from pydrake.systems.framework import Context, Diagram, DiagramBuilder
from pydrake.systems.lcm import LcmInterfaceSystem
from pydrake.systems.primitives import VectorLogSink

from s3o_drake.belief import Perceive
from s3o_drake.execution.activity import Activity
from s3o_drake.execution.controller_lcm import add_controller_lcm
from s3o_drake.execution.controllers import add_controllers
from s3o_drake.execution.executive_system import PlanFrom
from s3o_drake.execution.task_monitor import TIME_LIMIT, add_task_monitor
from s3o_drake.world import robot_channels as ch
from s3o_drake.world.dish_messages import DishPoses, DishStates
from s3o_drake.world.lcmtypes import s3o_lcm
from s3o_drake.world.message_systems import add_reader, add_subscriber
from s3o_drake.world.referee_channel import REFEREE, referee_of
from s3o_drake.world.resources import make_parser
from s3o_drake.world.robot import CONTROL_PERIOD, Robot
from s3o_drake.world.scenario import Scenario
from s3o_drake.world.system_lifetime import release_diagram

STATE_TIMEOUT = 0.5
"""How long (s) the controllers go on without the robot's state before they stop it."""
CATCH_UP = 0.25
"""When the controllers are behind the robot by more than this (s), the robot is taken to
have waited for them."""
ROBOT_SILENT = "robot state lost"


class NoRobotError(RuntimeError):
    """No robot state came on the bus within the wait."""


def build_controller_diagram(scenario: Scenario, *, lcm: DrakeLcm, method: str | None = None,
                             seed: int | None = None, perceive: Perceive | None = None,
                             noise: bool = True, progress_bar: bool = False,
                             plan_from: PlanFrom | None = None,
                             time_limit: float = TIME_LIMIT) -> Diagram:
    """The controllers of `scenario` on `lcm`, and their referee (module docstring); named
    "s3o_controllers". The arguments are `build_execution_diagram`'s."""
    seed = scenario.seed if seed is None else int(seed)
    robot = scenario.robot_value
    builder = DiagramBuilder()
    interface = builder.AddNamedSystem("lcm", LcmInterfaceSystem(lcm))
    ports = add_controller_lcm(builder, robot=robot, lcm=interface, start=scenario.robot.start)
    executive = add_controllers(
        builder, scenario, reads=ports.reads, commands=ports.commands, method=method,
        seed=seed, perceive=perceive, noise=noise, progress_bar=progress_bar,
        robot_labels=robot_labels(robot), plan_from=plan_from)
    referee = add_subscriber(builder, lcm=interface, channel=REFEREE,
                             message_type=s3o_lcm.referee_t)

    def seen(read: Callable[..., object]) -> Callable[[s3o_lcm.referee_t], object]:
        return lambda message: (None if (view := referee_of(message)) is None
                                else read(view))

    add_task_monitor(
        builder, scenario, progress=executive.GetOutputPort("progress"),
        dish_states=add_reader(builder, referee, name="referee_dish_states",
                               message_type=s3o_lcm.referee_t,
                               decode=seen(lambda v: v.dish_states), initial=DishStates()),
        dish_poses=add_reader(builder, referee, name="referee_dish_poses",
                              message_type=s3o_lcm.referee_t,
                              decode=seen(lambda v: v.dish_poses), initial=DishPoses()),
        closest_approach=add_reader(builder, referee, name="referee_closest_approach",
                                    message_type=s3o_lcm.referee_t,
                                    decode=seen(lambda v: [v.closest_approach]),
                                    initial=[math.nan], size=1),
        time_limit=time_limit)
    # What the controllers commanded, for the run's timeline (the robot reports positions
    # only).
    commanded = builder.AddNamedSystem("robot_command_log", VectorLogSink(
        2 * robot.num_positions, publish_period=CONTROL_PERIOD))
    builder.Connect(builder.GetSubsystemByName("desired_state_order").get_output_port(),
                    commanded.get_input_port())
    diagram = builder.Build()
    diagram.set_name("s3o_controllers")
    return diagram


def robot_labels(robot: Robot) -> frozenset[int]:
    """The labels of `robot`'s pixels in the overhead camera's label image, as the robot
    sees itself: a plant labels each body's geometry with the body's index, and a world's
    plant holds the robot's bodies first, after the world body."""
    plant = MultibodyPlant(0.0)
    return frozenset(int(b) for b in robot.add_model_instances(make_parser(plant))
                     .body_indices())


class RobotClock:
    """The robot's clock as its state messages tell it: the latest state's time (s) and
    positions, and when (wall time) it came."""

    def __init__(self, lcm: DrakeLcm, *, joints: tuple[str, ...]) -> None:
        self.time: float | None = None
        self.positions: np.ndarray | None = None
        self.heard = time.monotonic()
        self._joints = joints
        lcm.Subscribe(ch.ROBOT_STATE, self._hear)

    def _hear(self, data: bytes) -> None:
        message = s3o_lcm.robot_state_t.decode(data)
        if not message.num_joints:
            return
        self.time = ch.seconds(message.utime)
        self.positions = ch.positions_of(message, joints=self._joints)
        self.heard = time.monotonic()

    def silent_for(self) -> float:
        """Wall seconds since the latest state came."""
        return time.monotonic() - self.heard


@dataclass
class BusRun:
    """What a run of the controllers against a robot on a bus gave: the referee's report
    (with `waited`, `started_at` and `robot_time`), the first and latest plans' results,
    the overhead images at the start, and the commanded activity."""

    report: dict
    plan: object
    result: object
    images: tuple[np.ndarray, np.ndarray] | None
    activity: Activity | None


def _drain(lcm: DrakeLcm, *, wait_ms: int = 10) -> None:
    """Handles every message that came, waiting up to `wait_ms` for the first: one call
    handles one message, and messages left waiting overflow the socket's buffer (the
    images come in large ones), which loses the robot's state with them."""
    if lcm.HandleSubscriptions(wait_ms):
        while lcm.HandleSubscriptions(1):
            pass


def _hold(lcm: DrakeLcm, clock: RobotClock, *, joints: tuple[str, ...]) -> None:
    """Commands the robot to stand where it was last heard of: the base stopped, the arm
    held."""
    if clock.positions is None:
        return
    desired = np.concatenate([clock.positions, np.zeros(len(clock.positions))])
    message = ch.command_message(desired, joints=joints, t=clock.time or 0.0)
    for _ in range(3):  # a lost message or two must not leave the last command standing
        lcm.Publish(ch.ROBOT_COMMAND, message.encode())


def _output(diagram: Diagram, context: Context, name: str) -> object:
    """The value of the output port of `diagram`'s subsystem `name` (it has one)."""
    system = diagram.GetSubsystemByName(name)
    return system.get_output_port().Eval(system.GetMyContextFromRoot(context))


def execute_on_bus(scenario: Scenario, *, lcm: DrakeLcm, method: str | None = None,
                   seed: int | None = None, wait: float = ch.FIRST_STATE_WAIT, noise: bool = True,
                   progress: bool = True, plan_from: PlanFrom | None = None,
                   time_limit: float = TIME_LIMIT,
                   state_timeout: float = STATE_TIMEOUT) -> BusRun:
    """Runs the controllers of `scenario` against the robot on `lcm`, on its clock (module
    docstring), until the referee ends the run or the robot falls silent: no state for
    `state_timeout` wall seconds. NoRobotError when no robot state came within `wait` s."""
    robot = scenario.robot_value
    joints = tuple(robot.joints)
    clock = RobotClock(lcm, joints=joints)
    if progress:
        print(f"waiting up to {wait:g} s for the robot's state on {ch.ROBOT_STATE}",
              file=sys.stderr, flush=True)
    deadline = time.monotonic() + wait
    while clock.time is None and time.monotonic() < deadline:
        _drain(lcm, wait_ms=50)
    if clock.time is None:
        raise NoRobotError(f"no robot state on {ch.ROBOT_STATE} within {wait:g} s")
    diagram = build_controller_diagram(scenario, lcm=lcm, method=method, seed=seed,
                                       noise=noise, progress_bar=progress,
                                       plan_from=plan_from, time_limit=time_limit)
    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    executive = diagram.GetSubsystemByName("executive")
    progress_port = executive.GetOutputPort("progress")
    executive_context = executive.GetMyContextFromRoot(context)

    def planned() -> bool:
        return bool(progress_port.Eval(executive_context).plans)

    # The controllers' clock is the robot's less the time the robot waited for them: it
    # starts at 0 at the robot's first state and goes on from where it stood after a plan.
    offset = clock.time
    simulator.Initialize()
    if progress:
        print(f"the robot answered at {offset:.2f} s of its clock", file=sys.stderr,
              flush=True)
    # The run starts when the executive asks for its first plan (once the overhead images
    # came), as a run in one process starts at its first plan.
    started_at, offset_at_start = (0.0, offset) if planned() else (None, None)
    reason = None
    wall = time.perf_counter()
    while True:
        _drain(lcm)
        if clock.silent_for() > state_timeout:
            _hold(lcm, clock, joints=joints)
            reason = (f"{ROBOT_SILENT}: no state for {state_timeout:g} s after "
                      f"{clock.time:.2f} s of the robot's clock")
            break
        now = context.get_time()
        behind = clock.time - offset - now
        if behind > CATCH_UP:  # the robot waited for the controllers (a plan, mostly)
            offset += behind
            continue
        if behind <= 0.0:
            continue
        # Before the start, a period at a time: the start is known to the period.
        status = simulator.AdvanceTo(now + (behind if started_at is not None
                                            else min(behind, CONTROL_PERIOD)))
        if started_at is None and planned():
            started_at, offset_at_start = now, offset
        if status.reason() == SimulatorStatus.ReturnReason.kReachedTerminationCondition:
            break
    if started_at is None:
        started_at, offset_at_start = context.get_time(), offset
    monitor = diagram.GetSubsystemByName("task_monitor")
    report = monitor.GetOutputPort("report").Eval(
        monitor.GetMyContextFromRoot(context)).to_dict()
    finished_at = report["execution_time"]
    wall = time.perf_counter() - wall
    waited = offset - offset_at_start
    report.update(
        simulated_time=context.get_time() - started_at, wall_time=wall,
        realtime_rate=(context.get_time() - started_at) / wall if wall > 0 else float("inf"),
        execution_time=finished_at - started_at, robot_time=finished_at - started_at + waited,
        started_at=started_at + offset_at_start, waited=waited,
        referee=bool(report["dishes"]),
        planning_time=float(executive.GetOutputPort("planning_time").Eval(
            executive_context)[0]))
    if reason is not None:
        report.update(finished=False, reason=reason)
    color, depth = (_output(diagram, context, name)
                    for name in ("from_overhead_color", "from_overhead_depth"))
    images = ((np.array(color.data)[:, :, :3], np.array(depth.data)[:, :, 0])
              if depth.size() else None)
    log = diagram.GetSubsystemByName("robot_command_log").FindLog(context)
    activity = Activity.of(log.sample_times().copy(), log.data().copy(), robot=robot)
    report["time_by_motion"] = activity.by_motion()
    run = BusRun(report=report,
                 plan=executive.GetOutputPort("plan").Eval(executive_context),
                 result=executive.GetOutputPort("planning_result").Eval(executive_context),
                 images=images, activity=activity)
    del simulator, executive, monitor, log
    release_diagram(diagram)
    return run
