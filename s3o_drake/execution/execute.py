"""Execute a scenario's task: build the execution diagram, plan at initialization, simulate
until the task monitor ends the run, and collect what happened (`execute`). The `run`
command (s3o_drake/commands/run_scenario.py) is a thin main over it."""


import math
import sys
import time
from dataclasses import dataclass
from typing import TextIO

import numpy as np
from pydrake.geometry import Meshcat
from pydrake.systems.analysis import ApplySimulatorConfig, InitializeParams, Simulator
from tqdm import tqdm

from s3o_drake.belief import Perceive
from s3o_drake.execution.activity import Activity
from s3o_drake.execution.diagram import build_execution_diagram
from s3o_drake.execution.executive_system import PlanFrom
from s3o_drake.execution.task_monitor import TIME_LIMIT
from s3o_drake.planning.pipeline import PlanningResult
from s3o_drake.planning.plan import TaskMotionPlan
from s3o_drake.world.builder import ILLUSTRATION, overhead_images
from s3o_drake.world.scenario import Scenario
from s3o_drake.world.system_lifetime import release_diagram

SOLVER_RESTARTS = 5
"""Restarts of the contact solver from rest allowed in one run (`_simulate`)."""
REST_SPEED = 1e-6
"""A plant whose velocities are all below this (m/s, rad/s) stands still."""


@dataclass
class Execution:
    """What one planned and simulated run produced. The diagram that ran it is gone: it is
    freed when the run ends (`release_diagram`), so that runs in one process do not
    accumulate their diagrams."""

    plan: TaskMotionPlan | None
    report: dict
    images: tuple[np.ndarray, np.ndarray]
    """The overhead camera's colour (RGB) and depth (m) images at the start."""
    result: PlanningResult | None
    """The latest planning's result: what the plan was made on (the KnownWorld with the
    perceived chairs, the heatmaps, the navigation map, the state spaces)."""
    html: str | None  # the playback page; None when nothing was recorded
    activity: Activity | None = None
    """When the base and the arm moved (None when the run has no log of it)."""


class SimulatedSeconds:
    """The execution's progress bar: whole simulated seconds against the predicted
    execution time.

    The prediction is a plan's, made before the noise, the corrections and the replans:
    the simulation often runs longer. Past the prediction the total grows with the
    simulated time (the bar stays full and says how long it has run) instead of counting
    past 100 %; at the end the total is the simulated time, whatever was predicted.
    """

    def __init__(self, expected: float, *, disable: bool = False,
                 file: TextIO | None = None) -> None:
        self.bar = tqdm(total=max(1, round(expected)), desc="executing", unit="sim s",
                        disable=disable, file=file)

    def show(self, t: float) -> None:
        """Moves the bar to simulated time `t` (s)."""
        done = int(t)
        if done > self.bar.total:
            self.bar.total = done
        if done > self.bar.n:
            self.bar.update(done - self.bar.n)

    def close(self, t: float) -> None:
        """Ends the bar at simulated time `t`: done, against the time it really took."""
        done = max(1, int(t))
        self.bar.total = done
        self.bar.update(done - self.bar.n)
        self.bar.close()


#: Meshcat's camera: its vertical field of view (deg), three.js's default.
MESHCAT_FOV = 75.0
#: The first view: the camera this far (m) behind the robot's start, away from the room's
#: centre, and this high, so that the robot fills more than a quarter of the view's height (its
#: arm visible) with the room spread out behind it.
VIEW_BACK = 2.0
VIEW_HEIGHT = 2.0
#: ... looking at a point this far from the robot towards the room's centre, 0.5 m up.
VIEW_LEAD = 1.0
#: The camera rises (up to VIEW_HIGHEST, m) to see the robot's base (SIGHT_LOW above the
#: floor) over a wall, SIGHT_CLEARANCE (m) above the wall's top.
SIGHT_LOW = 0.2
SIGHT_CLEARANCE = 0.1
VIEW_HIGHEST = 5.0


