"""The plan's predicted execution time against the simulated one.

    s3o bench time [--tasks PATH ...] [--count N] [--noise on off] [--set PATH=VALUE]
                   [--json FILE]

Plans and executes each task as `s3o run` does (no playback, open loop), once with the
simulated noise off and once on, and compares the plan's prediction with the report's
execution_time: predicted_time (every landing exact) with the noise off, expected_time (the
noise's average added; predicted_time where the time model has none) with it on. Targets
over the 100 generated tasks: median |prediction - simulated| / simulated at most 3 % with
the noise off, 8 % with it on. Each run executes in a worker
process. --evaluation instead measures one CMA-ES sample's evaluation cost.
"""

from __future__ import annotations

import dataclasses
import hashlib
import logging
import statistics
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

# Light imports only: --help and bad arguments answer before Drake loads; the functions
# import the planner and the execution where they use them.
from s3o_drake.commands.common import command_parser, read_scenario
from s3o_drake.commands.options import (
    add_json,
    add_method,
    add_overrides,
    add_seed,
    add_tasks,
    add_workers,
    json_store,
    one_robot,
    task_paths,
    with_overrides_or_fail,
)
from s3o_drake.world.choices import COST_PROFILES, Recovery

if TYPE_CHECKING:
    from concurrent.futures import ProcessPoolExecutor

    from s3o_drake.world.scenario import Scenario

TARGETS = {"off": 0.03, "on": 0.08}
"""Median |predicted - simulated| / simulated allowed, per noise setting."""


def model_version(path: Path) -> str:
    """A short digest of the recorded time model: rows of another model are not reused."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()[:12]


def measure(name: str, scenario: Scenario, *, method: str, seed: int, noise: bool) -> dict:
    """One planned and simulated run: the prediction, the simulated time and what happened.
    The run is open loop (execution.recovery none): the prediction is of the plan as
    planned, and recoveries are the execution's own (docs/execution.md)."""
    from s3o_drake.execution.execute import execute
    from s3o_drake.planning.time_model import departures

    scenario = dataclasses.replace(scenario, execution=dataclasses.replace(
        scenario.execution, recovery=Recovery.NONE.value))
    run = execute(scenario, method=method, seed=seed, meshcat=None, noise=noise, progress=False)
    report, plan = run.report, run.plan
    outcomes = report["outcomes"]
    failed: dict[str, int] = {}
    for action, _, outcome in outcomes:
        if outcome != "done":
            key = f"{action} {outcome.removeprefix('failed: ')}"
            failed[key] = failed.get(key, 0) + 1
    predicted = plan.predicted_time if plan is not None else None
    expected = plan.expected_time if plan is not None else None
    simulated = report["execution_time"]
    row = {"task": name, "method": method, "seed": seed, "noise": noise,
           "cost_profile": scenario.planner.cost_profile, "dishes": report["dishes"],
           "collected": report["collected"], "actions": len(plan.actions) if plan else 0,
           "executed": len(outcomes), "failed": failed,
           "all_done": bool(plan) and len(outcomes) == len(plan.actions) and not failed,
           "reason": report["reason"], "predicted_time": predicted,
           "expected_time": expected, "execution_time": simulated,
           "outcome_actions": [action for action, _, _ in outcomes],
           "outcome_times": report["outcome_times"],
           "motion": scenario.execution.motion,
           "departures": departures(plan.actions) if plan is not None else 0,
           "planning_time": report["planning_time"], "wall_time": report["wall_time"]}
    row["prediction"] = "expected_time" if noise and expected is not None else "predicted_time"
    if row[row["prediction"]] is not None and simulated > 0:
        row["rel_error"] = (row[row["prediction"]] - simulated) / simulated
    return row


def measure_job(job: tuple) -> dict:
    """A worker's run of `measure`: ((key, name, scenario, seed, noise), method, version)."""
    (key, name, scenario, seed, noise), method, version = job
    logging.getLogger("drake").setLevel(logging.WARNING)
    return {"key": key, "time_model": version,
            **measure(name, scenario, method=method, seed=seed, noise=noise == "on")}


def local_pool(workers: int) -> ProcessPoolExecutor:
    """The scheduler's worker processes, imported when the runs start (it loads Drake)."""
    from s3o_drake.experiments.scheduler import local_pool as pool

    return pool(workers)


