"""Plan a scenario's task with S3O and execute it in a Drake simulation.

    s3o run scenarios/restaurant.yaml        (the same: python -m s3o_drake.run ...)

Perceives the unmapped chairs, computes every dish's Fea^m, plans and simulates the plan
with noise, recovering as --recovery says; writes report.json, plan.json, playback.html and
pictures to out/<scenario file stem>/ (--robot lcm: only the controllers run here, driving a
robot on a bus). Exit status: 0 every dish collected, 1 not, 2 bad input (nothing written).
"""

from __future__ import annotations

import dataclasses
import json
import logging
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from s3o_drake.commands.common import (
    MESHCAT_HOST,
    command_parser,
    fail,
    read_scenario,
    start_meshcat,
)
from s3o_drake.commands.options import (
    add_method,
    add_out,
    add_overrides,
    add_seed,
    out_folder,
    seconds,
    with_overrides_or_fail,
)

# Light imports only: --help and bad arguments answer before Drake, OpenCV, torch and
# matplotlib load (main imports them once the arguments are parsed).
from s3o_drake.execution.messages import ran_to_end
from s3o_drake.planning.plan import Goto, Place, TaskMotionPlan
from s3o_drake.world.choices import FEASIBILITY_SOURCES, RECOVERY_MODES
from s3o_drake.world.files import write_atomically
from s3o_drake.world.robot_channels import FIRST_STATE_WAIT, LOCAL_BUS
from s3o_drake.world.words import counted

if TYPE_CHECKING:
    from s3o_drake.execution.execute import Execution
    from s3o_drake.world.scenario import Scenario



def describe_plan(p: TaskMotionPlan) -> str:
    """The plan as a person reads it: one line per action, then the figures. Locations are
    named as in plan.json and state_space.png, stops numbered as in plan.png."""
    lines = [f"{p.method} plan (seed {p.seed}): {counted(len(p.gotos), 'stop')}, "
             f"{counted(len(p.pickups), 'pickup')}"
             + (f", {counted(len(p.places), 'place')}" if p.places else "")
             + (f", unreachable: {', '.join(p.unreachable)}" if p.unreachable else "")]
    stops = 0
    for i, a in enumerate(p.actions, 1):
        if isinstance(a, Goto):
            stops += 1
            x, y, yaw = a.pose
            lines.append(f"  {i:2d}. goto {a.location:<4} (stop {stops}) to ({x:5.2f}, "
                         f"{y:5.2f}) m, yaw {yaw:+.2f} rad, path {a.length:.2f} m")
        else:
            verb = "place" if isinstance(a, Place) else "pickup"
            lines.append(f"  {i:2d}. {verb} {a.dish} (Fea^m {a.feasibility:.2f})")
    t = p.timing
    if not p.actions:
        lines.append(f"  nothing to do: no dish can be picked from a free stop; planned in "
                     f"{p.planning_time:.2f} s")
        return "\n".join(lines)
    expected = ("" if p.expected_time is None
                else f" ({p.expected_time:.1f} s expected with the noise)")
    parts = ", ".join(f"{name.replace('_', ' ')} {t.get(name, 0):.2f}" for name in (
        "feasibility", "navigation", "abstraction", "task_planning", "motion_search"))
    lines.append(f"  expected utility {p.utility:.1f}, predicted execution time "
                 f"{p.predicted_time:.1f} s{expected}; planned in {p.planning_time:.2f} s "
                 f"({parts}); {p.searches} searches, {p.samples} samples"
                 + ("" if p.complete else "; the time budget cut the search short"))
    if p.order is not None:
        lines.append(f"  {p.order.describe()}")
    return "\n".join(lines)


def execution_time_line(predicted: float, simulated: float, *, first: str = "",
                        actions: int = 1, expected: float | None = None,
                        recoveries: Sequence[float] = ()) -> str:
    """The predicted execution time against the simulated one, said so that the sign cannot
    be misread: how much longer (or shorter) the simulation took than the plan said; with
    `expected` (the plan's expected time with the noise, for a run with the noise on),
    against that. `recoveries`: what each recovery of the run cost (s), which no prediction
    holds, so that a run with recoveries is not read as the time model's error."""
    if not actions:
        return "Execution time: nothing to execute (the plan has no actions)."
    if expected is not None:
        predicted, what = expected, ("the prediction is the plan with what the noise adds "
                                     "on average, every action done")
    else:
        what = "the prediction is the plan as planned: exact landings, every action done"
    if recoveries:
        n = len(recoveries)
        what += (f"; {n} {'recovery' if n == 1 else 'recoveries'}, which it leaves out, "
                 f"took {sum(recoveries):.1f} s")
    gap = simulated - predicted
    share = f" ({100 * abs(gap) / predicted:.1f} % of the prediction)" if predicted > 0 else ""
    return (f"Execution time: predicted {predicted:.1f} s{first}, simulated {simulated:.1f} s: "
            f"the simulation took {abs(gap):.1f} s{share} "
            f"{'longer' if gap >= 0 else 'less'} than predicted ({what}).")


