"""Tests of the navigation map: path lengths and paths for the base."""

import itertools
import math

import numpy as np
import pytest
import shapely
from shapely.geometry import LineString

from s3o_drake.abstraction.voronoi import free_space
from s3o_drake.belief.known_world import KnownWorld
from s3o_drake.commands.navigation_benchmark import benchmark, main
from s3o_drake.feasibility.scene import ENVIRONMENT_PADDING
from s3o_drake.planning.navigation.map import DRIVE_MARGIN, INSCRIBED_TOLERANCE, NavigationMap
from s3o_drake.world.map import Room, Table
from s3o_drake.world.robot import load_robot
from s3o_drake.world.scenario import Scenario, load_scenario

RESTAURANT = "scenarios/restaurant.yaml"
UR5E = load_robot("ur5e")
BASE_RADIUS, INSCRIBED_RADIUS = UR5E.base_radius, UR5E.inscribed_radius
DRIVE_RADIUS = BASE_RADIUS + DRIVE_MARGIN


def _room(tables=()) -> Scenario:
    return Scenario(room=Room(bounds=[0.0, 0.0, 6.0, 4.0]), tables=list(tables))


def _known(scenario, perceived_chairs) -> KnownWorld:
    """What the planner knows in `scenario` with these perceived chairs."""
    return KnownWorld.of(scenario, perceived_chairs=perceived_chairs)


def _one_table() -> Scenario:
    return _room([Table(name="t", center=[3.0, 2.0], yaw=0.0, size=[1.0, 0.6, 0.04])])


@pytest.fixture(scope="module")
def restaurant():
    scenario = load_scenario(RESTAURANT)
    perceived = [list(c.pose) for c in scenario.chairs if not c.mapped]
    return scenario, perceived, NavigationMap(_known(scenario, perceived).obstacles, robot=UR5E)


def _free_points(scenario, perceived, n, seed=0) -> np.ndarray:
    """Positions the abstraction calls free, near the dishes (where CMA-ES samples)."""
    region = free_space(_known(scenario, perceived))
    dishes = np.array([d.position for d in scenario.dishes])
    rng = np.random.default_rng(seed)
    out = np.zeros((0, 2))
    while len(out) < n:
        c = dishes[rng.integers(len(dishes), size=4 * n)] + rng.uniform(-1, 1, (4 * n, 2))
        out = np.vstack([out, c[shapely.contains_xy(region, c[:, 0], c[:, 1])]])
    return out[:n]


def test_radii():
    # The execution's collision check pads by ENVIRONMENT_PADDING: paths keep more.
    assert DRIVE_RADIUS >= BASE_RADIUS + ENVIRONMENT_PADDING
    assert abs(INSCRIBED_RADIUS - 0.28) < 1e-12


def test_empty_room_is_straight_line():
    nav = NavigationMap(_known(_room(), []).obstacles, robot=UR5E)
    p, q = [1.0, 1.0], [5.0, 3.2]
    assert nav.path_length(p, q) == pytest.approx(math.dist(p, q), abs=1e-9)
    path = nav.path(p, q)
    np.testing.assert_allclose(path, [p, q])


def test_around_a_table_matches_the_analytic_shortest_path():
    nav = NavigationMap(_known(_one_table(), []).obstacles, robot=UR5E)
    p, q = np.array([1.5, 2.0]), np.array([4.5, 2.0])
    r = DRIVE_RADIUS
    # Around the rounded rectangle (table offset by r): tangent, arc, top, arc, tangent.
    corner = np.array([2.5, 2.3])
    w = p - corner
    d = np.linalg.norm(w)
    theta_t = math.atan2(w[1], w[0]) % (2 * math.pi) - math.acos(r / d)
    analytic = 2 * (math.sqrt(d * d - r * r) + r * (theta_t - math.pi / 2)) + 1.0
    length = nav.path_length(p, q)
    assert length > math.dist(p, q) + 0.1
    assert length == pytest.approx(analytic, abs=0.03)
    path = nav.path(p, q)
    np.testing.assert_allclose(path[0], p)
    np.testing.assert_allclose(path[-1], q)
    assert np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1)) == pytest.approx(length)


