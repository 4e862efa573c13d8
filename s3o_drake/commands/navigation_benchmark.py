"""A scenario's navigation map: its size and its path-length query times.

    s3o bench navigation [--tasks scenarios/restaurant.yaml] [--benchmark] [--queries 2000]

Without --benchmark it prints each map's size (graph vertices, grid, blocking edges); with
it, the build time and the milliseconds per path-length query on CMA-ES-like workloads. The
unmapped chairs play the perceived ones. The map's design, measured with this command, is
described in s3o_drake/planning/navigation/map.py.
"""

from __future__ import annotations

import sys
import time
from typing import TYPE_CHECKING

import numpy as np

# Light imports only: --help and bad arguments answer before Drake and shapely load.
from s3o_drake.commands.common import command_parser, read_scenario
from s3o_drake.commands.options import add_tasks, at_least, task_paths
from s3o_drake.world.resources import RESTAURANT

if TYPE_CHECKING:
    from s3o_drake.belief.known_world import KnownWorld


def benchmark(known: KnownWorld, *, queries: int = 2000, seed: int = 0) -> dict[str, float]:
    """Times the map's build and path-length queries on CMA-ES-like workloads.

    Points are drawn uniformly from the abstraction's free space within reach (1 m) of
    the dishes: (a) independent pairs, (b) pairs jittered by 3 cm around 10 centre
    pairs, as CMA-ES's late generations are, and (c) the same as (b) with one endpoint
    fixed (the robot's start), and (d) CMA-ES-like generations (10 samples of a 5-goto
    sequence, one batch of 50 pairs). Returns milliseconds per query: cold (empty
    endpoint cache) for single calls and batches of 10, warm (the same queries again).
    """
    import shapely
    from shapely.geometry import Point
    from shapely.ops import unary_union

    from s3o_drake.abstraction.voronoi import free_space
    from s3o_drake.planning.navigation.map import NavigationMap

    rng = np.random.default_rng(seed)
    t0 = time.perf_counter()
    nav = NavigationMap(known.obstacles, robot=known.robot)
    build = time.perf_counter() - t0
    free = free_space(known)
    dishes = np.array([d.position for d in known.dishes], float).reshape(-1, 2)
    near = unary_union([Point(*d).buffer(known.planner.reach_for(known.robot)) for d in dishes]) \
        if len(dishes) else nav.room
    region = free.intersection(near)
    x0, y0, x1, y1 = region.bounds

    def draw(n: int) -> np.ndarray:
        out = np.zeros((0, 2))
        while len(out) < n:
            c = rng.uniform([x0, y0], [x1, y1], size=(4 * n, 2))
            out = np.vstack([out, c[shapely.contains_xy(region, c[:, 0], c[:, 1])]])
        return out[:n]

    uniform = (draw(queries), draw(queries))
    centres_p, centres_q = draw(10), draw(10)
    pick = rng.integers(0, 10, queries)
    jitter = (centres_p[pick] + rng.normal(0, 0.03, (queries, 2)),
              centres_q[pick] + rng.normal(0, 0.03, (queries, 2)))
    start = np.asarray(known.pose[:2], float)
    fixed = (np.repeat(start[None], queries, axis=0), jitter[1])
    result = {"build_s": build, "vertices": float(len(nav.vertices))}
    for name, (P, Q) in {"uniform": uniform, "jitter": jitter, "from_start": fixed}.items():
        for batch in (1, 10):
            nav._endpoint_cache.clear()
            t0 = time.perf_counter()
            for s in range(0, queries, batch):
                nav.path_lengths(P[s:s + batch], Q[s:s + batch])
            result[f"{name}_batch{batch}_ms"] = (time.perf_counter() - t0) / queries * 1e3
        t0 = time.perf_counter()  # warm: the same queries again, endpoints cached
        for s in range(0, queries, 10):
            nav.path_lengths(P[s:s + 10], Q[s:s + 10])
        result[f"{name}_warm_batch10_ms"] = (time.perf_counter() - t0) / queries * 1e3
    # CMA-ES-like: each generation, 10 samples of a 5-goto sequence from the start, each
    # pose jittered by 3 cm around its centre; one batch of 50 pairs per generation, the
    # end of one goto the start of the next.
    nav._endpoint_cache.clear()
    chain = draw(5)
    generations = max(1, queries // 50)
    t0 = time.perf_counter()
    for _ in range(generations):
        poses = chain[None] + rng.normal(0, 0.03, (10, 5, 2))
        stops = np.concatenate([np.repeat(start[None, None], 10, axis=0), poses], axis=1)
        nav.path_lengths(stops[:, :-1].reshape(-1, 2), stops[:, 1:].reshape(-1, 2))
    result["cma_like_batch50_ms"] = (time.perf_counter() - t0) / (generations * 50) * 1e3
    lengths = nav.path_lengths(*uniform)
    straight = np.linalg.norm(uniform[0] - uniform[1], axis=1)
    finite = np.isfinite(lengths)
    result["finite_fraction"] = float(finite.mean())
    result["mean_detour_ratio"] = float(np.mean(lengths[finite] / np.maximum(straight[finite],
                                                                             1e-9)))
    return result


def main(argv: list[str] | None = None) -> int:
    parser = command_parser("bench navigation", __doc__)
    add_tasks(parser, default=(RESTAURANT,))
    parser.add_argument("--benchmark", action="store_true",
                        help="time path-length queries and print the figures")
    parser.add_argument("--queries", type=at_least(10), default=2000, metavar="N",
                        help="queries per workload (default 2000)")
    args = parser.parse_args(argv)
    scenarios = [(path.stem, read_scenario(path)) for path in task_paths(args)]
    from s3o_drake.belief.known_world import KnownWorld
    from s3o_drake.planning.navigation.map import NavigationMap

    for name, scenario in scenarios:
        known = KnownWorld.perfect(scenario)
        print(f"{name}:")
        if not args.benchmark:
            nav = NavigationMap(known.obstacles, robot=known.robot)
            print(f"  {len(nav.vertices)} graph vertices, grid {nav.occupancy.shape}, "
                  f"{len(nav._blocking_edges.edges)} blocking edges")
            continue
        for key, value in benchmark(known, queries=args.queries).items():
            print(f"  {key:28s} {value:.4f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
