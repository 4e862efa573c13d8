"""Benchmark the planner at scale: 5 to 40 dishes, planning time by stage, the task
planner's orders against the exact optimum, and (--execute) executed completion.

    python -m s3o_drake.commands.scale_benchmark --json docs/scale/scale.jsonl

The tasks are scenarios/generated_scale/dishes_NN/task_*.yaml (--tasks-dir), NN dishes on
the restaurant's tables and 5 chairs off the map near 5 of them, made by

    python -m s3o_drake.commands.generate --dishes NN --chairs 5 --count 3 --seed 0 \\
        --out scenarios/generated_scale/dishes_NN

Each task is planned as `run` plans it: the overhead camera's images, the chairs that
perception finds, Fea^m from the planner's settings, then the method (default S3O-GROP*)
with the scenario's budget and workers. For every state space that clingo ordered, its
best order is compared with the exact optimum of the same ordering problem on the same
costs, solved by an integer program (HiGHS, `planning.exact_order`): "above" is how far
clingo's order lies above it. The exact solver's time is printed beside clingo's, the
reference measured in the same run. With --execute, each task is also run as `run` runs
it (planned again the same way, simulated, replanned where the scenario's recovery says
so), and the dishes collected are counted.

Prints a line per task, then per size: the median plan time and its stages, clingo's time
per state space (median and max), the orders proven, the orders above the optimum (median
and max), completion, and from 30 dishes on, the targets (docs/planning.md): task planning
at most 2 s per state space, every order within 2 % of the optimum, the whole plan at most
5 s (median). --markdown prints the summary as the table docs/planning.md shows.

--json FILE: a JSON line per task, appended as soon as it is done; run again with the
same file and settings and the tasks already there are read back, not run again. --fresh
starts the file over.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path
from typing import Any

from s3o_drake.commands.common import (
    ArgumentParser,
    doc_formatter,
    fail,
    finished_rows,
    read_scenario,
)

# Light imports only: the heavy ones come after the arguments are parsed.
from s3o_drake.world.choices import METHODS
from s3o_drake.world.resources import REPO_DIR

TASKS_DIR = REPO_DIR / "scenarios" / "generated_scale"
SIZES = (5, 10, 15, 20, 30, 40)


def _name(path: Path) -> str:
    """A task's name in the rows: its path from the repository when it lies in it."""
    try:
        return str(path.resolve().relative_to(REPO_DIR))
    except ValueError:
        return str(path)


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
    row: dict[str, Any] = {"task": _name(path), "dishes": len(scenario.dishes),
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
    parser = ArgumentParser(prog="python -m s3o_drake.commands.scale_benchmark",
                            description=__doc__, formatter_class=doc_formatter())
    parser.add_argument("--dishes", type=int, nargs="+", default=list(SIZES), metavar="N",
                        help=f"the task sizes (default {' '.join(map(str, SIZES))}): "
                             "the folders dishes_NN of --tasks-dir")
    parser.add_argument("--count", type=int, default=3,
                        help="tasks per size, the first of each folder (default 3)")
    parser.add_argument("--tasks-dir", default=str(TASKS_DIR), metavar="DIR",
                        help="where the dishes_NN folders are (default "
                             "scenarios/generated_scale)")
    parser.add_argument("--method", default="S3O-GROP*",
                        help=f"one of {', '.join(METHODS)} (default S3O-GROP*)")
    parser.add_argument("--seed", type=int, help="planning seed (default: each task's own)")
    parser.add_argument("--execute", action="store_true",
                        help="also simulate each plan and count the dishes collected")
    parser.add_argument("--reference-limit", type=float, default=120.0, metavar="S",
                        help="time limit of the exact solution, per state space (default 120)")
    parser.add_argument("--json", metavar="FILE", help="append a JSON line per task (resumes)")
    parser.add_argument("--fresh", action="store_true", help="start the --json file over")
    parser.add_argument("--markdown", action="store_true",
                        help="print the summary as a Markdown table too")
    args = parser.parse_args(argv)
    if args.method not in METHODS:
        fail(f"--method: must be one of {', '.join(METHODS)}, got {args.method!r}")
    if args.count < 1:
        fail(f"--count: must be at least 1, got {args.count}")
    if args.seed is not None and args.seed < 0:
        fail(f"--seed: must be a non-negative integer, got {args.seed}")
    if not args.reference_limit > 0:
        fail(f"--reference-limit: must be positive, got {args.reference_limit}")
    paths: list[Path] = []
    for size in args.dishes:
        folder = Path(args.tasks_dir) / f"dishes_{size:02d}"
        found = sorted(folder.glob("task_*.yaml"))
        if len(found) < args.count:
            fail(f"--dishes: {folder} has {len(found)} tasks, {args.count} needed (make them "
                 f"with: python -m s3o_drake.commands.generate --dishes {size} --chairs 5 "
                 f"--count {args.count} --seed 0 --out {folder})")
        paths += found[:args.count]

    import logging

    from s3o_drake.experiments.scale import summarize, summary_table, target_lines

    logging.getLogger("drake").setLevel(logging.WARNING)
    settings = {"method": args.method, "seed": args.seed, "execute": args.execute}
    out = None
    done: dict[str, dict[str, Any]] = {}
    if args.json:
        target = Path(args.json)
        target.parent.mkdir(parents=True, exist_ok=True)
        if args.fresh:
            target.write_text("")
        done = finished_rows(target, {k: v for k, v in settings.items() if v is not None})
        out = target.open("a")
    rows = []
    print(f"{len(paths)} tasks, {args.method}" + (", executed" if args.execute else ""),
          flush=True)
    try:
        for path in paths:
            row = done.get(_name(path))
            if row is None:
                row = plan_task_row(path, method=args.method, seed=args.seed,
                                    execute=args.execute, reference_limit=args.reference_limit)
                if out is not None:
                    out.write(json.dumps(row) + "\n")
                    out.flush()
            rows.append(row)
            _print_row(row)
    finally:
        if out is not None:
            out.close()
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
