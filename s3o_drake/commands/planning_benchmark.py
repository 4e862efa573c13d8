"""Benchmark the planner: planning time per task at the paper's sample counts, broken down,
and the plan's utility against a run with 10x the samples per sequence.

    python -m s3o_drake.commands.planning_benchmark --tasks 10 --method S3O-GROP* --seed 0

For each of the first N shipped tasks (scenarios/generated/task_*.yaml, 5-7 dishes each;
or the files given with --scenarios):

1. the feasibility heatmaps (Fea^m) of every dish, timed as "feasibility": in this process,
   whose collision checker already spreads its batches over the cores (worker processes
   would only add their start-up); the reachability map is loaded and prepared once
   before the first task and that one-time start-up is reported apart;
2. `plan` with the method at the scenario's sample counts (the paper's: 20 CMA-ES
   generations x 10 per sequence), timed, with the planner's own breakdown: feasibility,
   navigation, abstraction, task_planning, motion_search;
3. `plan` again on the same task, seed and heatmaps with --factor (default 10) times the
   CMA-ES generations, i.e. 10x the samples per sequence: the long run.

Both plans search on --workers processes (forked by the planner).

The utility ratio is the paper-count utility / the long-run utility (1.0: no loss; above
1: the short run happened to do better). The time budget is the scenario's, a cap, not a
target. The unmapped chairs of a scenario count as perceived.

Prints a per-task table and the summary: median planning time with the heatmaps excluded
and included (target: median <= 5 s on 2 cores) and the median and worst utility ratio
(target: within 5 %, ratio >= 0.95). A task whose planning fails is listed with its error
and left out of the medians.

--json FILE: one JSON line per task is appended (and flushed) as soon as the task is done,
then a {"summary": {...}} line. Run again with the same file and settings and it resumes:
tasks already in the file (same method, seed, workers and factor) are read back, not
planned again, and the summary covers all of them. --fresh starts the file over.
"""

from __future__ import annotations

import dataclasses
import json
import math
import statistics
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO

from s3o_drake.commands.common import (
    ArgumentParser,
    doc_formatter,
    fail,
    finished_rows,
    task_scenarios,
)

# Light imports only: the heavy ones come after the arguments are parsed.
from s3o_drake.world.choices import METHODS

if TYPE_CHECKING:
    from s3o_drake.world.scenario import Scenario

STAGES = ("feasibility", "navigation", "abstraction", "task_planning", "motion_search")
TIME_TARGET = 5.0
"""Target median planning time (s), on 2 cores."""
RATIO_TARGET = 0.95
"""Target utility ratio: within 5 % of the long run."""


def long_run(scenario: Scenario, factor: int) -> Scenario:
    """A copy of the scenario with `factor` times the CMA-ES generations per sequence."""
    planner = dataclasses.replace(scenario.planner,
                                  cma_generations=scenario.planner.cma_generations * factor)
    return dataclasses.replace(scenario, planner=planner)


def benchmark_task(name: str, scenario: Scenario, *, method: str, seed: int, workers: int,
                   factor: int) -> dict[str, Any]:
    """One task's row: heatmaps, the paper-count plan, the long run, their utility ratio."""
    from s3o_drake.belief.known_world import KnownWorld
    from s3o_drake.feasibility.heatmaps import compute_heatmaps
    from s3o_drake.planning.pipeline import plan_from

    row: dict[str, Any] = {"task": name, "dishes": len(scenario.dishes), "method": method,
                           "seed": seed, "workers": workers, "factor": factor}
    # The planner is given the scenario's unmapped chairs exactly: this benchmark measures
    # planning (perception has its own, s3o_drake.commands.perception_benchmark).
    known = KnownWorld.perfect(scenario)
    start = time.perf_counter()
    heatmaps = compute_heatmaps(known, workers=1, progress=False,
                                obstacles=known.obstacles)
    feasibility = time.perf_counter() - start
    short_result = plan_from(known, method=method, heatmaps=heatmaps, seed=seed,
                             workers=workers, started=start)
    long_result = plan_from(KnownWorld.perfect(long_run(scenario, factor)), method=method,
                            heatmaps=heatmaps, seed=seed, workers=workers)
    short, long = short_result.plan, long_result.plan
    if short is None or long is None:
        row["error"] = short_result.error or long_result.error
        row["feasibility_s"] = feasibility
        return row
    row.update({
        "planning_s": short.planning_time - feasibility,
        "planning_with_feasibility_s": short.planning_time,
        "timing": {k: short.timing.get(k, 0.0) for k in STAGES},
        "utility": short.utility,
        "samples": short.samples,
        "complete": short.complete,
        "long_planning_s": long.planning_time,
        "long_utility": long.utility,
        "long_samples": long.samples,
        "long_complete": long.complete,
        "utility_ratio": short.utility / long.utility if long.utility > 0 else math.nan,
    })
    return row