def test_paths_keep_their_clearances(restaurant):
    scenario, perceived, nav = restaurant
    obstacles = nav.obstacles
    walls = nav.room.exterior
    points = _free_points(scenario, perceived, 80, seed=1)
    checked = 0
    for p, q in zip(points[:40], points[40:], strict=True):
        path = nav.path(p, q)
        length = nav.path_length(p, q)
        if path is None:
            assert length == math.inf
            continue
        checked += 1
        np.testing.assert_allclose(path[0], p)
        np.testing.assert_allclose(path[-1], q)
        assert np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1)) == pytest.approx(length)
        segments = [LineString(path[k:k + 2]) for k in range(len(path) - 1)]
        for k, seg in enumerate(segments):
            clearance = min(seg.distance(obstacles.boundary), seg.distance(walls))
            assert not seg.intersects(obstacles.buffer(-1e-9))
            end = k == 0 or k == len(segments) - 1
            if end:
                assert clearance >= INSCRIBED_RADIUS - INSCRIBED_TOLERANCE
            else:
                assert clearance >= BASE_RADIUS - 1e-6
        # An endpoint's segment may come closer than BASE_RADIUS only where it touches it.
        for k in (0, len(segments) - 1):
            seg = segments[k]
            inner = seg.interpolate(0.999 if k == 0 else 0.001, normalized=True)
            if len(segments) > 1 and seg.length > 1e-3:
                assert min(inner.distance(obstacles), inner.distance(walls)) >= BASE_RADIUS - 0.01
    assert checked >= 30


def test_band_point_next_to_a_table_is_reachable():
    nav = NavigationMap(_known(_one_table(), []).obstacles, robot=UR5E)
    spot = [3.0, 2.3 + 0.33]  # 0.33 m from the table's edge: free, not driveable
    assert not nav.driveable.contains(shapely.Point(spot))
    length = nav.path_length([1.0, 3.5], spot)
    assert math.isfinite(length)
    path = nav.path([1.0, 3.5], spot)
    last = LineString(path[-2:])
    assert last.distance(nav.obstacles) >= INSCRIBED_RADIUS - 1e-6
    assert last.length == pytest.approx(DRIVE_RADIUS - 0.33, abs=0.02)


def test_enclosed_goal_is_unreachable():
    scenario = _room()
    centre = np.array([3.0, 2.0])
    chairs = []
    for k in range(4):  # four chairs facing the centre, 0.8 m away
        angle = k * math.pi / 2
        chairs.append([*(centre + 0.8 * np.array([math.cos(angle), math.sin(angle)])),
                       angle + math.pi])
    nav = NavigationMap(_known(scenario, chairs).obstacles, robot=UR5E)
    assert nav.exact_clearance(centre)[0] >= INSCRIBED_RADIUS
    assert nav.path_length([0.8, 0.8], centre) == math.inf
    assert nav.path([0.8, 0.8], centre) is None
    # The same chairs, not perceived: free.
    free = NavigationMap(_known(scenario, []).obstacles, robot=UR5E)
    assert math.isfinite(free.path_length([0.8, 0.8], centre))


def test_perceived_chairs_change_the_path():
    p, q = [1.0, 2.0], [5.0, 2.0]
    without = NavigationMap(_known(_room(), []).obstacles, robot=UR5E)
    with_chair = NavigationMap(_known(_room(), [[3.0, 2.0, 0.3]]).obstacles, robot=UR5E)
    assert without.path_length(p, q) == pytest.approx(4.0)
    assert with_chair.path_length(p, q) > 4.0 + 0.05
    assert len(with_chair.path(p, q)) > 2


def test_symmetric_deterministic_and_batched(restaurant):
    scenario, perceived, nav = restaurant
    points = _free_points(scenario, perceived, 60, seed=2)
    P, Q = points[:30], points[30:]
    forward = nav.path_lengths(P, Q)
    backward = nav.path_lengths(Q, P)
    np.testing.assert_allclose(forward, backward, rtol=1e-9, atol=1e-9)
    single = np.array([nav.path_length(p, q) for p, q in zip(P, Q, strict=True)])
    np.testing.assert_array_equal(forward, single)
    again = NavigationMap(_known(scenario, perceived).obstacles, robot=UR5E).path_lengths(P, Q)
    np.testing.assert_array_equal(forward, again)
    straight = np.linalg.norm(P - Q, axis=1)
    finite = np.isfinite(forward)
    assert finite.mean() > 0.9
    assert np.all(forward[finite] >= straight[finite] - 1e-9)