def summarize(rows: list[dict], noise: str) -> dict:
    """Median and percentiles of |error| over the rows of one noise setting, and over those
    where every action was done."""
    mine = [r for r in rows if ("on" if r["noise"] else "off") == noise and "rel_error" in r]
    out: dict = {"noise": noise, "runs": len(mine)}
    for label, subset in (("all", mine), ("all_done", [r for r in mine if r["all_done"]])):
        errors = np.array([r["rel_error"] for r in subset])
        if not len(errors):
            continue
        a = np.abs(errors)
        out[label] = {"runs": len(subset), "median_abs": float(np.median(a)),
                      "predictions": sorted({r.get("prediction", "predicted_time")
                                             for r in subset}),
                      "p75_abs": float(np.percentile(a, 75)),
                      "p90_abs": float(np.percentile(a, 90)), "max_abs": float(a.max()),
                      "mean_signed": float(errors.mean())}
    return out


def evaluation_cost(scenario: Scenario, *, generations: int = 20, population: int = 10,
                    repeats: int = 3, seed: int = 0) -> dict[str, float]:
    """Seconds per CMA-ES sample of `SequenceProblem.evaluate` under each cost profile, on
    the task's plain Voronoi locations visited in name order, CMA-ES-like samples (each
    generation jittered by 3 cm around a centre), Fea^m 1 everywhere (the same for both
    profiles). The paper profile's evaluation is the one the motion search had before the
    time model (one path-length batch); the robot's adds the motion times."""
    from s3o_drake.abstraction import HeatmapFeasibility, voronoi_partition
    from s3o_drake.belief.known_world import KnownWorld
    from s3o_drake.feasibility.oracle import Heatmap
    from s3o_drake.planning.motion.grop import SequenceProblem, location_regions
    from s3o_drake.planning.navigation.map import NavigationMap
    from s3o_drake.planning.time_model import CostModel

    known = KnownWorld.perfect(scenario)
    nav = NavigationMap(known.obstacles, robot=known.robot)
    partition = voronoi_partition(known)
    groups = [(d,) for d, cell in zip(partition.dishes, partition.cells, strict=True)
              if not cell.is_empty]
    regions = location_regions(groups, dict(zip(partition.dishes, partition.cells, strict=True)))
    sequence = [a for k, (d,) in enumerate(groups) for a in (("goto", f"l{k}"), ("pickup", d))]
    fea = HeatmapFeasibility([Heatmap(d.name, np.ones((80, 100)), 0.0, 0.0, 0.1)
                              for d in scenario.dishes])
    rng = np.random.default_rng(seed)
    centre = np.array([np.array(regions[f"l{k}"].representative_point().coords[0])
                       for k in range(len(groups))])
    batches = [centre[None] + rng.normal(0.0, 0.03, (population, len(groups), 2))
               for _ in range(generations)]
    out = {}
    for profile in ("paper", "robot"):
        costs = CostModel.for_known(KnownWorld.perfect(dataclasses.replace(
            scenario, planner=dataclasses.replace(scenario.planner, cost_profile=profile))))
        nav.route_table(costs.base)
        best = np.inf
        for _ in range(repeats):
            problem = SequenceProblem(sequence, regions, fea, nav, known.pose,
                                      costs.planner, None, costs)
            nav._endpoint_cache.clear()  # each repeat starts cold, as a new search does
            t0 = time.perf_counter()
            for X in batches:
                problem.evaluate(X)
            best = min(best, (time.perf_counter() - t0) / (generations * population))
        out[profile] = best
    out["ratio"] = out["robot"] / out["paper"]
    return out


def _print_summary(s: dict) -> None:
    target = TARGETS[s["noise"]]
    for label in ("all", "all_done"):
        if label not in s:
            continue
        v = s[label]
        verdict = "met" if v["median_abs"] <= target else "NOT met"
        print(f"noise {s['noise']:>3} {label:>8}: {v['runs']:3d} runs, "
              f"|{' or '.join(v['predictions'])} - simulated| / simulated: median "
              f"{100 * v['median_abs']:.2f} % (target {100 * target:g} %: {verdict}), p75 "
              f"{100 * v['p75_abs']:.2f} %, p90 {100 * v['p90_abs']:.2f} %, max "
              f"{100 * v['max_abs']:.2f} %; mean signed {100 * v['mean_signed']:+.2f} %")


