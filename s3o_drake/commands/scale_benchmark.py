"""5 to 40 dishes: planning time by stage, task orders against the optimum.

    s3o bench scale [--dishes 5 10 15 20 30 40] [--count 3] [--execute] [--json FILE]

Plans each task of scenarios/generated_scale/dishes_NN/ as `s3o run` plans it and compares
clingo's best order of every state space with the exact optimum of the same ordering
problem (HiGHS); --execute also simulates each plan. Prints a line per task and per size
the median plan time and stages, clingo's time, the orders above the optimum, completion,
and from 30 dishes on the targets (docs/planning.md).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path
from typing import Any

# Light imports only: the heavy ones come after the arguments are parsed.
from s3o_drake.commands.common import command_parser, fail, read_scenario
from s3o_drake.commands.options import (
    add_json,
    add_method,
    add_seed,
    at_least,
    json_store,
    one_robot,
    seconds,
)
from s3o_drake.world.resources import REPO_DIR, repo_path

TASKS_DIR = REPO_DIR / "scenarios" / "generated_scale"
SIZES = (5, 10, 15, 20, 30, 40)


def row_key(row: dict[str, Any]) -> str:
    """A task's row is reused for the same task, method, seed and --execute."""
    return "|".join(str(row[k]) for k in ("task", "method", "seed", "execute"))


def plan_task_row(path: Path, *, method: str, seed: int | None, execute: bool,
                  reference_limit: float) -> dict[str, Any]:
    """One task's row: its planning figures (`evaluation.scale.plan_row`), and with
    `execute` what the simulated run collected."""
    from s3o_drake.belief import perceive_known_world
    from s3o_drake.belief.known_world import Briefing
    from s3o_drake.experiments.scale import plan_row
    from s3o_drake.planning.pipeline import plan_from
    from s3o_drake.world.builder import render_overhead

    scenario = read_scenario(path)
    seed = scenario.seed if seed is None else seed
    row: dict[str, Any] = {"task": repo_path(path), "dishes": len(scenario.dishes),
                           "chairs": len(scenario.chairs), "method": method, "seed": seed,
                           "workers": scenario.planner.workers,
                           "budget": scenario.planner.time_budget, "execute": execute}
    start = time.perf_counter()
    color, depth, label, robot_labels = render_overhead(scenario)
    t0 = time.perf_counter()  # the run's planning time starts at perception too
    known = perceive_known_world(Briefing.of(scenario), (color, depth, label),
                                 pose=scenario.robot.start,
                                 dishes=[d.name for d in scenario.dishes],
                                 robot_labels=robot_labels)
    result = plan_from(known, method=method, seed=seed, started=t0)
    if execute:
        # The run plans again, the same way (the same plan unless the clock cut a search),
        # and may replan on the way: its result is its last plan's, so the planning
        # figures are the plan's above.
        from s3o_drake.execution.execute import execute as run

        report = run(scenario, method=method, seed=seed, meshcat=None, progress=False).report
        row.update(collected=report["collected"], execution_time=report["execution_time"],
                   finished=bool(report.get("finished", True)),
                   replans=len(report["plans"]) - 1,
                   run_planning_s=report["plans"][0]["planning_time"] if report["plans"]
                   else None)
    row.update(plan_row(result, reference_limit=reference_limit))
    row["wall_s"] = time.perf_counter() - start
    return row


