"""The navigation map's visibility graph: the convex corners of the inflated obstacles,
the straight chords between them that no obstacle blocks, and the shortest routes over
them (s3o_drake/planning/navigation/map.py asks it for the detours of blocked pairs, in batches).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

import numpy as np
import shapely
from scipy.sparse.csgraph import shortest_path
from shapely.geometry.base import BaseGeometry

from s3o_drake.planning.navigation.base_motion import BaseProfile
from s3o_drake.planning.navigation.visibility import BlockingEdges, VertexSight, cross, rings
from s3o_drake.world.angles import wrap

EPS = 1e-9
SLACK = 1e-4
"""m; the graph's vertices sit this far outside the blocking polygons."""
DETOUR_BATCH = 1_000_000
"""(pair, vertex, vertex) sums per batch of `VisibilityGraph.detours`."""


class Sightline(Protocol):
    """What a detour needs of an endpoint: the graph vertices it sees and how far."""

    seen: np.ndarray
    seen_d: np.ndarray


def padded(ends: Sequence[Sightline]) -> tuple[np.ndarray, np.ndarray]:
    """The endpoints' visible vertices and distances to them as (n, k) arrays, k the most
    any sees (at least 1): the rows padded with vertex 0 at distance inf."""
    counts = np.array([len(e.seen) for e in ends], dtype=int)
    width = max(1, int(counts.max(initial=0)))
    filled = np.arange(width)[None, :] < counts[:, None]
    seen = np.zeros((len(ends), width), dtype=int)
    dist = np.full((len(ends), width), np.inf)
    if counts.sum():
        # Row-major order of the mask is the order of the concatenation.
        seen[filled] = np.concatenate([e.seen for e in ends])
        dist[filled] = np.concatenate([e.seen_d for e in ends])
    return seen, dist