def test_points_inside_obstacles_or_outside_the_room_are_unreachable(restaurant):
    scenario, _, nav = restaurant
    table = scenario.tables[1]
    start = scenario.robot.start[:2]
    for bad in (table.center, [-1.0, 3.0], [table.center[0], table.center[1] + 0.6]):
        assert nav.path_length(start, bad) == math.inf
        assert nav.path_length(bad, start) == math.inf
        assert nav.path(start, bad) is None


def test_clearance_field_agrees_with_geometry(restaurant):
    scenario, perceived, nav = restaurant
    points = _free_points(scenario, perceived, 200, seed=3)
    approx = nav.clearance(points)
    exact = nav.exact_clearance(points)
    assert np.max(np.abs(approx - exact)) <= 1.5 * nav.resolution


def test_cli(capsys):
    with pytest.raises(SystemExit) as info:
        main(["--help"])
    assert info.value.code == 0
    with pytest.raises(SystemExit) as info:
        main(["--queries", "3"])
    assert info.value.code == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1
    with pytest.raises(SystemExit) as info:
        main(["--tasks", "no_such_file.yaml"])
    assert info.value.code == 2
    assert main(["--tasks", str(RESTAURANT)]) == 0


def test_fast_visibility_agrees_with_the_exact_segment_test(restaurant):
    scenario, perceived, fast = restaurant
    exact = NavigationMap(_known(scenario, perceived).obstacles, robot=UR5E, fast_visibility=False)
    points = _free_points(scenario, perceived, 400, seed=4)
    V = fast.vertices
    mi, vi = np.nonzero(np.ones((len(points), len(V)), dtype=bool))
    sees = fast._sight.polygons.sees(points[mi], vi)
    assert 0.05 < sees.mean() < 0.95
    np.testing.assert_array_equal(sees, ~fast._blocking_edges.blocked(points[mi], V[vi]))
    np.testing.assert_array_equal(fast.path_lengths(points[:200], points[200:]),
                                  exact.path_lengths(points[:200], points[200:]))


def test_lengths_match_an_independent_visibility_graph():
    """Reference: shortest paths over all vertices of the driveable polygon (shapely)."""
    from scipy.sparse.csgraph import shortest_path

    scenario = _one_table()
    nav = NavigationMap(_known(scenario, [[1.6, 2.9, 0.4], [4.4, 1.2, 2.0]]).obstacles, robot=UR5E)
    region = nav.driveable.buffer(1e-7)
    rng = np.random.default_rng(6)
    points = rng.uniform([0.4, 0.4], [5.6, 3.6], (200, 2))
    points = points[shapely.contains_xy(nav.driveable, points[:, 0], points[:, 1])][:20]
    V = np.unique(np.round(shapely.get_coordinates(nav.driveable.boundary), 9), axis=0)
    N = np.vstack([V, points])
    ii, jj = np.triu_indices(len(N), 1)
    free = shapely.covers(region, shapely.linestrings(np.stack([N[ii], N[jj]], axis=1)))
    W = np.zeros((len(N), len(N)))
    d = np.linalg.norm(N[ii] - N[jj], axis=1)
    W[ii[free], jj[free]] = d[free]
    W[jj[free], ii[free]] = d[free]
    D = shortest_path(W, directed=False)
    k = len(V)
    reference = np.array([D[k + a, k + a + 1] for a in range(0, len(points), 2)])
    got = nav.path_lengths(points[0::2], points[1::2])
    np.testing.assert_allclose(got, reference, atol=1e-3)
    assert np.any(got > np.linalg.norm(points[0::2] - points[1::2], axis=1) + 0.05)


def test_benchmark_reports_figures(restaurant):
    scenario, perceived, _ = restaurant
    figures = benchmark(_known(scenario, perceived), queries=50)
    assert figures["vertices"] > 0
    assert figures["cma_like_batch50_ms"] > 0
    assert 0.9 < figures["finite_fraction"] <= 1.0


