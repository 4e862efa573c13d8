"""Planning time per task, broken down, and utility against 10x the samples.

    s3o bench planning --count 10 [--method S3O-GROP*] [--json FILE]

For each task: the Fea^m heatmaps of every dish (timed as "feasibility"), a plan at the
paper's sample counts with the planner's own breakdown (navigation, abstraction, task
planning, motion search), and a plan with --factor times the CMA-ES generations, the long
run. Prints a row per task and the medians against the targets: planning at most 5 s on
2 cores, utility within 5 % of the long run. The unmapped chairs count as perceived.
"""

from __future__ import annotations

import dataclasses
import math
import statistics
import sys
import time
from typing import TYPE_CHECKING, Any

# Light imports only: the heavy ones come after the arguments are parsed.
from s3o_drake.commands.common import command_parser, read_scenario
from s3o_drake.commands.options import (
    add_json,
    add_method,
    add_seed,
    add_tasks,
    add_workers,
    at_least,
    json_store,
    one_robot,
    task_paths,
)

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
    from s3o_drake.feasibility.oracle_cache import bypassed
    from s3o_drake.planning.pipeline import plan_from

    row: dict[str, Any] = {"task": name, "dishes": len(scenario.dishes), "method": method,
                           "seed": seed, "workers": workers, "factor": factor}
    # The planner is given the scenario's unmapped chairs exactly: this benchmark measures
    # planning (perception has its own, s3o_drake.commands.perception_benchmark).
    known = KnownWorld.perfect(scenario)
    with bypassed():  # the oracle's time is measured, not a cached map's
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


def row_key(row: dict[str, Any]) -> str:
    """A task's row is reused for the same task, method, seed, workers and factor."""
    return "|".join(str(row[k]) for k in ("task", "method", "seed", "workers", "factor"))


def main(argv: list[str] | None = None) -> int:
    parser = command_parser("bench planning", __doc__)
    add_tasks(parser, count=10)
    add_method(parser)
    add_seed(parser)
    add_workers(parser, 2, "processes for the heatmaps and the planner")
    parser.add_argument("--factor", type=at_least(2), default=10, metavar="N",
                        help="sample multiplier of the long run (default 10)")
    add_json(parser, "task")
    args = parser.parse_args(argv)
    paths = task_paths(args)
    scenarios = [(path.stem, read_scenario(path)) for path in paths]
    robot = one_robot(zip(paths, (s for _, s in scenarios), strict=True))
    store = json_store(args, key=row_key, robot=robot)
    settings = {"method": args.method, "seed": args.seed, "workers": args.workers,
                "factor": args.factor}
    done = {name: store.get(row_key({"task": name, **settings})) for name, _ in scenarios
            if store is not None and store.finished(row_key({"task": name, **settings}))}

    from s3o_drake.feasibility.reachability.map import ReachabilityMap
    from s3o_drake.world.robot import load_robot

    start = time.perf_counter()
    ReachabilityMap.shared(robot=load_robot(robot)).prepare_all()
    startup = time.perf_counter() - start
    print(f"{args.method}, seed {args.seed}, {args.workers} workers, long run x{args.factor}; "
          f"times in s; one-time start-up (reachability map) {startup:.2f} s"
          + (f"; resuming: {len(done)} tasks read from {args.json}" if done else ""))
    print(f"{'task':<14} {'n':>2} {'heatmap':>7} {'nav':>6} {'abstr':>6} {'task':>6} "
          f"{'motion':>6} {'plan':>7} {'+heat':>7} {'utility':>9} {'long':>9} {'ratio':>6}",
          flush=True)
    rows: list[dict[str, Any]] = []
    for name, scenario in scenarios:
        if name in done:
            row = done[name]
        else:
            row = benchmark_task(name, scenario, method=args.method, seed=args.seed,
                                 workers=args.workers, factor=args.factor)
            if store is not None:
                row = store.append({"key": row_key(row), **row})
        rows.append(row)
        _print_row(row)
    summary = summarize(rows)
    summary.update(settings, startup_s=startup)
    if store is not None:
        store.append({"key": row_key({"task": "summary", **settings}), "summary": summary})

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
    if store is not None:
        print(f"wrote {store.path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
