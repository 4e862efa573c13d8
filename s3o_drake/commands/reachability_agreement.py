"""How often the reachability map agrees with exhaustive IK, on random queries.

Queries are drawn as a planner and its noise make them: a dish of the scene, a base position
uniform in the disc of radius `max_distance` around it (inside the room), the yaw facing the
dish plus navigation noise, and a reach offset of the dish (T^m, horizontal). Both methods
answer every query (`FeasibilityChecker` with method "map" and method "ik"); the report
gives the agreement over all queries and over those whose base is collision-free (the base
check is shared, so those are the informative ones), and lists the disagreements.

    python -m s3o_drake.commands.reachability_agreement [SCENARIO.yaml ...]
        [--queries 500] [--seed 0] [--fallback] [--vertical-reach] [--independent-ik]
"""

import sys
from pathlib import Path

import numpy as np

from s3o_drake.commands.common import ArgumentParser, doc_formatter, fail
from s3o_drake.feasibility.agreement import (
    DEFAULT_SCENARIOS,
    Agreement,
    measure,
    sample_queries,
)
from s3o_drake.feasibility.reachability import ReachabilityMap, ReachabilityMapError
from s3o_drake.feasibility.scene import FeasibilityScene
from s3o_drake.world.scenario import load_scenario
from s3o_drake.world.scenario_checks import ScenarioError


def main(argv: list[str] | None = None) -> int:
    parser = ArgumentParser(prog="python -m s3o_drake.commands.reachability_agreement",
                            description=__doc__, formatter_class=doc_formatter())
    parser.add_argument("scenarios", nargs="*", metavar="SCENARIO.yaml",
                        default=list(DEFAULT_SCENARIOS),
                        help="scenes to draw queries in (default scenarios/restaurant.yaml)")
    parser.add_argument("--queries", type=int, default=500,
                        help="queries in all, split evenly over the scenes (default 500)")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    parser.add_argument("--map", metavar="NPZ", default=None,
                        help="reachability map (default the shipped one)")
    parser.add_argument("--fallback", action="store_true",
                        help="map method with its fallback IK")
    parser.add_argument("--independent-ik", action="store_true",
                        help="exhaustive IK without the map's candidates among its seeds")
    parser.add_argument("--vertical-reach", action="store_true",
                        help="reach noise in 3D (default horizontal, as y_o is 2D)")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    args = parser.parse_args(argv)
    if args.queries < 1:
        fail(f"--queries: must be at least 1, got {args.queries}")
    try:
        reachability = ReachabilityMap.load(args.map)
        scenarios = [load_scenario(path) for path in args.scenarios]
    except (ReachabilityMapError, ScenarioError, OSError) as e:
        fail(str(e))
    rng = np.random.default_rng(args.seed)
    result = Agreement()
    for k, (path, scenario) in enumerate(zip(args.scenarios, scenarios, strict=True)):
        count = args.queries // len(scenarios) + (k < args.queries % len(scenarios))
        scene = FeasibilityScene(scenario.contents)
        queries = sample_queries(scene, count, rng, vertical_reach=args.vertical_reach)
        measure(scene, queries, reachability, fallback_ik=args.fallback,
                ik_map_seeds=not args.independent_ik,
                label=Path(path).stem, result=result, progress=not args.quiet)
    for line in result.disagreements:
        print(line)
    print(result.line())
    return 0


if __name__ == "__main__":
    sys.exit(main())
