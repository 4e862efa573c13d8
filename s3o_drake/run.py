"""Plan a scenario's task with S3O (or a baseline), simulate it in Drake, save what happened.

    python -m s3o_drake.run scenarios/restaurant.yaml [--method NAME] [--seed N]

Loads and validates the scenario, builds the restaurant and the mobile manipulator in a
Drake diagram (MultibodyPlant, SceneGraph, overhead RgbdSensor, Meshcat), computes every
dish's Fea^m heatmap with the Drake feasibility check, and plans with the chosen method
(default: the scenario's `planner.method`, S3O-GROP*): the methods are S3O-GROP*,
S3O-GROP, V-GROP*, V-GROP, V-PETLON and S3O-Random. It prints the plan and writes it.
Until execution lands, the simulated robot holds its start pose for
`simulation.hold_time` simulated seconds. Until perception lands, the planner is given
the scenario's unmapped chairs as if the overhead camera had found them.

Outputs, in `out/<scenario file stem>/` unless --out or `outputs.directory` says otherwise:
  playback.html   a self-contained Meshcat recording; open it in a browser
  overhead.png    the overhead camera's colour image at the start
  feasibility.png each dish's Fea^m heatmap (4 m x 4 m, 64 x 64 cells, from the Drake
                  feasibility check under the scenario's noise) over a top view of the room
  state_space.png the top-ranked S3O state space (Voronoi cells of the free base positions,
                  merged where that scores best) over the same heatmaps
  plan.json       the task-motion plan (actions, base poses, paths, expected utility,
                  predicted time, Fea^m per pickup, planning time and its breakdown)
  plan.png        the plan over the top view: paths, stops, which dish from which stop
  search.png      the winning CMA-ES search's first and last generation (the paper's Fig. 4)

Exit status: 0 on success, 1 when no plan could be made (the reason is printed), 2 on bad
input (one line on stderr naming the field; nothing is written).
"""

import logging
import shutil
import subprocess
import sys
import time
from pathlib import Path

import cv2
import numpy as np
from pydrake.geometry import Meshcat
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import Diagram, DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource

from s3o_drake.abstraction import build_abstraction
from s3o_drake.camera import orthophoto, overhead_camera
from s3o_drake.cli import ArgumentParser, doc_formatter, fail
from s3o_drake.feasibility.heatmaps import compute_heatmaps
from s3o_drake.io import write_atomically
from s3o_drake.pictures import (
    feasibility_figure,
    plan_figure,
    search_figure,
    state_space_figure,
)
from s3o_drake.planning.plan import Goto, TaskMotionPlan
from s3o_drake.planning.planner import METHODS, PlanningError, plan
from s3o_drake.planning.task_planner import TaskPlanningError
from s3o_drake.scenario import Scenario, ScenarioError, load_scenario, scenario_stem
from s3o_drake.world import build_world_diagram, robot_hold_state

TOP_VIEW_CELL = 0.02  # m per pixel of the pictures' top view
DIAGRAMS_DIR = Path(__file__).resolve().parent.parent / "diagrams"


def build_run_diagram(scenario: Scenario, *, meshcat: Meshcat | None) -> Diagram:
    """The world with a source that holds the robot at its start pose ("s3o_run")."""
    builder = DiagramBuilder()
    world = builder.AddNamedSystem("world", build_world_diagram(scenario, meshcat=meshcat))
    hold = builder.AddNamedSystem("robot_hold", ConstantVectorSource(robot_hold_state(scenario)))
    builder.Connect(hold.get_output_port(), world.GetInputPort("robot_desired_state"))
    diagram = builder.Build()
    diagram.set_name("s3o_run")
    return diagram


def overhead_images(diagram: Diagram, context) -> tuple[np.ndarray, np.ndarray]:
    """The overhead camera's colour (RGB) and depth (m) images."""
    world = diagram.GetSubsystemByName("world")
    world_context = world.GetMyContextFromRoot(context)
    color = world.GetOutputPort("overhead_color_image").Eval(world_context)
    depth = world.GetOutputPort("overhead_depth_image").Eval(world_context)
    return np.array(color.data[:, :, :3], copy=True), np.array(depth.data[:, :, 0], copy=True)