def test_every_free_position_near_the_dishes_is_reachable(restaurant):
    """The abstraction's free space (inscribed radius) is all reachable in the restaurant,
    including the 0.75 m gap between small_4 and the wall (not driveable)."""
    scenario, perceived, nav = restaurant
    points = _free_points(scenario, perceived, 2000, seed=7)
    gap = np.array([[9.555, 1.93], [9.709, 2.192], [9.671, 1.079], [9.618, 1.297]])
    points = np.vstack([points, gap])
    start = np.repeat(np.array(scenario.robot.start[:2])[None], len(points), axis=0)
    lengths = nav.path_lengths(start, points)
    assert np.all(np.isfinite(lengths))
    for q in gap:
        path = nav.path(scenario.robot.start[:2], q)
        last = LineString(path[-2:])
        assert min(last.distance(nav.obstacles), last.distance(nav.room.exterior)) \
            >= INSCRIBED_RADIUS - INSCRIBED_TOLERANCE


def test_a_full_endpoint_cache_starts_afresh_without_losing_the_batch(monkeypatch):
    from s3o_drake.planning.navigation import map as navigation

    monkeypatch.setattr(navigation, "_ENDPOINT_CACHE_SIZE", 4)
    nav = NavigationMap(_known(_room(), []).obstacles, robot=UR5E)
    P = np.array([[1.0, 1.0], [1.2, 1.0], [1.4, 1.0]])
    Q = np.array([[2.0, 2.0], [2.0, 1.8], [2.0, 1.6]])
    first = nav.path_lengths(P, Q)
    again = nav.path_lengths(P + 0.01, Q)  # overflows the cache: keys of both batches
    np.testing.assert_allclose(first, np.linalg.norm(P - Q, axis=1))
    np.testing.assert_allclose(again, np.linalg.norm(P + 0.01 - Q, axis=1))


def test_furniture_in_a_row_does_not_open_a_way_through_the_middle():
    """The generated tasks' four small tables stand in a row: the inflated footprints'
    vertices at the tables' edge line are collinear, and a chord along that line crosses
    no edge properly. The benchmark's robot drove into small_2 on such a path."""
    scenario = load_scenario("scenarios/generated/task_010.yaml")
    nav = NavigationMap(KnownWorld.perfect(scenario).obstacles, robot=UR5E)
    path = nav.path([3.349, 1.567], [8.969, 2.589])
    assert path is not None
    # Interior segments keep the driving clearance (the first and the last join stops).
    for a, b in itertools.pairwise(path[1:-1]):
        assert LineString([a, b]).distance(nav.obstacles) >= DRIVE_RADIUS - 1e-3


def _door(width: float):
    """A 6 x 4 m room split at x = 3 by a wall with a door `width` wide, centred at y = 2."""
    from shapely.geometry import box

    from s3o_drake.world.obstacles import Obstacles

    half = width / 2
    return Obstacles(room=box(0, 0, 6, 4), footprints=(box(2.9, 0, 3.1, 2 - half),
                                                        box(2.9, 2 + half, 3.1, 4)))


def test_a_tight_map_passes_a_door_the_usual_margin_closes_by_millimetres():
    """A door 0.88 m wide, its jambs' corners rounded as the map circumscribes them (up to
    2 % more): closed by 13 mm with the usual drive clearance (0.438 m), open by 7 mm with
    the tight one (0.428 m, the collision check's padding)."""
    from s3o_drake.planning.navigation.map import TIGHT_DRIVE_MARGIN

    rounding = 1.0 / math.cos(math.pi / 16)
    assert 2 * (BASE_RADIUS + TIGHT_DRIVE_MARGIN) * rounding < 0.88 < \
        2 * DRIVE_RADIUS * rounding
    usual = NavigationMap(_door(0.88), robot=UR5E)
    tight = NavigationMap(_door(0.88), robot=UR5E, drive_margin=TIGHT_DRIVE_MARGIN)
    assert usual.drive_radius == DRIVE_RADIUS
    assert tight.drive_radius == pytest.approx(BASE_RADIUS + ENVIRONMENT_PADDING)
    a, b = [1.0, 1.2], [5.0, 3.1]  # through the door, not along its axis
    assert math.isinf(usual.path_length(a, b))
    assert tight.path_length(a, b) == pytest.approx(math.dist(a, b), abs=0.05)
    path = tight.path(a, b)
    assert shapely.distance(LineString(path), shapely.box(2.9, 0, 3.1, 1.56)) >= \
        BASE_RADIUS + ENVIRONMENT_PADDING - 1e-3
    with pytest.raises(ValueError, match="drive_margin"):
        NavigationMap(_door(0.88), robot=UR5E, drive_margin=ENVIRONMENT_PADDING / 2)