def summarize(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Medians over the tasks that planned (NaN ratios left out)."""
    ok = [r for r in rows if "error" not in r]
    ratios = [r["utility_ratio"] for r in ok if not math.isnan(r["utility_ratio"])]
    times = [r["planning_s"] for r in ok]
    times_all = [r["planning_with_feasibility_s"] for r in ok]
    nan = math.nan
    summary = {
        "tasks": len(rows),
        "planned": len(ok),
        "failed": [r["task"] for r in rows if "error" in r],
        "median_planning_s": statistics.median(times) if times else nan,
        "median_planning_with_feasibility_s": statistics.median(times_all) if times_all else nan,
        "median_timing": {k: statistics.median(r["timing"][k] for r in ok) if ok else nan
                          for k in STAGES},
        "median_utility_ratio": statistics.median(ratios) if ratios else nan,
        "worst_utility_ratio": min(ratios) if ratios else nan,
    }
    summary["time_target_met"] = summary["median_planning_s"] <= TIME_TARGET
    summary["time_target_met_with_feasibility"] = (
        summary["median_planning_with_feasibility_s"] <= TIME_TARGET)
    summary["utility_target_met"] = bool(ratios) and summary["worst_utility_ratio"] >= RATIO_TARGET
    return summary


def _print_row(r: dict[str, Any]) -> None:
    if "error" in r:
        print(f"{r['task']:<14} {r['dishes']:>2}  heatmaps {r['feasibility_s']:.2f} s; "
              f"FAILED: {r['error']}", flush=True)
        return
    t = r["timing"]
    flag = "" if r["complete"] and r["long_complete"] else "  (budget cut)"
    print(f"{r['task']:<14} {r['dishes']:>2} {t['feasibility']:7.2f} {t['navigation']:6.2f} "
          f"{t['abstraction']:6.2f} {t['task_planning']:6.2f} {t['motion_search']:6.2f} "
          f"{r['planning_s']:7.2f} {r['planning_with_feasibility_s']:7.2f} "
          f"{r['utility']:9.2f} {r['long_utility']:9.2f} {r['utility_ratio']:6.3f}{flag}",
          flush=True)


def _append(out: TextIO | None, record: dict[str, Any]) -> None:
    if out is not None:
        out.write(json.dumps(record) + "\n")
        out.flush()


def main(argv: list[str] | None = None) -> int:
    parser = ArgumentParser(prog="python -m s3o_drake.commands.planning_benchmark",
                            description=__doc__, formatter_class=doc_formatter())
    parser.add_argument("--tasks", type=int, default=10,
                        help="first N shipped tasks (default 10)")
    parser.add_argument("--scenarios", nargs="+", metavar="YAML",
                        help="these scenario files instead of the shipped tasks")
    parser.add_argument("--method", default="S3O-GROP*",
                        help=f"one of {', '.join(METHODS)} (default S3O-GROP*)")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    parser.add_argument("--workers", type=int, default=2,
                        help="processes for the heatmaps and the planner (default 2)")
    parser.add_argument("--factor", type=int, default=10,
                        help="sample multiplier of the long run (default 10)")
    parser.add_argument("--json", metavar="FILE",
                        help="append one JSON line per task as it finishes, then the summary; "
                             "resumes from the tasks already in it")
    parser.add_argument("--fresh", action="store_true",
                        help="start the --json file over instead of resuming")
    args = parser.parse_args(argv)
    if args.method not in METHODS:
        fail(f"--method: unknown method {args.method!r}; one of {', '.join(METHODS)}")
    if args.workers < 1:
        fail(f"--workers: must be at least 1, got {args.workers}")
    if args.factor < 2:
        fail(f"--factor: must be at least 2, got {args.factor}")
    scenarios = task_scenarios(args.scenarios, args.tasks)
    json_path = Path(args.json) if args.json else None
    if json_path is not None and not json_path.parent.is_dir():
        fail(f"--json: no folder {json_path.parent}")

    settings = {"method": args.method, "seed": args.seed, "workers": args.workers,
                "factor": args.factor}
    done = {} if json_path is None or args.fresh else finished_rows(json_path, settings)
    if json_path is not None and args.fresh:
        json_path.unlink(missing_ok=True)

    from s3o_drake.feasibility.reachability import ReachabilityMap

    start = time.perf_counter()
    ReachabilityMap.shared().prepare_all()
    startup = time.perf_counter() - start
    print(f"{args.method}, seed {args.seed}, {args.workers} workers, long run x{args.factor}; "
          f"times in s; one-time start-up (reachability map) {startup:.2f} s"
          + (f"; resuming: {len(done)} tasks read from {json_path}" if done else ""))
    print(f"{'task':<14} {'n':>2} {'heatmap':>7} {'nav':>6} {'abstr':>6} {'task':>6} "
          f"{'motion':>6} {'plan':>7} {'+heat':>7} {'utility':>9} {'long':>9} {'ratio':>6}",
          flush=True)
    rows: list[dict[str, Any]] = []
    out = json_path.open("a") if json_path is not None else None
    if out is not None and json_path.stat().st_size and not json_path.read_bytes().endswith(b"\n"):
        out.write("\n")  # after a line an interruption cut short
    try:
        for name, scenario in scenarios:
            if name in done:
                row = done[name]
            else:
                row = benchmark_task(name, scenario, method=args.method, seed=args.seed,
                                     workers=args.workers, factor=args.factor)
                _append(out, row)
            rows.append(row)
            _print_row(row)
        summary = summarize(rows)
        summary.update(settings, startup_s=startup)
        _append(out, {"summary": summary})
    finally:
        if out is not None:
            out.close()

    s = summary
    t = s["median_timing"]
    print(f"planned {s['planned']} of {s['tasks']} tasks"
          + (f"; failed: {', '.join(s['failed'])}" if s["failed"] else ""))
    print("median breakdown: " + ", ".join(f"{k} {t[k]:.2f} s" for k in STAGES))
    print(f"median planning time: {s['median_planning_s']:.2f} s without the heatmaps, "
          f"{s['median_planning_with_feasibility_s']:.2f} s with them "
          f"(target <= {TIME_TARGET:g} s: {'met' if s['time_target_met'] else 'NOT met'} "
          f"without, {'met' if s['time_target_met_with_feasibility'] else 'NOT met'} with)")
    print(f"utility ratio (paper counts / x{args.factor} samples): median "
          f"{s['median_utility_ratio']:.3f}, worst {s['worst_utility_ratio']:.3f} "
          f"(target >= {RATIO_TARGET:g}: {'met' if s['utility_target_met'] else 'NOT met'})")
    if json_path is not None:
        print(f"wrote {json_path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