def frame_room(meshcat: Meshcat, scenario: Scenario) -> None:
    """Points Meshcat's camera at the room from above its south edge, so that the whole
    restaurant is in view when the page opens (the default camera sits outside the walls)."""
    x_min, y_min, x_max, y_max = scenario.room.bounds
    center = np.array([(x_min + x_max) / 2, (y_min + y_max) / 2, 0.0])
    span = max(x_max - x_min, y_max - y_min)
    meshcat.SetCameraPose(center + np.array([0.0, -0.75 * span, 0.9 * span]), center)


def write_graphviz(diagram: Diagram, directory: Path, name: str) -> list[Path]:
    """Writes the diagram's Graphviz source, and an SVG when `dot` is installed."""
    directory.mkdir(parents=True, exist_ok=True)
    dot = directory / f"{name}.dot"
    dot.write_text(diagram.GetGraphvizString(max_depth=2))
    written = [dot]
    if shutil.which("dot"):
        svg = dot.with_suffix(".svg")
        subprocess.run(["dot", "-Tsvg", str(dot), "-o", str(svg)], check=True)
        written.append(svg)
    return written


def simulate(scenario: Scenario, *, meshcat: Meshcat, realtime: bool = False) -> tuple:
    """Builds and runs the diagram; returns (diagram, (colour, depth) images, playback HTML)."""
    diagram = build_run_diagram(scenario, meshcat=meshcat)
    frame_room(meshcat, scenario)
    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    simulator.Initialize()
    images = overhead_images(diagram, context)
    visualizer = diagram.GetSubsystemByName("world").GetSubsystemByName("meshcat_visualizer")
    visualizer.StartRecording(set_transforms_while_recording=realtime)
    if realtime:
        simulator.set_target_realtime_rate(1.0)
    simulator.AdvanceTo(scenario.simulation.hold_time)
    visualizer.StopRecording()
    visualizer.PublishRecording()
    return diagram, images, meshcat.StaticHtml()