def describe_execution(report: dict) -> str:
    """The execution's outcome: each action, then the summary line."""
    lines = ["Execution:"]
    # A record per finished pickup and place, in the order of their outcomes.
    predicted = iter(record["predicted"] for record in report.get("pickups", []))
    for i, (action, arg, outcome) in enumerate(report["outcomes"], 1):
        fea = next(predicted, None) if action in ("pickup", "place") else None
        lines.append(f"  {i:2d}. {action} {arg}: {outcome}"
                     + ("" if fea is None else f" (predicted Fea^m {fea:.2f})"))
    recoveries = report.get("recoveries", [])
    if recoveries:
        lines.append("Recoveries:")
    for r in recoveries:
        what = f"{r['kind']}{' ' + r['dish'] if r['dish'] else ''}"
        cost = f"{r['cost']:.1f} s" + (f", planning {r['planning_time']:.1f} s"
                                       if r["kind"] == "replan" else "")
        lines.append(f"  {what}: {r['trigger']} -> {r['action']}: {r['result']} ({cost})")
    if report.get("unreachable"):
        lines.append(f"Unreachable (no free pose of the known map can pick them): "
                     f"{', '.join(report['unreachable'])}")
    plans = 1 + sum(r["kind"] == "replan" for r in recoveries)
    placements = report.get("placements", [])
    for p in placements:
        where = ("at its place" if p["placed"] else "not at its place") + (
            f" ({100 * p['error']:.1f} cm from it, {'upright' if p['upright'] else 'tilted'})"
            if p["state"] == "placed" else f" ({p['state']})")
        lines.append(f"{p['object']} stands {where}")
    got = (f"Collected {report['collected']} and placed {report['placed']} of "
           f"{report['dishes']} objects" if placements else
           f"Collected {report['collected']} of {report['dishes']} dishes")
    lines.append(f"{got} in "
                 f"{report['execution_time']:.1f} s of execution (simulated); planning took "
                 f"{report['planning_time']:.2f} s"
                 + (f" in all ({plans} plans)" if plans > 1 else "")
                 + f"; simulated {report['simulated_time']:.1f} s in {report['wall_time']:.1f} s "
                 f"({report['realtime_rate']:.1f}x real time); {ending(report)}.")
    return "\n".join(lines)


def ending(report: dict) -> str:
    """Why the run ended, in words that are true: a plan that ran to its end says which
    objects it did not collect or place (a failed pickup is not "complete")."""
    if not ran_to_end(report["reason"]):
        return report["reason"]  # e.g. "goto l1 failed: blocked", "no plan: ..."
    done = set(report["collected_dishes"]) | {
        p["object"] for p in report.get("placements", []) if p["placed"]}
    unreachable = [d for d in report.get("unreachable", []) if d not in done]
    failed = sorted({dish for action, dish, outcome in report["outcomes"]
                     if action in ("pickup", "place") and outcome != "done"}
                    - done - set(unreachable))
    what = ("pickup or place", "pickups or places") if report.get("placements") else \
        ("pickup", "pickups")
    missed = [f"{counted(len(failed), *what)} failed ({', '.join(failed)})"] if failed else []
    if unreachable:
        missed.append(f"{counted(len(unreachable), 'dish', 'dishes')} unreachable "
                      f"({', '.join(unreachable)})")
    completed = report.get("completed", report["collected"])
    if not missed and completed == report["dishes"]:
        return ("plan ended: every object collected or placed" if report.get("placements")
                else "plan ended: every dish collected")
    return "plan ended: " + ("; ".join(missed) or
                             f"{report['dishes'] - completed} of {report['dishes']} not "
                             "collected or placed")