def first_view(bounds: list[float], start: tuple[float, float, float],
               wall_height: float) -> tuple[np.ndarray, np.ndarray]:
    """Where the playback's camera stands and what it looks at (p_WC, p_WT) when the page
    opens: behind the robot's start, seen from the side away from the room's centre (from
    behind the robot, as it faces, when it starts at the centre)."""
    x_min, y_min, x_max, y_max = bounds
    p_WR = np.array(start[:2], dtype=float)
    towards = np.array([(x_min + x_max) / 2, (y_min + y_max) / 2]) - p_WR
    if np.linalg.norm(towards) < 0.5:
        towards = np.array([np.cos(start[2]), np.sin(start[2])])
    towards /= np.linalg.norm(towards)
    # Where the line of sight leaves the room, a wall could hide the robot: the camera then
    # goes up until that line passes over the wall, SIGHT_CLEARANCE above it.
    leaving = [(bound - p) / -t for p, t, bound in zip(
        p_WR, towards, ((x_min, x_max)[int(towards[0] < 0)], (y_min, y_max)[int(towards[1] < 0)]),
        strict=True) if abs(t) > 1e-9]
    inside = min(leaving, default=math.inf)
    height = VIEW_HEIGHT
    if inside < VIEW_BACK:
        height = max(height, SIGHT_LOW + (wall_height + SIGHT_CLEARANCE - SIGHT_LOW)
                     * VIEW_BACK / max(inside, 0.1))
    camera = np.append(p_WR - VIEW_BACK * towards, min(height, VIEW_HIGHEST))
    return camera, np.append(p_WR + VIEW_LEAD * towards, 0.5)


def frame_room(meshcat: Meshcat, scenario: Scenario) -> None:
    """Points Meshcat's camera at the robot's start with the room behind it (`first_view`),
    so that the page opens on the robot, large enough to see its arm, and the room it will
    work in (Meshcat's default camera sits outside the walls, far from a robot)."""
    camera, target = first_view(scenario.room.bounds, scenario.robot.start,
                                scenario.room.wall_height)
    meshcat.SetCameraPose(camera, target)


def _simulate(simulator: Simulator, plant) -> tuple[str | None, int]:
    """Runs `simulator` until the task monitor ends the run; returns why it failed (None when
    it did not) and how many times the contact solver was restarted.

    SAP can fail to converge on a robot standing still with no contact at all: velocities
    of 1e-12 m/s, the numerical dust of a PD-held rest, make its line search fail
    (task_002, seed 4132582129: every run ended at t = 14.08 s, with a 0.01 s or a
    0.005 s step). Such a state is at rest for any purpose, so its velocities are set to
    exactly zero and the step is taken again, at most SOLVER_RESTARTS times per run.
    Any other failure ends the run: a RuntimeError is e.g. the solver diverging in motion,
    and pydrake raises SystemExit for a failed Drake requirement (DRAKE_DEMAND) inside a
    system. Either is reported with the data so far, and not the study that called it.
    """
    context = simulator.get_mutable_context()
    plant_context = plant.GetMyMutableContextFromRoot(context)
    restarts = 0
    while True:
        try:
            simulator.AdvanceTo(TIME_LIMIT + 1.0)  # the task monitor ends it before
            return None, restarts
        except (RuntimeError, SystemExit) as e:
            message = str(e).splitlines()[0] if str(e) else type(e).__name__
            at_rest = np.abs(plant.GetVelocities(plant_context)).max(initial=0.0) < REST_SPEED
            if (isinstance(e, RuntimeError) and "SAP solver failed to converge" in message
                    and at_rest and restarts < SOLVER_RESTARTS):
                restarts += 1
                plant.SetVelocities(plant_context, np.zeros(plant.num_velocities()))
                simulator.Initialize(InitializeParams(suppress_initialization_events=True))
                continue
            return f"the simulation failed at t = {context.get_time():.2f} s: {message}", restarts