def main(argv: list[str] | None = None) -> int:
    parser = command_parser("bench time", __doc__)
    add_tasks(parser)
    parser.add_argument("--noise", nargs="+", choices=("off", "on"), default=["off", "on"],
                        help="the simulated noise settings to run (default: off on)")
    add_method(parser)
    add_seed(parser, None, "seed of every run")
    parser.add_argument("--cost-profile", choices=COST_PROFILES,
                        help="plan with this cost profile (default: each scenario's own)")
    add_overrides(parser, "replace a scenario field in every run, e.g. "
                          "execution.motion=stop_and_go (repeatable)")
    add_json(parser, "run")
    add_workers(parser, 1, "runs at once, each in a worker process")
    parser.add_argument("--evaluation", action="store_true",
                        help="measure the CMA-ES evaluation cost per sample instead")
    args = parser.parse_args(argv)
    paths = task_paths(args)
    tasks = [(path.stem, read_scenario(path)) for path in paths]
    if args.cost_profile is not None:
        tasks = [(name, dataclasses.replace(scenario, planner=dataclasses.replace(
            scenario.planner, cost_profile=args.cost_profile))) for name, scenario in tasks]
    tasks = [(name, with_overrides_or_fail(scenario, args.overrides)) for name, scenario in tasks]
    robot = one_robot(zip(paths, (s for _, s in tasks), strict=True))
    store = None if args.evaluation else json_store(args, robot=robot)
    logging.getLogger("drake").setLevel(logging.WARNING)

    if args.evaluation:
        ratios = []
        print(f"{'task':<10} {'paper ms':>9} {'robot ms':>9} {'ratio':>6}", flush=True)
        for name, scenario in tasks:
            r = evaluation_cost(scenario)
            ratios.append(r["ratio"])
            print(f"{name:<10} {1e3 * r['paper']:9.3f} {1e3 * r['robot']:9.3f} "
                  f"{r['ratio']:6.2f}", flush=True)
        print(f"evaluation cost per sample, robot / paper profile: median "
              f"{statistics.median(ratios):.2f}x (range {min(ratios):.2f}-{max(ratios):.2f})")
        return 0

    from s3o_drake.world.robot import load_robot

    version = model_version(load_robot(robot).files.time_model)
    changed = "".join(f"|set:{item}" for item in args.overrides)
    runs = [(f"{name}|{args.method}|{seed}|{noise}|{scenario.planner.cost_profile}|{version}"
             f"{changed}", name, scenario, seed, noise)
            for name, scenario in tasks
            for seed in [scenario.seed if args.seed is None else args.seed]
            for noise in args.noise]
    pending = [run for run in runs if store is None or not store.finished(run[0])]
    rows = []
    print(f"{'task':<10} {'noise':>5} {'dishes':>7} {'predicted':>9} {'simulated':>9} "
          f"{'error':>7}  failures", flush=True)
    # The runs execute in worker processes that are replaced now and then
    # (experiments/scheduler.TASKS_PER_CHILD): before execute() freed its diagram, a single
    # process grew to 21 GB over 140 runs.
    from s3o_drake.experiments.scheduler import ordered_map

    with local_pool(args.workers) as pool:
        measured = ordered_map(pool, measure_job, [(run, args.method, version) for run in pending],
                               window=args.workers)
        for key, *_ in runs:
            if store is not None and store.finished(key):
                row = store.get(key)
            else:
                row = next(measured)
                if store is not None:
                    store.append(row)
            rows.append(row)
            name = row["task"]
            noise = "on" if row["noise"] else "off"
            error = f"{100 * row['rel_error']:+6.2f}%" if "rel_error" in row else "    --"
            predicted = row[row.get("prediction", "predicted_time")]
            print(f"{name:<10} {noise:>5} {row['collected']:>3}/{row['dishes']:<3} "
                  f"{predicted if predicted is not None else float('nan'):9.1f} "
                  f"{row['execution_time']:9.1f} {error}  "
                  f"{', '.join(f'{k} x{v}' for k, v in row['failed'].items())}", flush=True)
    for noise in args.noise:
        _print_summary(summarize(rows, noise))
    return 0


if __name__ == "__main__":
    sys.exit(main())
