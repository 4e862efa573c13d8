"""Segment-crossing and visibility tests against the edges of the inflated obstacles.

The navigation map (s3o_drake/planning/navigation/map.py) asks two questions many thousand
times per plan: does a segment cross an edge of the blocking polygons (`BlockingEdges`),
and which graph vertices does a point see (`VertexSight`: the tangent ones, tested with
`VisibilityPolygons`, the segment test's answer in O(log n) from polygons precomputed by
ray casting).
"""

from __future__ import annotations

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

_EPS = 1e-9
_MAX_LENGTH = 1e3
"""An upper bound on a segment's length (m), for the cheap first filter of vertices on a
segment."""
_VERTEX_STEP = 1e-6
"""How far (m) beside a blocking vertex on a segment the segment is asked whether it lies
inside a blocking polygon."""


def cross(u: np.ndarray, v: np.ndarray) -> float:
    """The z component of u x v for two 2-vectors."""
    return float(u[0] * v[1] - u[1] * v[0])


def cross2(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """`cross` over the leading axes of (..., 2) arrays (broadcast)."""
    return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]


def rings(geometry: BaseGeometry) -> list:
    """Exterior and interior rings of a (multi)polygon."""
    if geometry.is_empty:
        return []
    polygons = getattr(geometry, "geoms", [geometry])
    out = []
    for poly in polygons:
        out.append(poly.exterior)
        out.extend(poly.interiors)
    return out