def _print_row(r: dict[str, Any]) -> None:
    name = Path(r["task"]).parent.name + "/" + Path(r["task"]).stem
    if "error" in r:
        print(f"{name:<24} {r['dishes']:>2} dishes  FAILED: {r['error']}", flush=True)
        return
    spaces = r["state_spaces"]
    above = [s["above"] for s in spaces if s["above"] is not None]
    clingo = max((s["task_s"] for s in spaces), default=0.0)
    exact = max((s["reference_s"] or 0.0 for s in spaces), default=0.0)
    ran = (f"  collected {r['collected']}/{r['dishes']}" if "collected" in r else "")
    print(f"{name:<24} {r['dishes']:>2} dishes  plan {r['planning_s']:5.2f} s "
          f"(task planning {r['timing']['task_planning']:5.2f}, motion search "
          f"{r['timing']['motion_search']:5.2f})  {len(spaces)} state spaces, "
          f"clingo <= {clingo:4.2f} s (exact {exact:4.2f} s), proven "
          f"{sum(s['proven'] for s in spaces)}/{len(spaces)}, above optimum <= "
          f"{max(above, default=0.0):.2%}{ran}", flush=True)


def main(argv: list[str] | None = None) -> int:
    parser = command_parser("bench scale", __doc__)
    parser.add_argument("--dishes", type=int, nargs="+", default=list(SIZES), metavar="N",
                        help=f"the task sizes, folders dishes_NN of --tasks-dir (default "
                             f"{' '.join(map(str, SIZES))})")
    parser.add_argument("--count", type=at_least(1), default=3, metavar="N",
                        help="the first N tasks of each size (default 3)")
    parser.add_argument("--tasks-dir", default=str(TASKS_DIR), metavar="DIR",
                        help="where the dishes_NN folders are (default "
                             "scenarios/generated_scale)")
    add_method(parser)
    add_seed(parser, None, "planning seed")
    parser.add_argument("--execute", action="store_true",
                        help="also simulate each plan and count the dishes collected")
    parser.add_argument("--reference-limit", type=seconds, default=120.0, metavar="S",
                        help="time limit of the exact solution per state space (default 120)")
    add_json(parser, "task")
    parser.add_argument("--markdown", action="store_true",
                        help="print the summary as a Markdown table too")
    args = parser.parse_args(argv)
    paths: list[Path] = []
    for size in args.dishes:
        folder = Path(args.tasks_dir) / f"dishes_{size:02d}"
        found = sorted(folder.glob("task_*.yaml"))
        if len(found) < args.count:
            fail(f"--dishes: {folder} has {len(found)} tasks, {args.count} needed (make them "
                 f"with: s3o generate --dishes {size} --chairs 5 --count {args.count} "
                 f"--seed 0 --out {folder})")
        paths += found[:args.count]
    scenarios = {path: read_scenario(path) for path in paths}
    seeds = {path: s.seed if args.seed is None else args.seed for path, s in scenarios.items()}
    store = json_store(args, key=row_key, robot=one_robot(scenarios.items()))

    import logging

    from s3o_drake.experiments.scale import summarize, summary_table, target_lines

    logging.getLogger("drake").setLevel(logging.WARNING)
    rows = []
    print(f"{len(paths)} tasks, {args.method}" + (", executed" if args.execute else ""),
          flush=True)
    for path in paths:
        key = row_key({"task": repo_path(path), "method": args.method, "seed": seeds[path],
                       "execute": args.execute})
        row = store.get(key) if store is not None and store.finished(key) else None
        if row is None:
            row = plan_task_row(path, method=args.method, seed=args.seed,
                                execute=args.execute, reference_limit=args.reference_limit)
            if store is not None:
                row = store.append({"key": key, **row})
        rows.append(row)
        _print_row(row)
    summary = summarize(rows)
    print()
    print(summary_table(summary) if args.markdown else "\n".join(
        f"{size:>2} dishes: plan {s['plan_s']:.2f} s (median), clingo per state space "
        f"{s['task_s_median']:.2f} s median / {s['task_s_max']:.2f} s max (exact "
        f"{s['reference_s']:.2f} s), proven {s['proven']:.0%}, above optimum "
        f"{s['above_median']:.2%} median / {s['above_max']:.2%} max, completion "
        + (f"{s['completion']:.2f}" if s["executed"] else "not executed")
        for size, s in summary.items()))
    for line in target_lines(summary):
        print(line)
    return 0


if __name__ == "__main__":
    sys.exit(main())