def _write_pictures(scenario: Scenario, run: Execution, plan: TaskMotionPlan | None,
                    out: Path) -> list[Path]:
    """The pictures of `plan` and what it was made on (the latest planning's result), so
    that they name its locations and stops as plan.json does."""
    from s3o_drake.viz.floor import Floor
    from s3o_drake.viz.pictures import (
        feasibility_figure,
        overhead_figure,
        plan_figure,
        search_figure,
        state_space_figure,
    )
    from s3o_drake.world.camera import overhead_camera

    written = []
    if run.activity is not None and len(run.activity.t):
        from s3o_drake.viz.timeline import timeline_figure

        report = run.report
        timeline_figure(run.activity, report["outcomes"], report["outcome_times"],
                        out / "timeline.png",
                        title=f"{scenario.execution.motion.replace('_', ' ')} motion")
        written.append(out / "timeline.png")
    camera = overhead_camera(scenario.room, scenario.camera)
    color, _depth = run.images
    if scenario.outputs.overhead:
        overhead_figure(scenario, camera, color, out / "overhead.png")
        written.append(out / "overhead.png")
    result = run.result
    heatmaps = list(result.heatmaps) if result is not None else []
    if not heatmaps and plan is None:
        return written
    # The floor as the plan knew it: the chairs it perceived, and (in the pictures of what
    # it believed) the true ones dashed beside them.
    perceived = result.known.perceived_chairs if result is not None else None
    pose = result.known.pose if result is not None else None
    believed = Floor.of(scenario, perceived=perceived, truth=True, robot_pose=pose)
    floor = dataclasses.replace(believed, true_chairs=())
    if heatmaps and scenario.outputs.feasibility:
        feasibility_figure(scenario, believed, heatmaps, out / "feasibility.png")
        written.append(out / "feasibility.png")
    # The state space only of the result that holds the plan (a replan that found none
    # leaves the plan before it, whose state space is not kept).
    made_on = result is not None and result.plan is plan
    if plan is not None and made_on and result.partition is not None \
            and scenario.outputs.state_space:
        state_space_figure(scenario, believed, result, out / "state_space.png")
        written.append(out / "state_space.png")
    if plan is not None:
        start = result.known.pose if made_on else None
        plan_figure(scenario, floor, plan, out / "plan.png", start=start)
        written.append(out / "plan.png")
        if plan.early_samples:
            search_figure(scenario, floor, heatmaps, plan, out / "search.png")
            written.append(out / "search.png")
    return written


def latest_plan(run: Execution) -> TaskMotionPlan | None:
    """The plan the outputs show: the latest one (after replans, the plan of what
    remained), or the one before it when a replan found none."""
    if run.result is not None and run.result.plan is not None:
        return run.result.plan
    return run.plan


def _run_on_bus(args, scenario: Scenario, seed: int, out: Path) -> int:
    """`s3o run --robot lcm`: the controllers here, the robot on the bus."""
    from pydrake.lcm import DrakeLcm

    from s3o_drake.execution.controller_process import NoRobotError, execute_on_bus

    try:
        lcm = DrakeLcm(args.lcm)
    except RuntimeError as e:
        fail(f"--lcm: {e}")
    try:
        run = execute_on_bus(scenario, lcm=lcm, method=args.method, seed=seed,
                             wait=args.wait, noise=not args.no_noise)
    except NoRobotError as e:
        print(f"{e}: is `s3o sim` running on {args.lcm}?", file=sys.stderr)
        return 1
    out.mkdir(parents=True, exist_ok=True)
    report = {"scenario": str(args.scenario), "method": args.method or scenario.planner.method,
              "feasibility": scenario.planner.feasibility, "seed": seed,
              "recovery": scenario.execution.recovery, "overrides": list(args.overrides),
              "noise": not args.no_noise, "robot": "lcm", "lcm": args.lcm, **run.report}
    write_atomically(out / "report.json", json.dumps(report, indent=1) + "\n")
    written = [out / "report.json"]
    plan = run.result.plan if run.result is not None and run.result.plan else run.plan
    if plan is not None:
        plan.write(out / "plan.json")
        written.append(out / "plan.json")
        print(describe_plan(plan))
    if run.images is not None:
        written += _write_pictures(scenario, run, plan, out)
    print(describe_execution(report))
    if not report["referee"]:
        print("No referee on the bus: the dishes are not counted (the robot's own "
              "simulation publishes them).")
    for path in written:
        print(f"  wrote {path}")
    return 0 if report["referee"] and report["completed"] == report["dishes"] else 1