class BlockingEdges:
    """The edges of the blocking polygons (segments a path must not cross), indexed by the
    bounding boxes of their rings and of each edge."""

    def __init__(self, blocking: BaseGeometry):
        self._blocking = blocking
        shapely.prepare(blocking)
        edges = []
        for ring in rings(blocking):
            c = np.asarray(ring.coords)
            edges.append(np.hstack([c[:-1], c[1:]]))
        self.edges = np.vstack(edges) if edges else np.zeros((0, 4))
        """Edges (e, 4) as rows [x0, y0, x1, y1], ring after ring."""
        counts = np.array([len(e) for e in edges], dtype=int)
        self._ring_count = counts
        self._ring_start = np.cumsum(counts) - counts
        self._ring_lo = np.array([e.reshape(-1, 2).min(axis=0) for e in edges]).reshape(-1, 2)
        self._ring_hi = np.array([e.reshape(-1, 2).max(axis=0) for e in edges]).reshape(-1, 2)
        self._edge_lo = np.minimum(self.edges[:, :2], self.edges[:, 2:])
        self._edge_hi = np.maximum(self.edges[:, :2], self.edges[:, 2:])

    def blocked(self, A: np.ndarray, B: np.ndarray, chunk: int = 20_000) -> np.ndarray:
        """Whether segments A[i] -> B[i] properly cross a blocking edge, or pass through a
        blocking vertex into a blocking polygon: (m,) bool.

        Two bounding-box filters first (segment against each obstacle ring, then against
        each edge of the rings it meets), the orientation test only on the (segment,
        edge) pairs left: a segment meets few edges, so this is several times faster than
        testing them all. A segment through a vertex crosses no edge properly (two
        inflated chairs that meet leave vertices on a line of symmetry, and a segment
        along it went through a closed door); the rare vertex on a segment is asked of the
        polygons themselves.
        """
        m = len(A)
        out = np.zeros(m, dtype=bool)
        if not m or not len(self.edges):
            return out
        if m <= 4:  # few segments: one test against every edge costs fewer numpy calls
            a, b = A[:, None, :], B[:, None, :]
            p0, p1 = self.edges[None, :, :2], self.edges[None, :, 2:]
            ed, sd = p1 - p0, b - a
            d3 = cross2(sd, p0 - a)
            hit = ((cross2(ed, a - p0) * cross2(ed, b - p0) < 0)
                   & (d3 * cross2(sd, p1 - a) < 0))
            out = hit.any(axis=1)
            ki, ei = np.nonzero(~hit)
            self._through_vertex(A, B, ki, ei, d3[ki, ei], out)
            return out
        lo, hi = np.minimum(A, B), np.maximum(A, B)
        rlo, rhi = self._ring_lo, self._ring_hi
        for s in range(0, m, chunk):
            sl, sh = lo[s:s + chunk], hi[s:s + chunk]
            near = ((sl[:, None, 0] <= rhi[None, :, 0]) & (sh[:, None, 0] >= rlo[None, :, 0])
                    & (sl[:, None, 1] <= rhi[None, :, 1]) & (sh[:, None, 1] >= rlo[None, :, 1]))
            ki, ri = np.nonzero(near)
            if not len(ki):
                continue
            counts = self._ring_count[ri]
            offsets = np.repeat(np.cumsum(counts) - counts, counts)
            ei = np.arange(counts.sum()) - offsets + np.repeat(self._ring_start[ri], counts)
            ki = np.repeat(ki, counts)
            keep = ((sl[ki, 0] <= self._edge_hi[ei, 0]) & (sh[ki, 0] >= self._edge_lo[ei, 0])
                    & (sl[ki, 1] <= self._edge_hi[ei, 1]) & (sh[ki, 1] >= self._edge_lo[ei, 1]))
            ki, ei = ki[keep] + s, ei[keep]
            a, b = A[ki], B[ki]
            p0, p1 = self.edges[ei, :2], self.edges[ei, 2:]
            ed, sd = p1 - p0, b - a
            d1 = cross2(ed, a - p0)
            d2 = cross2(ed, b - p0)
            d3 = cross2(sd, p0 - a)
            d4 = cross2(sd, p1 - a)
            proper = (d1 * d2 < 0) & (d3 * d4 < 0)
            out[ki[proper]] = True
            self._through_vertex(A, B, ki[~proper], ei[~proper], d3[~proper], out)
        return out

    def _through_vertex(self, A: np.ndarray, B: np.ndarray, ki: np.ndarray, ei: np.ndarray,
                        d3: np.ndarray, out: np.ndarray) -> None:
        """Sets out[k] for the segments k (of pairs ki, ei) whose open interior holds the
        first vertex of edge ei and enters a blocking polygon there."""
        # Cheap first: a vertex on the segment's line (|d3| = |sd| x distance; segments are
        # shorter than _MAX_LENGTH), then the few left exactly.
        near = np.abs(d3) <= _EPS * _MAX_LENGTH
        ki, ei, d3 = ki[near], ei[near], d3[near]
        if not len(ki):
            return
        a, sd = A[ki], B[ki] - A[ki]
        length2 = np.einsum("ij,ij->i", sd, sd)
        p0 = self.edges[ei, :2]
        t = np.einsum("ij,ij->i", p0 - a, sd) / np.maximum(length2, _EPS)
        on = (np.abs(d3) <= _EPS * np.sqrt(length2)) & (t > _EPS) & (t < 1 - _EPS) & ~out[ki]
        if not on.any():
            return
        step = _VERTEX_STEP * sd[on] / np.sqrt(length2[on])[:, None]
        beside = np.concatenate([p0[on] + step, p0[on] - step])
        inside = shapely.contains_xy(self._blocking, beside[:, 0], beside[:, 1])
        half = int(on.sum())
        out[ki[on][inside[:half] | inside[half:]]] = True


_ANGLE_SLACK = 1e-7
"""rad; an edge's angular span, seen from a ray's origin, is widened by this before rays
are paired with it: float error at its ends (the rays 1e-9 beside each end included)
never drops a ray that hits it."""