def test_the_way_out_leaves_a_pocket_that_leads_nowhere_aside():
    """A 0.89 m aisle between the wall (y = 0) and a table across the room holds a strip of
    driveable positions 1.4 cm wide that leads nowhere; a robot standing against the wall
    there backs out to the room beyond the table, not into the strip."""
    from shapely.geometry import box

    from s3o_drake.planning.navigation.map import WAY_OUT_MIN_AREA
    from s3o_drake.world.obstacles import Obstacles

    nav = NavigationMap(Obstacles(room=box(0, 0, 6, 4), footprints=(box(0, 0.89, 6, 1.2),)),
                        robot=UR5E)
    parts = sorted(g.area for g in shapely.get_parts(nav.driveable))
    assert len(parts) == 2 and parts[0] < WAY_OUT_MIN_AREA < parts[1]
    here = np.array([3.0, 0.25])  # 0.25 m from the wall: no base position of the map
    assert not nav.drivable_from(here[None])[0]
    out = nav.way_out(here)
    assert out[1] > 1.2 + DRIVE_RADIUS - 1e-3 and out[0] == pytest.approx(3.0, abs=1e-6)
    assert nav.reachable(out, np.array([[1.0, 3.0], [5.0, 3.0]])).all()


def test_a_closed_door_is_closed_along_its_axis_too():
    """Door 0.855 m: the inflated jambs overlap, and their union has vertices on the door's
    axis. The straight segment along the axis passes through them, crossing no edge
    properly; it used to go through the closed door."""
    nav = NavigationMap(_door(0.855), robot=UR5E)
    assert not nav.driveable.intersects(shapely.box(2.95, 1.9, 3.05, 2.1))
    for y in (2.0, 2.0001, 1.9999):
        assert math.isinf(nav.path_length([1.0, y], [5.0, y]))
    open_ = NavigationMap(_door(0.95), robot=UR5E)
    assert open_.path_length([1.0, 2.0], [5.0, 2.0]) == pytest.approx(4.0)


def test_each_ray_meets_the_first_edge_in_its_way_as_the_all_pairs_test_finds_it():
    """`_first_hits` pairs each edge only with the rays in its angular span; against every
    pair tested (the definition), on random edges around the origin, some across angle 0,
    with rays at random angles and at the edges' ends."""
    from s3o_drake.planning.navigation.visibility import _first_hits, cross2

    rng = np.random.default_rng(3)
    edges = rng.uniform(-5, 5, (60, 4))
    edges[:5] = [[2, -1, 2, 1], [3, 0.5, 3, -0.5], [-1, -2, 1, -2], [4, 0, 5, 0], [1, 1, 2, 2]]
    v = np.zeros(2)
    ends = np.arctan2(edges[:, [1, 3]], edges[:, [0, 2]]).ravel()
    ang = np.unique(np.concatenate([ends - 1e-9, ends, ends + 1e-9,
                                    rng.uniform(0, 2 * np.pi, 300)]) % (2 * np.pi))
    d = np.stack([np.cos(ang), np.sin(ang)], axis=1)
    e0, ed = edges[:, :2], edges[:, 2:] - edges[:, :2]
    w = e0 - v
    denom = cross2(d[:, None, :], ed[None, :, :])
    with np.errstate(divide="ignore", invalid="ignore"):
        t = cross2(w[None], ed[None]) / denom
        u = cross2(w[None], d[:, None, :]) / denom
    valid = (np.abs(denom) > 1e-15) & (t > 0) & (u >= 0) & (u <= 1)
    reference = np.where(valid, t, np.inf).min(axis=1)
    np.testing.assert_array_equal(_first_hits(v, ang, d, edges), reference)
    assert np.isfinite(reference).mean() > 0.5
