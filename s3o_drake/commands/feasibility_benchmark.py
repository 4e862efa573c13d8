"""Benchmark the feasibility check: speed with the reachability map and with full IK in the
same run, their agreement, and the time of one heatmap.

    python -m s3o_drake.commands.feasibility_benchmark --queries 500 --tasks 4

Queries are drawn as a planner makes them (`agreement.sample_queries`): base positions
within 1.1 m of a dish, yaw facing it with navigation noise, a horizontal reach offset, in
cluttered scenes: scenarios/restaurant.yaml and generated benchmark tasks (chairs
included). Every query is answered by

- the map, one `check` call at a time, and batched (`check_many`, one thread): the two
  per-core rates;
- full IK: Drake `InverseKinematics` with the 1 cm minimum-distance constraint from the
  stow configuration, one solve per grasp (the speed reference, one thread);
- exhaustive IK: many seeds (closed-form branches, stow, random; never the map's own
  configurations): the ground truth for the agreement.

Then one 64 x 64 heatmap (`FeasibilityOracle.heatmap`) is timed for every dish of the
restaurant with the batched check on two threads (the issue's target is the worst dish).
Prints the figures; --json also writes them to a file.
"""

import json
import sys
import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

from s3o_drake.commands.common import ArgumentParser, doc_formatter, fail
from s3o_drake.feasibility.agreement import Agreement, measure, sample_queries
from s3o_drake.feasibility.check import FeasibilityChecker
from s3o_drake.feasibility.oracle import FeasibilityOracle
from s3o_drake.feasibility.reachability import ReachabilityMap
from s3o_drake.feasibility.scene import FeasibilityScene
from s3o_drake.world.files import write_atomically
from s3o_drake.world.resources import RESTAURANT
from s3o_drake.world.scenario import load_scenario
from s3o_drake.world.task_generation import generate_task


def _batched_seconds(checker: FeasibilityChecker, queries) -> float:
    """Time of `check_many` over the queries, grouped by dish (one call per dish)."""
    dishes = np.array(queries.dishes)
    start = time.perf_counter()
    for dish in sorted(set(queries.dishes)):
        rows = dishes == dish
        checker.check_many(queries.bases[rows], dish, queries.offsets[rows])
    return time.perf_counter() - start


def main(argv: list[str] | None = None) -> int:
    parser = ArgumentParser(prog="python -m s3o_drake.commands.feasibility_benchmark",
                            description=__doc__, formatter_class=doc_formatter())
    parser.add_argument("--queries", type=int, default=500,
                        help="queries in all, split over the scenes (default 500)")
    parser.add_argument("--tasks", type=int, default=4,
                        help="generated tasks used besides the restaurant (default 4)")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    parser.add_argument("--json", metavar="FILE", help="also write the figures here")
    args = parser.parse_args(argv)
    if args.queries < 10:
        fail(f"--queries: must be at least 10, got {args.queries}")
    if args.tasks < 0:
        fail(f"--tasks: must be at least 0, got {args.tasks}")

    rng = np.random.default_rng(args.seed)
    restaurant = load_scenario(RESTAURANT)
    scenarios = [restaurant] + [generate_task(restaurant, args.seed, i)
                                for i in range(args.tasks)]
    rmap = ReachabilityMap.load()
    result = Agreement()
    seconds = {"batched": 0.0, "full_ik": 0.0}
    for k, scenario in enumerate(scenarios):
        count = args.queries // len(scenarios) + (k < args.queries % len(scenarios))
        scene = FeasibilityScene(scenario.contents)
        queries = sample_queries(scene, count, rng)
        label = "restaurant" if k == 0 else f"task_{k - 1:03d}"
        measure(scene, queries, rmap, ik_map_seeds=False, label=label, result=result,
                progress=True)
        batched = FeasibilityChecker(scene, rmap, parallelize=False)
        seconds["batched"] += _batched_seconds(batched, queries)
        full_ik = FeasibilityChecker(scene, None, method="ik", exhaustive=False,
                                     parallelize=False)
        for i in tqdm(range(count), desc=f"{label} full IK", leave=False):
            start = time.perf_counter()
            full_ik.check(queries.bases[i], queries.dishes[i], queries.offsets[i])
            seconds["full_ik"] += time.perf_counter() - start

    oracle = FeasibilityOracle(FeasibilityChecker(FeasibilityScene(restaurant.contents), rmap),
                               restaurant.uncertainty)
    oracle.heatmap(restaurant.dishes[0].name, cells=8)  # allocate the thread contexts
    heatmap_s = {}
    for dish in restaurant.dishes:
        start = time.perf_counter()
        oracle.heatmap(dish.name)
        heatmap_s[dish.name] = time.perf_counter() - start

    n = result.total
    figures = {
        "queries": n,
        "base_collision_free": result.base_free,
        "feasible_by_exhaustive_ik": result.feasible_ik,
        "map_single_checks_per_s_per_core": n / result.map_seconds,
        "map_batched_checks_per_s_per_core": n / seconds["batched"],
        "full_ik_checks_per_s_per_core": n / seconds["full_ik"],
        "exhaustive_ik_checks_per_s_per_core": n / result.ik_seconds,
        "speedup_single_vs_full_ik": seconds["full_ik"] / result.map_seconds,
        "speedup_batched_vs_full_ik": seconds["full_ik"] / seconds["batched"],
        "agreement": result.agree / n,
        "agreement_base_collision_free": result.agree_base_free / max(result.base_free, 1),
        "disagreements": result.disagreements,
        "heatmap_64x64x5_s": heatmap_s,
        "heatmap_64x64x5_worst_s": max(heatmap_s.values()),
    }
    f = figures
    print(f"queries: {n} in {len(scenarios)} scenes; base collision-free {result.base_free}, "
          f"feasible by exhaustive IK {result.feasible_ik}")
    print(f"map, one check() at a time: {f['map_single_checks_per_s_per_core']:8.0f} checks/s "
          "per core")
    print(f"map, batched check_many:    {f['map_batched_checks_per_s_per_core']:8.0f} checks/s "
          "per core")
    print(f"full IK (stow seed):        {f['full_ik_checks_per_s_per_core']:8.1f} checks/s "
          "per core")
    print(f"exhaustive IK:              {f['exhaustive_ik_checks_per_s_per_core']:8.1f} checks/s "
          "per core")
    print(f"ratio map/full IK: {f['speedup_single_vs_full_ik']:.0f}x single, "
          f"{f['speedup_batched_vs_full_ik']:.0f}x batched")
    print(f"agreement map vs exhaustive IK: {f['agreement']:.1%} of all queries, "
          f"{f['agreement_base_collision_free']:.1%} of those with a free base")
    for line in result.disagreements:
        print(f"  disagrees: {line}")
    print("one 64x64 heatmap of the executed pickup, 2 threads: "
          + ", ".join(f"{k} {v:.2f} s" for k, v in heatmap_s.items())
          + f"; worst {f['heatmap_64x64x5_worst_s']:.2f} s")
    if args.json:
        write_atomically(Path(args.json), json.dumps(figures, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
