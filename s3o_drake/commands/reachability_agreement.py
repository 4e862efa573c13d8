"""The reachability map against exhaustive IK, on random queries.

    s3o bench reachability-agreement [--tasks PATH ...] [--queries 500] [--seed 0]

Queries are drawn as a planner and its noise make them (a dish, a base position near it,
the yaw facing it plus navigation noise, a reach offset). The map and exhaustive IK answer
every one; prints the agreement over all queries and over those with a collision-free base
(the informative ones), and lists the disagreements.
"""

import sys

import numpy as np

# Light imports only: --help and bad arguments answer before Drake loads.
from s3o_drake.commands.common import command_parser, fail, read_scenario
from s3o_drake.commands.options import (
    add_quiet,
    add_seed,
    add_tasks,
    at_least,
    one_robot,
    task_paths,
)
from s3o_drake.world.resources import RESTAURANT


def main(argv: list[str] | None = None) -> int:
    parser = command_parser("bench reachability-agreement", __doc__)
    add_tasks(parser, default=(RESTAURANT,))
    parser.add_argument("--queries", type=at_least(1), default=500, metavar="N",
                        help="queries in all, split evenly over the tasks (default 500)")
    add_seed(parser)
    parser.add_argument("--map", metavar="NPZ", default=None,
                        help="reachability map (default the shipped one)")
    parser.add_argument("--fallback", action="store_true",
                        help="map method with its fallback IK")
    parser.add_argument("--independent-ik", action="store_true",
                        help="exhaustive IK without the map's candidates among its seeds")
    parser.add_argument("--vertical-reach", action="store_true",
                        help="reach noise in 3D (default horizontal, as y_o is 2D)")
    add_quiet(parser)
    args = parser.parse_args(argv)
    paths = task_paths(args)
    scenarios = [read_scenario(path) for path in paths]
    from s3o_drake.experiments.reachability_agreement import Agreement, measure, sample_queries
    from s3o_drake.feasibility.reachability.map import ReachabilityMap, ReachabilityMapError
    from s3o_drake.feasibility.scene import FeasibilityScene
    from s3o_drake.world.robot import load_robot

    robot = load_robot(one_robot(zip(paths, scenarios, strict=True)))
    try:
        reachability = ReachabilityMap.load(args.map, robot=robot)
    except (ReachabilityMapError, OSError) as e:
        fail(f"--map: {e}")
    rng = np.random.default_rng(args.seed)
    result = Agreement()
    for k, (path, scenario) in enumerate(zip(paths, scenarios, strict=True)):
        count = args.queries // len(scenarios) + (k < args.queries % len(scenarios))
        scene = FeasibilityScene(scenario.contents)
        queries = sample_queries(scene, count, rng, vertical_reach=args.vertical_reach)
        measure(scene, queries, reachability, fallback_ik=args.fallback,
                ik_map_seeds=not args.independent_ik,
                label=path.stem, result=result, progress=not args.quiet)
    for line in result.disagreements:
        print(line)
    print(result.line())
    return 0


if __name__ == "__main__":
    sys.exit(main())
