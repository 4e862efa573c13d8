"""The navigation map: collision-free path lengths and paths for the base (DESIGN.md 2.6).

GROP*'s utility charges `len(y, y') / v` per `goto` (the paper's cost profile), with `len`
the collision-free path length on the map, or the base navigator's motion time along the
path (`path_times`, the robot's cost profile); CMA-ES evaluates it thousands of times per
plan at continuous, clustered points, so it must be exact enough to rank samples and cheap
(<= 0.2 ms).

Obstacles: the tables and the mapped chairs of the scenario, plus the chairs the planner
perceives, passed explicitly (the scenario's unmapped chairs are never read here), and
the room's walls.

Two radii (the base is a 0.62 x 0.56 m rectangle):

- `DRIVE_RADIUS` = BASE_RADIUS + DRIVE_MARGIN = 0.438 m, the circumscribed radius and a
  margin for the collision check's padding. Along a path the base turns freely, so every
  interior point of a path keeps at least this much from every footprint: the *driveable*
  region.
- `INSCRIBED_RADIUS` = BASE_WIDTH / 2 = 0.28 m. The abstraction calls a position free if
  it keeps this much (`s3o_drake.abstraction.voronoi.free_space`), so standing spots next
  to tables may lie in the 0.28-0.438 m band, outside the driveable region.

Endpoint rule. An endpoint with clearance >= DRIVE_RADIUS is used as it is. One in the
band is joined to the driveable region by the straight segment to its nearest point in
that region (0.2 mm inside it, so that a wedge between a table and a wall works; the
base backs straight away from the obstacle, facing it, as it came in); that segment
must keep >= INSCRIBED_RADIUS from every footprint and wall, else the endpoint counts as
unreachable (both up to INSCRIBED_TOLERANCE = 1 mm, the abstraction's polygonisation
error). An endpoint with clearance < INSCRIBED_RADIUS (inside
or touching an obstacle, or outside the room) is not a position of the base at all:
`path_length` returns inf and `path` returns None for it (no exception, so that CMA-ES
can score such samples with its penalty).

Design (measured with `python -m s3o_drake.commands.navigation_benchmark --benchmark`):

- Occupancy grid + Euclidean distance field (`scipy.ndimage.distance_transform_edt`) at
  `resolution`: `clearance(P)` is an O(1) lookup per point. It classifies most endpoints
  without geometry (clearly driveable / clearly not a base position); only points within
  1.5 cells of a threshold go to the exact shapely test.
- Visibility graph for the lengths, which are exact on the polygonal map (any-angle, no
  grid error): obstacles inflated by DRIVE_RADIUS as polygons that circumscribe the round
  offset (arcs of `quad_segs` segments per quarter, so at most ~0.8 cm over-inflation with
  the default 4), their convex vertices as nodes, all-pairs shortest distances
  precomputed once (`scipy.sparse.csgraph`).
- Per query, len(p, q) = |p q| if p sees q (one exact segment-crossing test), else
  min over u, w of |p u| + D[u, w] + |w q| over the vertices u that p sees and w that q
  sees, restricted to tangent vertices (a shortest path leaves a point along a tangent to
  an obstacle), plus the endpoint segments of the rule above. "p sees vertex u" is a
  binary search in u's visibility polygon, precomputed at build time by ray casting (see
  `_build_visibility_polygons`), so it costs O(log n) instead of O(edges); it agrees with
  the exact segment test (checked in the tests). Endpoints are cached by their exact
  coordinates, so a repeated endpoint (the robot's start, the end of one goto that starts
  the next) costs nothing the second time.
- Batch queries (`path_lengths`) amortise numpy's per-call overhead: use them from the
  motion search (one batch per CMA-ES generation). A single `path_length` call costs
  ~0.4 ms, mostly numpy call overhead.
"""

from __future__ import annotations

import sys

from s3o_drake.known_world import KnownWorld
from s3o_drake.planning.navigation import (
    NavigationMap,
    benchmark,
)


def main(argv: list[str] | None = None) -> int:
    """`python -m s3o_drake.commands.navigation_benchmark [scenario] --benchmark`."""
    from s3o_drake.commands.common import ArgumentParser, doc_formatter, fail
    from s3o_drake.scenario import ScenarioError, load_scenario

    parser = ArgumentParser(prog="python -m s3o_drake.commands.navigation_benchmark",
                            description=__doc__, formatter_class=doc_formatter())
    parser.add_argument("scenario", nargs="?", default="scenarios/restaurant.yaml",
                        help="scenario YAML (default: scenarios/restaurant.yaml); its "
                             "unmapped chairs play the perceived ones")
    parser.add_argument("--benchmark", action="store_true",
                        help="time path-length queries and print the figures")
    parser.add_argument("--queries", type=int, default=2000, help="queries per workload")
    args = parser.parse_args(argv)
    if args.queries < 10:
        parser.error(f"--queries must be at least 10, got {args.queries}")
    try:
        scenario = load_scenario(args.scenario)
    except ScenarioError as e:
        fail(str(e))
    known = KnownWorld.perfect(scenario)
    if not args.benchmark:
        nav = NavigationMap(known.obstacles)
        print(f"{len(nav.vertices)} graph vertices, grid {nav.occupancy.shape}, "
              f"{len(nav._edges)} blocking edges")
        return 0
    for key, value in benchmark(known, queries=args.queries).items():
        print(f"{key:28s} {value:.4f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
