"""The feasibility check: map and IK speed, agreement, one heatmap's time.

    s3o bench feasibility [--queries 500] [--generated 4] [--json FILE]

Queries drawn as a planner makes them, in the restaurant and --generated tasks drawn with
--seed, are answered by the reachability map (one at a time and batched), by full IK (the
speed reference) and by exhaustive IK (the truth for the agreement). Then one 64 x 64
heatmap is timed for every dish of the restaurant. Prints the figures.
"""

from __future__ import annotations

import json
import sys
import time
from typing import TYPE_CHECKING

import numpy as np

# Light imports only: --help and bad arguments answer before Drake loads.
from s3o_drake.commands.common import command_parser
from s3o_drake.commands.options import add_json, add_seed, at_least, json_file
from s3o_drake.world.files import write_atomically
from s3o_drake.world.resources import RESTAURANT

if TYPE_CHECKING:
    from s3o_drake.feasibility.check import FeasibilityChecker


def _batched_seconds(checker: FeasibilityChecker, queries) -> float:
    """Time of `check_many` over the queries, grouped by dish (one call per dish)."""
    dishes = np.array(queries.dishes)
    start = time.perf_counter()
    for dish in sorted(set(queries.dishes)):
        rows = dishes == dish
        checker.check_many(queries.bases[rows], dish, queries.offsets[rows])
    return time.perf_counter() - start


def main(argv: list[str] | None = None) -> int:
    parser = command_parser("bench feasibility", __doc__)
    parser.add_argument("--queries", type=at_least(10), default=500, metavar="N",
                        help="queries in all, split over the scenes (default 500)")
    parser.add_argument("--generated", type=at_least(0), default=4, metavar="N",
                        help="tasks drawn with --seed besides the restaurant (default 4)")
    add_seed(parser)
    add_json(parser, None)
    args = parser.parse_args(argv)
    json_path = json_file(args)
    from tqdm import tqdm

    from s3o_drake.experiments.reachability_agreement import Agreement, measure, sample_queries
    from s3o_drake.feasibility.check import FeasibilityChecker
    from s3o_drake.feasibility.oracle import FeasibilityOracle
    from s3o_drake.feasibility.oracle_cache import bypassed
    from s3o_drake.feasibility.reachability.map import ReachabilityMap
    from s3o_drake.feasibility.scene import FeasibilityScene
    from s3o_drake.world.scenario import load_scenario
    from s3o_drake.world.task_generation import generate_task

    rng = np.random.default_rng(args.seed)
    restaurant = load_scenario(RESTAURANT)
    scenarios = [restaurant] + [generate_task(restaurant, args.seed, i)
                                for i in range(args.generated)]
    rmap = ReachabilityMap.load(robot=restaurant.contents.robot)
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
    with bypassed():  # the oracle's time is measured, not a cached map's
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
    if json_path is not None:
        write_atomically(json_path, json.dumps(figures, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