def main(argv: list[str] | None = None, prog: str | None = None) -> int:
    """`s3o run`; `prog` names the command in its messages (the card's address,
    `python -m s3o_drake.run`, says its own)."""
    parser = command_parser("run", __doc__, prog)
    parser.add_argument("scenario", help="the scenario YAML file")
    add_method(parser, None, shown="the scenario's planner.method")
    add_seed(parser, None, "seed of all randomness")
    add_out(parser, file=False, text="output folder (default out/<scenario file stem>/)")
    parser.add_argument("--meshcat", action="store_true",
                        help="also serve a live Meshcat and simulate in real time")
    parser.add_argument("--host", default=MESHCAT_HOST,
                        help=f"the address Meshcat listens on (default {MESHCAT_HOST}: this "
                             "machine only; 0.0.0.0: every network interface)")
    parser.add_argument("--feasibility", choices=FEASIBILITY_SOURCES,
                        help="source of Fea^m: the Drake oracle or the network (default: the "
                             "scenario's planner.feasibility)")
    parser.add_argument("--recovery", choices=RECOVERY_MODES,
                        help="what execution does when an action fails (default: the "
                             "scenario's execution.recovery, replan unless it says otherwise)")
    parser.add_argument("--no-noise", action="store_true",
                        help="simulate without navigation and reaching noise")
    add_overrides(parser, "replace a field of the scenario, e.g. planner.top_k=8 or "
                          "uncertainty.nav_xy_std=0.2 (repeatable)")
    parser.add_argument("--robot", choices=("sim", "lcm"), default="sim",
                        help="sim (default): simulated here; lcm: the robot on --lcm (s3o sim)")
    parser.add_argument("--lcm", default=LOCAL_BUS, metavar="URL",
                        help="with --robot lcm: the bus (default s3o sim's, this machine's)")
    parser.add_argument("--wait", type=seconds, default=FIRST_STATE_WAIT, metavar="S",
                        help=f"with --robot lcm: seconds to wait for the robot (default "
                             f"{FIRST_STATE_WAIT:g})")
    args = parser.parse_args(argv)
    if args.robot == "lcm" and not args.lcm.startswith("udpm://"):
        fail(f"--lcm: expected a udpm:// URL, got {args.lcm!r} (memq:// stays inside one "
             "process, and the robot runs in another)")
    if args.robot == "lcm" and args.meshcat:
        fail("--meshcat: with --robot lcm the world is the robot's, not this process's")

    from s3o_drake.world.scenario import scenario_stem

    scenario = with_overrides_or_fail(read_scenario(args.scenario), args.overrides)
    if not any(d.goal != "stay" for d in scenario.dishes):
        fail(f"{args.scenario}: dishes: none to collect or place (an empty file is all "
             "defaults: a room without tables or dishes)")
    if args.feasibility is not None:
        scenario = dataclasses.replace(scenario, planner=dataclasses.replace(
            scenario.planner, feasibility=args.feasibility))
    if args.recovery is not None:
        scenario = dataclasses.replace(scenario, execution=dataclasses.replace(
            scenario.execution, recovery=args.recovery))
    from s3o_drake.planning.robot_files import missing_robot_files

    missing = missing_robot_files(scenario.settings, scenario.robot_value)
    if missing:
        fail(missing[0])
    seed = scenario.seed if args.seed is None else args.seed
    out = out_folder(args.out or scenario.outputs.directory
                     or Path("out") / scenario_stem(args.scenario))

    if args.robot == "lcm":
        return _run_on_bus(args, scenario, seed, out)

    from s3o_drake.execution.execute import execute

    if not args.meshcat:  # the recording needs a Meshcat, but nobody is watching it live
        logging.getLogger("drake").setLevel(logging.WARNING)
    meshcat = start_meshcat(args.host)
    if args.meshcat:
        print(f"Meshcat: {meshcat.web_url()}", flush=True)
    run = execute(scenario, method=args.method, seed=seed, meshcat=meshcat,
                  realtime=args.meshcat, noise=not args.no_noise)

    out.mkdir(parents=True, exist_ok=True)
    report = {"scenario": str(args.scenario), "method": args.method or scenario.planner.method,
              "feasibility": scenario.planner.feasibility, "seed": seed,
              "recovery": scenario.execution.recovery, "overrides": list(args.overrides),
              "noise": not args.no_noise, **run.report}
    write_atomically(out / "report.json", json.dumps(report, indent=1) + "\n")
    written = [out / "report.json"]
    plan = latest_plan(run)
    if plan is not None:
        plan.write(out / "plan.json")
        written.append(out / "plan.json")
    if scenario.outputs.playback:
        write_atomically(out / "playback.html", run.html)
        written.append(out / "playback.html")
    written += _write_pictures(scenario, run, plan, out)

    recoveries = report.get("recoveries", [])
    plans = 1 + sum(r["kind"] == "replan" for r in recoveries)
    if plan is not None:
        if plans > 1:
            print(f"The latest of {plans} plans (plan.json; the execution below lists the "
                  "actions of every plan):")
        print(describe_plan(plan))
    print(describe_execution(report))
    if run.plan is not None:
        # The prediction made before the execution began: the first plan's.
        predicted, simulated = run.plan.predicted_time, report["execution_time"]
        first = f" by the first of {plans} plans" if plans > 1 else ""
        print(execution_time_line(predicted, simulated, first=first,
                                  actions=len(run.plan.actions),
                                  expected=run.plan.expected_time if report["noise"] else None,
                                  recoveries=[r["cost"] for r in recoveries]))
    for path in written:
        print(f"  wrote {path}")
    if args.meshcat and sys.stdin.isatty():
        input("Meshcat is still serving; press Enter to exit.")
    return 0 if report["completed"] == report["dishes"] else 1


if __name__ == "__main__":
    sys.exit(main())