def execute(scenario: Scenario, *, method: str | None = None, seed: int | None = None,
            meshcat: Meshcat | None, realtime: bool = False, noise: bool = True,
            progress: bool = True, perceive: Perceive | None = None,
            plan_from: PlanFrom | None = None, bus: str | None = None) -> Execution:
    """Builds the execution diagram, plans (at initialization) and simulates until the task
    monitor ends the run; records the playback in `meshcat` (none without one: the
    benchmark's runs). `perceive` replaces the executive's perception of the chairs (at
    every plan and replan); `plan_from` what makes each plan (default the pipeline's);
    `bus` an LCM URL the controllers and the robot talk over (`build_execution_diagram`)."""
    diagram = build_execution_diagram(scenario, method=method, seed=seed, meshcat=meshcat,
                                      perceive=perceive, noise=noise, progress_bar=progress,
                                      show_collisions=realtime, plan_from=plan_from, bus=bus)
    if meshcat is not None:
        frame_room(meshcat, scenario)
    simulator = Simulator(diagram)
    ApplySimulatorConfig(scenario.simulator, simulator)
    context = simulator.get_mutable_context()
    executive = diagram.GetSubsystemByName("executive")
    executive_context = executive.GetMyContextFromRoot(context)
    simulator.Initialize()  # the executive plans here
    world = diagram.GetSubsystemByName("world")
    color, depth, _ = overhead_images(world, world.GetMyContextFromRoot(context))
    images = (color[:, :, :3], depth)
    plan = executive.GetOutputPort("plan").Eval(executive_context)
    visualizer = None
    if meshcat is not None:
        visualizer = world.GetSubsystemByName(ILLUSTRATION)
        visualizer.StartRecording(set_transforms_while_recording=realtime)
    if realtime:
        simulator.set_target_realtime_rate(1.0)
        # The pacing counts from the simulator's statistics, which Initialize() started
        # before the planning; reset, the live view is paced from the first simulated second.
        simulator.ResetStatistics()
    # Whole simulated seconds against the plan's predicted execution time.
    expected = 1.0 if plan is None else plan.predicted_time
    if progress:
        print(f"simulating the execution ({expected:.0f} s predicted"
              f"{', in real time' if realtime else ''})", file=sys.stderr, flush=True)
    bar = SimulatedSeconds(expected, disable=not progress)
    simulator.set_monitor(lambda root_context: bar.show(root_context.get_time()))
    start = time.perf_counter()
    failure, restarts = _simulate(simulator, world.GetSubsystemByName("plant"))
    wall = time.perf_counter() - start
    bar.close(context.get_time())
    if visualizer is not None:
        visualizer.StopRecording()
        visualizer.PublishRecording()
    monitor = diagram.GetSubsystemByName("task_monitor")
    monitor_context = monitor.GetMyContextFromRoot(context)
    # The RunReport as plain JSON data: what report.json and the evaluation's rows hold.
    report = monitor.GetOutputPort("report").Eval(monitor_context).to_dict()
    result = executive.GetOutputPort("planning_result").Eval(executive_context)
    if failure is not None:
        report.update(finished=False, reason=failure, execution_time=context.get_time())
    planning_time = float(executive.GetOutputPort("planning_time").Eval(executive_context)[0])
    report.update(planning_time=planning_time, wall_time=wall, solver_restarts=restarts,
                  realtime_rate=context.get_time() / wall if wall > 0 else float("inf"),
                  simulated_time=context.get_time())
    html = None if meshcat is None else meshcat.StaticHtml()
    log = diagram.GetSubsystemByName("robot_state_log").FindLog(context)
    activity = Activity.of(log.sample_times().copy(), log.data().copy(),
                           robot=scenario.robot_value)
    report["time_by_motion"] = activity.by_motion()
    del simulator, executive, world, monitor, visualizer, executive_context, monitor_context
    del log
    release_diagram(diagram)
    return Execution(plan=plan, report=report, images=images, result=result, html=html,
                     activity=activity)