def _first_hits(v: np.ndarray, ang: np.ndarray, d: np.ndarray,
                edges: np.ndarray) -> np.ndarray:
    """The distance (m) along each ray from `v` at the sorted angles `ang` (r,) in
    [0, 2 pi), directions `d` (r, 2), to the first of `edges` (e, 4) it hits: (r,), inf
    for none.

    A ray can hit an edge only within the angle the edge spans seen from `v` (the short
    way round), so each edge is tested against the rays in its span alone (a contiguous
    run of the sorted angles) rather than against all of them: the same intersection
    test on fewer pairs, the same answers several times faster."""
    two_pi = 2 * np.pi
    e0, e1 = edges[:, :2], edges[:, 2:]
    ed, w = e1 - e0, e0 - v
    a0 = np.arctan2(w[:, 1], w[:, 0]) % two_pi
    a1 = np.arctan2(e1[:, 1] - v[1], e1[:, 0] - v[0]) % two_pi
    span = (a1 - a0) % two_pi
    long_way = span > np.pi
    lo = (np.where(long_way, a1, a0) - _ANGLE_SLACK) % two_pi
    span = np.where(long_way, two_pi - span, span) + 2 * _ANGLE_SLACK
    r = len(ang)
    twice = np.concatenate([ang, ang + two_pi])  # a span may pass angle 0
    first = np.searchsorted(twice, lo, "left")
    count = np.minimum(np.searchsorted(twice, lo + span, "right") - first, r)
    ei = np.repeat(np.arange(len(edges)), count)
    within = np.arange(int(count.sum())) - np.repeat(np.cumsum(count) - count, count)
    ri = (np.repeat(first, count) + within) % r
    dr, ee, we = d[ri], ed[ei], w[ei]
    denom = cross2(dr, ee)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = cross2(we, ee) / denom
        u = cross2(we, dr) / denom
    valid = (np.abs(denom) > 1e-15) & (t > 0) & (u >= 0) & (u <= 1)
    rho = np.full(r, np.inf)
    np.minimum.at(rho, ri[valid], t[valid])
    return rho


class VisibilityPolygons:
    """Each graph vertex's visibility polygon, as rays sorted by angle.

    Rays from vertex v towards every blocking vertex (and eps to either side) hit the
    blocking edges (or a box around the room) at points h; between two consecutive rays
    the boundary of what v sees is the segment between their hits, because no blocking
    vertex lies strictly between them. So "p sees v" is a binary search on the angle of
    p - v and one comparison: O(log n), against O(edges) for the exact segment test
    (`BlockingEdges.blocked`), and exact up to eps-wide wedges (~1e-8 m).
    """

    def __init__(self, vertices: np.ndarray, edges: np.ndarray, room: BaseGeometry,
                 eps: float = 1e-9):
        """`vertices` (n, 2): the graph's; `edges` (e, 4): the blocking edges
        (`BlockingEdges.edges`); `room`: the polygon whose bounds, grown by 1 m, close
        every ray."""
        self.vertices = vertices
        n = len(vertices)
        self._ray_key = np.zeros(0)
        if not n:
            return
        x0, y0, x1, y1 = room.buffer(1.0, join_style="mitre").bounds
        box_c = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])
        box_e = np.hstack([box_c, np.roll(box_c, -1, axis=0)])
        all_edges = np.vstack([edges, box_e])
        targets = np.unique(np.vstack([edges[:, :2], box_c]), axis=0)
        keys, hits = [], []
        for i, v in enumerate(vertices):
            base = np.arctan2(targets[:, 1] - v[1], targets[:, 0] - v[0])
            ang = np.unique(np.concatenate([base - eps, base, base + eps]) % (2 * np.pi))
            d = np.stack([np.cos(ang), np.sin(ang)], axis=1)  # (r, 2)
            rho = _first_hits(v, ang, d, all_edges)
            h = v + d * rho[:, None]
            # Wrap around: the last ray before angle 0 and the first after 2 pi.
            ang = np.concatenate([[ang[-1] - 2 * np.pi], ang, [ang[0] + 2 * np.pi]])
            h = np.vstack([h[-1:], h, h[:1]])
            keys.append(ang + 8.0 * i)
            hits.append(h)
        self._ray_key = np.concatenate(keys)
        self._ray_hit = np.vstack(hits)

    def sees(self, P: np.ndarray, vi: np.ndarray) -> np.ndarray:
        """Whether point P[k] sees graph vertex vi[k]."""
        if not len(vi):
            return np.zeros(0, dtype=bool)
        V = self.vertices[vi]
        dp = P - V
        ang = np.arctan2(dp[:, 1], dp[:, 0]) % (2 * np.pi)
        pos = np.searchsorted(self._ray_key, ang + 8.0 * vi)
        pos = np.clip(pos, 1, len(self._ray_key) - 1)
        h0, h1 = self._ray_hit[pos - 1], self._ray_hit[pos]
        dh = h1 - h0
        dist = np.linalg.norm(dp, axis=1)
        u = dp / np.maximum(dist, _EPS)[:, None]
        denom = cross2(u, dh)
        with np.errstate(divide="ignore", invalid="ignore"):
            rho = cross2(h0 - V, dh) / denom
        near = np.minimum(np.linalg.norm(h0 - V, axis=1), np.linalg.norm(h1 - V, axis=1))
        rho = np.where(np.abs(denom) > 1e-12, rho, near)
        return dist < rho