def describe_plan(p: TaskMotionPlan) -> str:
    """The plan as a person reads it: one line per action, then the figures."""
    lines = [f"{p.method} plan (seed {p.seed}): {len(p.gotos)} stops, {len(p.pickups)} pickups"
             + (f", unreachable: {', '.join(p.unreachable)}" if p.unreachable else "")]
    for i, a in enumerate(p.actions, 1):
        if isinstance(a, Goto):
            x, y, yaw = a.pose
            lines.append(f"  {i:2d}. goto {a.location:<4} to ({x:5.2f}, {y:5.2f}) m, "
                         f"yaw {yaw:+.2f} rad, path {a.length:.2f} m")
        else:
            lines.append(f"  {i:2d}. pickup {a.dish} (Fea^m {a.feasibility:.2f})")
    t = p.timing
    lines.append(f"  expected utility {p.utility:.1f}, predicted execution time "
                 f"{p.predicted_time:.1f} s; planned in {p.planning_time:.2f} s (feasibility "
                 f"{t.get('feasibility', 0):.2f}, navigation {t.get('navigation', 0):.2f}, "
                 f"abstraction {t.get('abstraction', 0):.2f}, task planning "
                 f"{t.get('task_planning', 0):.2f}, motion search "
                 f"{t.get('motion_search', 0):.2f}); {p.searches} searches, {p.samples} samples"
                 + ("" if p.complete else "; the time budget cut the search short"))
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = ArgumentParser(prog="python -m s3o_drake.run", description=__doc__,
                            formatter_class=doc_formatter())
    parser.add_argument("scenario", help="the scenario YAML file")
    parser.add_argument("--out", metavar="DIR",
                        help="output folder (default: out/<scenario file stem>/)")
    parser.add_argument("--meshcat", action="store_true",
                        help="also serve a live Meshcat, print its URL and simulate in real "
                             "time so that it can be watched")
    parser.add_argument("--method", metavar="NAME",
                        help=f"planning method, one of {', '.join(METHODS)} "
                             "(default: the scenario's planner.method)")
    parser.add_argument("--seed", type=int, metavar="N",
                        help="seed of all randomness (default: the scenario's seed)")
    parser.add_argument("--graphviz", action="store_true",
                        help="write the diagram's Graphviz (.dot, and .svg when Graphviz is "
                             f"installed) under {DIAGRAMS_DIR.name}/")
    args = parser.parse_args(argv)

    try:
        scenario = load_scenario(args.scenario)
    except ScenarioError as e:
        fail(f"{args.scenario}: {e}")
    if args.method is not None and args.method not in METHODS:
        fail(f"--method: unknown method {args.method!r}; one of {', '.join(METHODS)}")
    method = args.method or scenario.planner.method
    seed = scenario.seed if args.seed is None else args.seed
    if seed < 0:
        fail(f"--seed: must be a non-negative integer, got {seed}")
    out = Path(args.out or scenario.outputs.directory or Path("out") / scenario_stem(args.scenario))
    if out.exists() and not out.is_dir():
        fail(f"--out: {out} exists and is not a folder")

    if not args.meshcat:  # the recording needs a Meshcat, but nobody is watching it live
        logging.getLogger("drake").setLevel(logging.WARNING)
    meshcat = Meshcat()
    if args.meshcat:
        print(f"Meshcat: {meshcat.web_url()}", flush=True)
    start = time.perf_counter()
    diagram, (color, depth), html = simulate(scenario, meshcat=meshcat, realtime=args.meshcat)
    elapsed = time.perf_counter() - start
    # Until perception lands, the planner "perceives" the scenario's unmapped chairs.
    chairs = [list(c.pose) for c in scenario.chairs if not c.mapped]
    heatmaps, task_plan, planning_failure = [], None, None
    if scenario.dishes:
        # In this process: the collision checker already spreads its batches over the
        # cores, and worker processes would only add their start-up.
        t = time.perf_counter()
        heatmaps = compute_heatmaps(scenario, seed=seed, workers=1)
        feasibility_time = time.perf_counter() - t
        try:
            task_plan = plan(scenario, method=method, heatmaps=heatmaps, perceived_chairs=chairs,
                             seed=seed, workers=scenario.planner.workers,
                             feasibility_time=feasibility_time)
        except (PlanningError, TaskPlanningError) as e:
            planning_failure = str(e)
    draw_state_space = scenario.outputs.state_space and bool(scenario.dishes)

    out.mkdir(parents=True, exist_ok=True)
    written = []
    if scenario.outputs.overhead:
        _, png = cv2.imencode(".png", cv2.cvtColor(color, cv2.COLOR_RGB2BGR))
        write_atomically(out / "overhead.png", png.tobytes())
        written.append(out / "overhead.png")
    if scenario.outputs.playback:
        write_atomically(out / "playback.html", html)
        written.append(out / "playback.html")
    if heatmaps:
        top_view = orthophoto(overhead_camera(scenario), color, depth, scenario.room.bounds,
                              TOP_VIEW_CELL)
        if scenario.outputs.feasibility:
            feasibility_figure(scenario, top_view, heatmaps, out / "feasibility.png")
            written.append(out / "feasibility.png")
        if draw_state_space:
            # Until perception lands, the planner "perceives" the scenario's chairs.
            abstraction = build_abstraction(scenario, heatmaps, perceived_chairs=chairs,
                                            seed=seed)
            state_space_figure(scenario, top_view, heatmaps, abstraction,
                               out / "state_space.png")
            written.append(out / "state_space.png")
        if task_plan is not None:
            task_plan.write(out / "plan.json")
            plan_figure(scenario, top_view, task_plan, out / "plan.png")
            written += [out / "plan.json", out / "plan.png"]
            if task_plan.early_samples:
                search_figure(scenario, top_view, heatmaps, task_plan, out / "search.png")
                written.append(out / "search.png")
    if args.graphviz:
        written += write_graphviz(diagram, DIAGRAMS_DIR, "run")

    print(f"Simulated {scenario.simulation.hold_time:g} s of {scenario_stem(args.scenario)} "
          f"in {elapsed:.1f} s wall time.")
    if task_plan is not None:
        print(describe_plan(task_plan))
    elif planning_failure is not None:
        print(f"No plan: {planning_failure}")
    for path in written:
        print(f"  wrote {path}")
    if args.meshcat and sys.stdin.isatty():
        input("Meshcat is still serving; press Enter to exit.")
    return 1 if planning_failure is not None else 0


if __name__ == "__main__":
    sys.exit(main())