class VisibilityGraph:
    """The visibility graph of one map: vertices, all-pairs shortest routes, what a point
    sees, and the routes' motion times per base profile."""

    def __init__(self, blocking: BaseGeometry, outer: BaseGeometry,
                 interior_room: BaseGeometry, room: BaseGeometry):
        """`blocking`: the obstacles inflated by the drive radius (chords may not enter
        them); `outer`: the same, SLACK larger (its convex corners are the vertices);
        `interior_room`: where the base's centre may drive; `room`: the room's polygon."""
        self.edges = BlockingEdges(blocking)
        self._route_tables: dict[BaseProfile, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
        self._route_vertices: np.ndarray | None = None
        # Convex vertices of the slightly larger polygons, inside the driveable room.
        verts, prev, nxt = [], [], []
        for ring in rings(outer):
            c = np.asarray(ring.coords)[:-1]
            if ring.is_ccw is False:  # orient so the obstacle is on the left
                c = c[::-1]
            n = len(c)
            for k in range(n):
                a, b, d = c[k - 1], c[k], c[(k + 1) % n]
                turn = cross(b - a, d - b)
                if turn > EPS:  # convex corner of the obstacle: a path may bend here
                    verts.append(b)
                    prev.append(a)
                    nxt.append(d)
        V = np.array(verts).reshape(-1, 2)
        keep = shapely.contains_xy(interior_room, V[:, 0], V[:, 1]) if len(V) else \
            np.zeros(0, dtype=bool)
        self.vertices = V[keep]
        """Convex vertices of the inflated obstacles (k, 2)."""
        prev = np.array(prev).reshape(-1, 2)[keep]
        nxt = np.array(nxt).reshape(-1, 2)[keep]
        n = len(self.vertices)
        weights = np.zeros((n, n))
        if n:
            ii, jj = np.triu_indices(n, k=1)
            A, B = self.vertices[ii], self.vertices[jj]
            free = ~self.edges.blocked(A, B)
            # A chord between two vertices of one polygon may run inside it without
            # crossing an edge; its midpoint tells.
            mid = (A + B) / 2
            free &= ~shapely.contains_xy(blocking, mid[:, 0], mid[:, 1])
            # A chord through vertices of another polygon crosses none of its edges
            # properly, yet may run inside it: furniture in a row puts the vertices of
            # several inflated footprints on one line (the four small tables of the
            # generated tasks). Those chords are tested exactly against the interior.
            if free.any() and not blocking.is_empty:
                inside = blocking.buffer(-SLACK)
                shapely.prepare(inside)
                cand = np.flatnonzero(free)
                lines = shapely.linestrings(np.stack([A[cand], B[cand]], axis=1))
                free[cand[shapely.intersects(inside, lines)]] = False
            d = np.linalg.norm(B - A, axis=1)
            weights[ii[free], jj[free]] = d[free]
            weights[jj[free], ii[free]] = d[free]
        if n:
            self.distances, self._pred = shortest_path(weights, method="D", directed=False,
                                                       return_predecessors=True)
        else:
            self.distances, self._pred = np.zeros((0, 0)), np.zeros((0, 0), dtype=int)
        """Shortest route length (m) between every pair of vertices; inf: none."""
        self.sight = VertexSight(self.vertices, prev, nxt, self.edges, room)

    def detours(self, A: Sequence[Sightline], B: Sequence[Sightline]
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """For pairs of points (A[k], B[k]) that do not see each other: the shortest
        length from A[k] over the graph to B[k] (inf: none), and its first and last graph
        vertex (-1 when none), in one batch over the vertices each sees, padded to one
        width."""
        SA, DA = padded(A)
        SB, DB = padded(B)
        n, ka, kb = len(A), SA.shape[1], SB.shape[1]
        best = np.empty(n)
        first = np.empty(n, dtype=int)
        last = np.empty(n, dtype=int)
        step = max(1, DETOUR_BATCH // (ka * kb))  # rows per batch bound the (n, ka, kb) array
        for s in range(0, n, step):
            rows = slice(s, s + step)
            total = (DA[rows, :, None] + self.distances[SA[rows, :, None], SB[rows, None, :]]
                     + DB[rows, None, :]).reshape(-1, ka * kb)
            # The first minimum in (a's vertex, b's vertex) order, as padding comes last.
            k = np.argmin(total, axis=1)
            best[rows] = total[np.arange(len(k)), k]
            i, j = np.divmod(k, kb)
            first[rows] = SA[rows][np.arange(len(k)), i]
            last[rows] = SB[rows][np.arange(len(k)), j]
        none = ~np.isfinite(best)
        first[none] = last[none] = -1
        return best, first, last

    def route_table(self, profile: BaseProfile, *, keep: bool = True
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """For every pair (i, j) of graph vertices, the heading of the first and of the last
        leg of the shortest route i -> j, and its motion time under `profile`: the drives of
        its legs and the turns at its inner vertices. Computed once per profile, by hop
        count (a route is the route to its last vertex's predecessor plus one leg); kept for the
        next call when `keep`."""
        if profile in self._route_tables:
            return self._route_tables[profile]
        n = len(self.vertices)
        V = self.vertices
        dv = V[None, :, :] - V[:, None, :]  # dv[k, j] = V[j] - V[k]
        edge_heading = np.arctan2(dv[..., 1], dv[..., 0])
        edge_time = profile.drive_time(np.hypot(dv[..., 0], dv[..., 1]))
        h_in = np.zeros((n, n))
        h_out = np.zeros((n, n))
        time_ij = np.zeros((n, n))
        done = np.eye(n, dtype=bool)
        reachable = np.isfinite(self.distances)
        rows = np.arange(n)[:, None].repeat(n, axis=1)
        while True:
            k = self._pred
            todo = reachable & ~done
            ready = todo & done[rows, np.where(k >= 0, k, 0)] & (k >= 0)
            if not ready.any():
                break
            i, j = np.nonzero(ready)
            kk = k[i, j]
            single = kk == i
            turn = profile.turn_time(wrap(edge_heading[kk, j] - h_out[i, kk]))
            time_ij[i, j] = np.where(single, 0.0, time_ij[i, kk] + turn) + edge_time[kk, j]
            h_in[i, j] = np.where(single, edge_heading[i, j], h_in[i, kk])
            h_out[i, j] = edge_heading[kk, j]
            done[i, j] = True
        if not keep:
            return h_in, h_out, time_ij
        self._route_tables[profile] = (h_in, h_out, time_ij)
        return self._route_tables[profile]

    def route_vertices(self, *, keep: bool = True) -> np.ndarray:
        """For every pair (i, j) of graph vertices, the vertices of the shortest route
        i -> j after i, in order, padded with j: (n, n, h), h the most hops of any route
        (at least 1); an unreachable pair's row is j alone. Computed once, by hop count,
        and kept for the next call when `keep`."""
        if self._route_vertices is not None:
            return self._route_vertices
        n = len(self.vertices)
        reachable = np.isfinite(self.distances)
        columns: list[np.ndarray] = []
        cols = np.arange(n)[None, :].repeat(n, axis=0)
        rows = np.arange(n)[:, None].repeat(n, axis=1)
        # route[i, j] ends with j; the hop before j is pred[i, j], the one before that
        # pred[i, pred[i, j]], ...: built from the end, then turned round.
        at = cols.copy()
        hops = np.zeros((n, n), dtype=int)
        while True:
            going = reachable & (at != rows) & (hops < n)
            if not going.any():
                break
            columns.append(np.where(going, at, -1))
            at = np.where(going, self._pred[rows, np.where(going, at, 0)], at)
            hops += going
        width = max(1, len(columns))
        table = np.full((n, n, width), -1, dtype=int)
        for k, col in enumerate(columns):
            # Column k holds the vertex k hops before the end: its place from the front.
            place = hops - 1 - k
            ok = col >= 0
            table[rows[ok], cols[ok], place[ok]] = col[ok]
        table = np.where(table >= 0, table, cols[..., None])
        if keep:
            self._route_vertices = table
        return table

    def vertex_route(self, i: int, j: int) -> list[int]:
        """Graph vertices from i to j along the precomputed shortest paths."""
        route = [j]
        while route[-1] != i:
            route.append(int(self._pred[i, route[-1]]))
        return route[::-1]