class VertexSight:
    """The graph vertices a point sees that a shortest path may leave it by: tangent
    vertices (both of the vertex's obstacle edges on one side of the sight line) in sight.
    """

    def __init__(self, vertices: np.ndarray, prev: np.ndarray, nxt: np.ndarray,
                 edges: BlockingEdges, room: BaseGeometry):
        """`vertices` (n, 2): the graph's, convex corners of the inflated obstacles; `prev`,
        `nxt` (n, 2): the corners before and after each along its ring; `edges`: the
        blocking edges; `room`: see `VisibilityPolygons`."""
        self.vertices = vertices
        self._prev = prev
        self._next = nxt
        self._prev_len = np.linalg.norm(prev - vertices, axis=1)
        self._next_len = np.linalg.norm(nxt - vertices, axis=1)
        self.edges = edges
        self.polygons = VisibilityPolygons(vertices, edges.edges, room)

    def visible(self, E: np.ndarray, ok: np.ndarray, *, fast: bool = True) -> list[np.ndarray]:
        """For each point E[k] (m, 2) with ok[k], the tangent graph vertices it sees
        (indices); `fast=False` asks the exact segment test instead of the polygons."""
        n = len(self.vertices)
        m = len(E)
        if not n:
            return [np.zeros(0, int) for _ in range(m)]
        V = self.vertices
        dv = V[None, :, :] - E[:, None, :]  # (m, n, 2)
        # Sines of the angles between p -> v and v's two edges: v is a tangent vertex
        # when both edges lie on one side of the line. Nearly collinear edges (|sin| <
        # 0.01) count too: the slack offsets can put a point just on the wrong side, and
        # an extra candidate only costs time (every candidate is a real path).
        dist = np.maximum(np.linalg.norm(dv, axis=2), _EPS)
        s1 = cross2(dv, (self._prev - V)[None]) / (dist * self._prev_len[None])
        s2 = cross2(dv, (self._next - V)[None]) / (dist * self._next_len[None])
        tangent = ((s1 * s2 >= 0) | (np.minimum(np.abs(s1), np.abs(s2)) < 0.01)) \
            & ok[:, None]
        mi, vi = np.nonzero(tangent)
        free = self.polygons.sees(E[mi], vi) if fast else ~self.edges.blocked(E[mi], V[vi])
        mi, vi = mi[free], vi[free]
        # mi is sorted (np.nonzero's row-major order): point k's vertices are one slice.
        bounds = np.searchsorted(mi, np.arange(m + 1)).tolist()
        return [vi[bounds[k]:bounds[k + 1]] for k in range(m)]
