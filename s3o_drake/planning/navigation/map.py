"""The navigation map: collision-free path lengths and paths for the base.

GROP*'s utility charges `len(y, y') / v` per `goto` (the paper's cost profile), with `len`
the collision-free path length on the map, or the base navigator's motion time along the
path (`path_times`, the robot's cost profile); CMA-ES evaluates it thousands of times per
plan at continuous, clustered points, so it must be exact enough to rank samples and cheap
(<= 0.2 ms).

Obstacles: what the robot knows (`KnownWorld.obstacles`): the room's walls, the tables, the
mapped chairs and the chairs it perceived (the true unmapped chairs are never read here).

Two radii of the robot's base (the UR5e's is a 0.62 x 0.56 m rectangle):

- the drive radius = `Robot.base_radius` + DRIVE_MARGIN = 0.438 m, the circumscribed
  radius and a margin for the collision check's padding. Along a path the base turns
  freely, so every interior point of a path keeps at least this much from every footprint:
  the *driveable* region.
- the inscribed radius = `Robot.inscribed_radius`, half the base's width = 0.28 m. The
  abstraction calls a position free if
  it keeps this much (`s3o_drake.abstraction.voronoi.free_space`), so standing spots next
  to tables may lie in the 0.28-0.438 m band, outside the driveable region.

Endpoint rule. An endpoint with clearance >= the drive radius is used as it is. One in the
band is joined to the driveable region by the straight segment to its nearest point in
that region (0.2 mm inside it, so that a wedge between a table and a wall works; the
base backs straight away from the obstacle, facing it, as it came in); that segment
must keep >= the inscribed radius from every footprint and wall, else the endpoint counts as
unreachable (both up to INSCRIBED_TOLERANCE = 1 mm, the abstraction's polygonisation
error). An endpoint with clearance < the inscribed radius (inside
or touching an obstacle, or outside the room) is not a position of the base at all:
`path_length` returns inf and `path` returns None for it (no exception, so that CMA-ES
can score such samples with its penalty).

Design: docs/planning.md ("The navigation map's design"), measured with
`s3o bench navigation --benchmark`.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry import Polygon
from shapely.geometry.base import BaseGeometry
from shapely.ops import unary_union

from s3o_drake.planning.navigation.base_motion import (
    BaseProfile,
    chain_time,
    smooth_chain_time,
)
from s3o_drake.planning.navigation.visibility_graph import SLACK, VisibilityGraph
from s3o_drake.world.furniture import DistanceField
from s3o_drake.world.obstacles import Obstacles
from s3o_drake.world.robot import Robot

DRIVE_MARGIN = 0.02
"""Added to the circumscribed radius along paths (m): the execution's collision check keeps
1 cm of padding (feasibility.scene.ENVIRONMENT_PADDING), and a path that hugs an inflated
obstacle at exactly the base's radius left the base no room to turn there (the benchmark
found runs of every method blocked so, e.g. task_010 next to a wall)."""
TIGHT_DRIVE_MARGIN = 0.01
"""The least margin a map may keep (m): the execution's collision check's own padding
(feasibility.scene.ENVIRONMENT_PADDING). A map built with it finds ways that DRIVE_MARGIN
closes by millimetres; it is asked only for dishes that the usual map leaves no stop."""
INSCRIBED_TOLERANCE = 1e-3
"""An endpoint's clearance may fall this short of the inscribed radius (m): the abstraction's
free space is a polygon (`buffer(..., quad_segs=16)`) whose boundary comes ~0.3 mm closer."""
WAY_OUT_MIN_AREA = 0.05
"""A part of the driveable region smaller than this (m²) is no way out (`way_out`): in a
narrow aisle the map can hold a pocket of a few cm² that leads nowhere (dense task_030,
0.001 m² beside a robot in the 0.85 m aisle), and a plan started there reaches nothing."""
_ENDPOINT_CACHE_SIZE = 20_000


@dataclass
class _Endpoint:
    """A query point prepared for the graph: where it joins it and what it sees."""

    p: np.ndarray
    """The query point (2,)."""
    entry: np.ndarray | None
    """The driveable point the rule joins it to (== p when p is driveable); None: unreachable."""
    lead: float
    """|p entry| (m)."""
    seen: np.ndarray | None = None
    """Indices of the graph vertices `entry` sees (tangent ones only); None: not yet
    computed (only needed when the straight segment is blocked)."""
    seen_d: np.ndarray | None = None
    """|entry v| for those vertices."""


class NavigationMap:
    """Collision-free path lengths and paths for the base on one map.

    Built once per planning problem (obstacles fixed); `path_length`, `path_lengths` and
    `path` are the queries. Deterministic: no randomness, ties broken by index.
    """

    def __init__(self, obstacles: Obstacles, *, robot: Robot, resolution: float = 0.05,
                 quad_segs: int = 4, fast_visibility: bool = True,
                 drive_margin: float = DRIVE_MARGIN):
        """`obstacles`: what the robot knows (`KnownWorld.obstacles`: the walls, the tables,
        the mapped and the perceived chairs); `robot`: whose base drives. `resolution` (m)
        is the occupancy grid's cell size. `fast_visibility=False` tests what an endpoint
        sees with the exact segment test instead of the precomputed visibility polygons (a
        reference for tests).
        `drive_margin` (m, at least TIGHT_DRIVE_MARGIN) is added to the base's circumscribed
        radius along paths."""
        self.fast_visibility = fast_visibility
        if resolution <= 0:
            raise ValueError(f"resolution must be positive, got {resolution}")
        if drive_margin < TIGHT_DRIVE_MARGIN:
            raise ValueError(f"drive_margin must be at least {TIGHT_DRIVE_MARGIN} m (the "
                             f"collision check's padding), got {drive_margin}")
        self.robot = robot
        """The robot whose base the map is for."""
        self.drive_radius = robot.base_radius + drive_margin
        """The clearance this map keeps along paths (m): the base's circumscribed radius
        and the margin, safe at any yaw."""
        self.inscribed_radius = robot.inscribed_radius
        """The least clearance of a base position (m): nearer, every yaw collides."""
        self.resolution = float(resolution)
        self.room = obstacles.room
        self.footprints: list[Polygon] = list(obstacles.footprints)
        self.obstacles: BaseGeometry = obstacles.union
        """The union of the true footprints (not inflated)."""
        # What the exact tests measure clearance to: footprints and the walls.
        self._walls = self.room.exterior
        self._solid = unary_union([self.obstacles.boundary, self._walls]) if self.footprints \
            else self._walls
        shapely.prepare(self._solid)
        self._build_grid()
        self._build_graph(quad_segs)
        self._endpoint_cache: dict[tuple[float, float], _Endpoint] = {}
        self._sealed = False

    # ----------------------------------------------------------------------------- grid
    def _build_grid(self) -> None:
        """Occupancy grid of footprints and walls, and the distance field to them."""
        field = DistanceField.of(self.obstacles, self.room.bounds, self.resolution,
                                 grow=self.resolution / 2)
        self._field = field
        self.origin = field.origin
        self.occupancy = field.occupied
        """occupancy[i, j]: cell (i, j) (x index, y index) touches an obstacle."""
        self.distance = field.distance
        """Distance (m) from each cell centre to the nearest occupied cell centre."""

    def clearance(self, P: np.ndarray) -> np.ndarray:
        """Approximate clearance (m) of points (m, 2) to footprints and walls, O(1) each.

        From the distance field at the nearest cell; the error is within about one cell
        (`resolution`). Points outside the room get 0.
        """
        return self._field.at(P)

    def exact_clearance(self, P: np.ndarray) -> np.ndarray:
        """Exact clearance (m) of points (m, 2) to footprints and walls; 0 inside them."""
        P = np.asarray(P, dtype=float).reshape(-1, 2)
        points = shapely.points(P)
        d = shapely.distance(points, self._solid)
        inside_room = shapely.contains_xy(self.room, P[:, 0], P[:, 1])
        if not self.obstacles.is_empty:
            inside_room &= ~shapely.contains_xy(self.obstacles, P[:, 0], P[:, 1])
        return np.where(inside_room, d, 0.0)

    # ---------------------------------------------------------------------------- graph
    def _build_graph(self, quad_segs: int) -> None:
        """Inflated polygons, their convex vertices, visibility and all-pairs distances."""
        factor = 1.0 / math.cos(math.pi / (4 * quad_segs))  # circumscribe the round offset
        r_block = self.drive_radius * factor
        self._r_block = r_block
        if self.obstacles.is_empty:
            blocking = Polygon()
            outer = Polygon()
        else:
            blocking = self.obstacles.buffer(r_block, quad_segs=quad_segs)
            outer = self.obstacles.buffer(r_block + SLACK, quad_segs=quad_segs)
        interior_room = self.room.buffer(-self.drive_radius, join_style="mitre")
        self.blocking = blocking
        """Obstacles inflated by (at least) `drive_radius`: paths never enter them."""
        self.driveable = interior_room.difference(blocking)
        """Positions a path may pass: `drive_radius` from walls and footprints."""
        shapely.prepare(self.driveable)
        self._driveable_inner = self.driveable.buffer(-2 * SLACK)
        shapely.prepare(self._driveable_inner)
        parts = [g for g in shapely.get_parts(self._driveable_inner)
                 if g.area >= WAY_OUT_MIN_AREA]
        self._way_out_region = unary_union(parts) if parts else self._driveable_inner
        self._graph = VisibilityGraph(blocking, outer, interior_room, self.room)
        self._blocking_edges = self._graph.edges
        self.vertices = self._graph.vertices
        """Graph nodes: convex vertices of the inflated obstacles (k, 2)."""
        self._D = self._graph.distances
        self._sight = self._graph.sight

    # ------------------------------------------------------------------------ endpoints
    def seal(self) -> None:
        """Stops memoising: later queries compute what the caches lack without storing it,
        and work on copies of what they hold, so the map no longer changes. The execution
        seals the plan's map before Drake's state copies share it."""
        self._sealed = True

    def drivable_from(self, P: np.ndarray) -> np.ndarray:
        """bool (m,): whether the base can drive off from (and so to) each point (m, 2): it
        is a base position the endpoint rule joins to the driveable region."""
        return np.array([e.entry is not None for e in self._prepare(P)], dtype=bool)

    def reachable(self, start: Sequence[float], P: np.ndarray) -> np.ndarray:
        """bool (m,): whether a collision-free path leads from `start` to each point (m, 2)."""
        P = np.asarray(P, dtype=float).reshape(-1, 2)
        start = np.broadcast_to(np.asarray(start, dtype=float)[:2], P.shape)
        return np.isfinite(self.path_lengths(start, P))

    def way_out(self, p: Sequence[float]) -> np.ndarray:
        """`p` (2,) when it is a position the base can drive from (an endpoint the rule
        joins to the driveable region), else the nearest point of the driveable region,
        leaving out parts smaller than WAY_OUT_MIN_AREA: where a robot that stands at p, by
        the map inside or against an obstacle, should back out to (the map errs; the robot
        is there)."""
        p = np.asarray(p, dtype=float)[:2]
        if self.drivable_from(p[None])[0]:
            return p
        line = shapely.shortest_line(shapely.points(p), self._way_out_region)
        return np.asarray(shapely.get_coordinates(line)[1], dtype=float)

    def _prepare(self, P: np.ndarray) -> list[_Endpoint]:
        """Endpoints for points (m, 2), from the cache or computed in one batch."""
        P = np.asarray(P, dtype=float).reshape(-1, 2)
        keys = list(map(tuple, P.tolist()))
        if self._sealed:
            # Copies: `_see` fills in what an endpoint sees, and the cache must not change.
            missing = sorted({k for k in keys if k not in self._endpoint_cache})
            fresh = dict(zip(missing, self._compute_endpoints(np.array(missing)), strict=True)) \
                if missing else {}
            return [dataclasses.replace(self._endpoint_cache[k]) if k in self._endpoint_cache
                    else fresh[k] for k in keys]
        todo = sorted({k for k in keys if k not in self._endpoint_cache})
        if todo:
            if len(self._endpoint_cache) + len(todo) > _ENDPOINT_CACHE_SIZE:
                # Start afresh; every key of this batch must then be computed.
                self._endpoint_cache.clear()
                todo = sorted(set(keys))
            for k, e in zip(todo, self._compute_endpoints(np.array(todo)), strict=True):
                self._endpoint_cache[k] = e
        return [self._endpoint_cache[k] for k in keys]

    def _compute_endpoints(self, P: np.ndarray) -> list[_Endpoint]:
        approx = self.clearance(P)
        slack = 1.5 * self.resolution
        clear = approx - slack > self._r_block + SLACK  # surely driveable, no geometry
        bad = approx + slack < self.inscribed_radius  # surely not a base position
        unsure = ~clear & ~bad
        entry = P.copy()
        ok = ~bad
        if unsure.any():
            idx = np.flatnonzero(unsure)
            Q = P[idx]
            exact = self.exact_clearance(Q)
            in_drive = shapely.contains_xy(self.driveable, Q[:, 0], Q[:, 1])
            ok[idx] = exact >= self.inscribed_radius - INSCRIBED_TOLERANCE
            band = idx[~in_drive & ok[idx]]
            if len(band):
                # Nearest point of the driveable region shrunk by 2 * SLACK: strictly
                # inside it, also where the region ends in a wedge (table by a wall).
                lines = shapely.shortest_line(shapely.points(P[band]), self._driveable_inner)
                target = shapely.get_coordinates(lines).reshape(-1, 2, 2)[:, 1]
                seg = shapely.linestrings(np.stack([P[band], target], axis=1))
                # p keeps >= the inscribed radius, so a segment that keeps it from every
                # boundary never enters an obstacle.
                seg_ok = shapely.distance(seg, self._solid) >= \
                    self.inscribed_radius - INSCRIBED_TOLERANCE
                seg_ok &= shapely.contains_xy(self.driveable, target[:, 0], target[:, 1])
                entry[band] = target
                ok[band] = seg_ok
        lead = np.linalg.norm(entry - P, axis=1)
        return [_Endpoint(p, e, d) if good else
                _Endpoint(p, None, math.inf, np.zeros(0, int), np.zeros(0))
                for p, e, d, good in zip(P, entry, lead.tolist(), ok.tolist(), strict=True)]

    def _see(self, ends: list[_Endpoint]) -> None:
        """Fills in the visible vertices of the endpoints that lack them, in one batch."""
        todo = [e for e in {id(e): e for e in ends if e.seen is None}.values()]
        if not todo:
            return
        for s in range(0, len(todo), 2000):  # chunks bound the (points x vertices) arrays
            chunk = todo[s:s + 2000]
            E = np.array([e.entry for e in chunk])
            seen = self._sight.visible(E, np.ones(len(chunk), dtype=bool),
                                       fast=self.fast_visibility)
            counts = [len(idx) for idx in seen]
            flat = np.concatenate(seen) if sum(counts) else np.zeros(0, int)
            d = np.linalg.norm(self.vertices[flat] - np.repeat(E, counts, axis=0), axis=1)
            bounds = np.concatenate([[0], np.cumsum(counts)]).tolist()
            for k, (e, idx) in enumerate(zip(chunk, seen, strict=True)):
                e.seen, e.seen_d = idx, d[bounds[k]:bounds[k + 1]]

    # -------------------------------------------------------------------------- queries
    def _query(self, P: np.ndarray, Q: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[_Endpoint], list[_Endpoint]]:
        """Per pair: the length, the first and the last graph vertex (-1, -1 when the path
        is direct or there is none), and the pairs' endpoints."""
        P = np.asarray(P, dtype=float).reshape(-1, 2)
        Q = np.asarray(Q, dtype=float).reshape(-1, 2)
        if len(P) != len(Q):
            raise ValueError(f"P and Q differ in length: {len(P)} vs {len(Q)}")
        m = len(P)
        ends = self._prepare(np.vstack([P, Q]))
        A, B = ends[:m], ends[m:]
        lengths = np.full(m, np.inf)
        first = np.full(m, -1)
        last = np.full(m, -1)
        idx = np.array([k for k, (a, b) in enumerate(zip(A, B, strict=True))
                        if a.entry is not None and b.entry is not None], dtype=int)
        if len(idx):
            ea = np.array([A[k].entry for k in idx])
            eb = np.array([B[k].entry for k in idx])
            la = np.array([A[k].lead for k in idx])
            lb = np.array([B[k].lead for k in idx])
            direct = ~self._blocking_edges.blocked(ea, eb)
            straight = np.linalg.norm(ea - eb, axis=1)
            lengths[idx[direct]] = (la + straight + lb)[direct]
            detour = idx[~direct]
            if len(detour):
                a, b = [A[k] for k in detour], [B[k] for k in detour]
                self._see(a + b)
                via, first[detour], last[detour] = self._graph.detours(a, b)
                lengths[detour] = la[~direct] + via + lb[~direct]
        return lengths, first, last, A, B

    def path_length(self, p: Sequence[float], q: Sequence[float]) -> float:
        """Collision-free path length (m) from p to q; inf when unreachable.

        Symmetric, deterministic, exact on the polygonal map (see the module docstring).
        """
        return float(self.path_lengths(np.asarray(p, float)[None], np.asarray(q, float)[None])[0])

    def path_lengths(self, P: np.ndarray, Q: np.ndarray) -> np.ndarray:
        """`path_length` for pairs (P[i], Q[i]), P and Q (m, 2): one vectorised batch."""
        return self._query(P, Q)[0]

    def path_times(self, P: np.ndarray, Q: np.ndarray, yaw_from: np.ndarray,
                   yaw_to: np.ndarray, profile: BaseProfile
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Path lengths (m), the base's motion times (s) and landing yaws (rad) for pairs
        (P[i], Q[i]): the BaseNavigator's motion along `path(P[i], Q[i])` from yaw
        `yaw_from[i]`, landing at `yaw_to[i]` (NaN: facing along the last leg), timed by
        `profile` (`base_motion.chain_time`; settle time and command hand-over not
        included). inf (and NaN yaw) where the path length is inf. One vectorised batch,
        as `path_lengths`.

        A path is up to five items: the lead from P to its entry point, the leg from there
        to the first graph vertex (or straight to Q's entry), the stretch along the graph's
        shortest route between its first and last vertex (timed once per map and profile
        by `route_table`), the leg to Q's entry, and the lead to Q.
        """
        lengths, first, last, A, B = self._query(P, Q)
        m = len(lengths)
        times = np.full(m, np.inf)
        landing = np.full(m, np.nan)
        ok = np.isfinite(lengths)
        if not ok.any():
            return lengths, times, landing
        idx = np.flatnonzero(ok)
        pa = np.array([A[k].p for k in idx])
        ea = np.array([A[k].entry for k in idx])
        eb = np.array([B[k].entry for k in idx])
        pb = np.array([B[k].p for k in idx])
        first, last = first[idx], last[idx]
        graph = first >= 0
        fi, la = np.where(graph, first, 0), np.where(graph, last, 0)
        yaw0 = np.asarray(yaw_from, float).reshape(m)[idx]
        yaw1 = np.asarray(yaw_to, float).reshape(m)[idx]
        if profile.smooth:
            # The whole path, point by point: a smooth motion's corners depend on the legs
            # on both sides of them (base_motion.path_corners). Repeated points (the
            # padding of shorter routes, a lead of no length) drop out there.
            if graph.any():
                route = self.vertices[self._graph.route_vertices(keep=not self._sealed)[fi, la]]
                inner = np.where(graph[:, None, None],
                                 np.concatenate([self.vertices[fi][:, None], route], axis=1),
                                 ea[:, None])
            else:
                inner = ea[:, None]
            points = np.concatenate([pa[:, None], ea[:, None], inner, eb[:, None],
                                     pb[:, None]], axis=1)
            times[idx], landing[idx] = smooth_chain_time(
                profile, points, np.full(len(idx), points.shape[1]), yaw0, yaw1)
            return lengths, times, landing
        vi = np.where(graph[:, None], self.vertices[fi] if len(self.vertices) else ea, eb)
        vj = np.where(graph[:, None], self.vertices[la] if len(self.vertices) else eb, eb)
        # The legs as (from, to) point pairs; the stretch (item 2) comes from the table.
        legs = [(pa, ea), (ea, vi), (vj, vj), (vj, eb), (eb, pb)]
        d = np.stack([b - a for a, b in legs], axis=1)  # (k, 5, 2)
        heading = np.arctan2(d[..., 1], d[..., 0])
        length = np.hypot(d[..., 0], d[..., 1])
        own = profile.drive_time(length)
        h_in, h_out = heading.copy(), heading.copy()
        if graph.any():
            route_in, route_out, route_time = self.route_table(profile)
            stretch = graph & (fi != la)
            h_in[:, 2] = np.where(stretch, route_in[fi, la], 0.0)
            h_out[:, 2] = np.where(stretch, route_out[fi, la], 0.0)
            own[:, 2] = np.where(stretch, route_time[fi, la], 0.0)
            length[:, 2] = np.where(stretch, self._D[fi, la], 0.0)
        times[idx], landing[idx] = chain_time(profile, h_in, h_out, length, own, yaw0, yaw1)
        return lengths, times, landing

    def route_table(self, profile: BaseProfile) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """`VisibilityGraph.route_table`: per pair of graph vertices, the headings of the
        first and last leg of the shortest route and its motion time under `profile`."""
        return self._graph.route_table(profile, keep=not self._sealed)

    def path(self, p: Sequence[float], q: Sequence[float]) -> np.ndarray | None:
        """Waypoints (k, 2) from p to q, or None when q is unreachable from p.

        Interior segments keep >= the drive radius from every footprint and the walls; the
        first and last segments (the endpoint rule) keep >= the inscribed radius.
        """
        p = np.asarray(p, float)
        q = np.asarray(q, float)
        lengths, first, last, _, _ = self._query(p[None], q[None])
        length, i, j = float(lengths[0]), int(first[0]), int(last[0])
        if not math.isfinite(length):
            return None
        a, b = self._prepare(np.vstack([p, q]))
        points = [a.p, a.entry]
        if i >= 0:
            points += [self.vertices[k] for k in self._graph.vertex_route(i, j)]
        points += [b.entry, b.p]
        out = [points[0]]
        for pt in points[1:]:
            if np.linalg.norm(pt - out[-1]) > 1e-12:
                out.append(pt)
        if len(out) == 1:
            out.append(points[-1])
        return np.array(out)
