"""S3O's state space: Voronoi cells, candidates, Fea^t, Score and ranking (issue 4)."""

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from shapely.geometry import Point
from shapely.ops import unary_union

from s3o_drake.abstraction import (
    HeatmapFeasibility,
    LocationGrid,
    TaskFeasibility,
    build_abstraction,
    connected_partitions,
    free_space,
    top_k_distribution,
    voronoi_partition,
)
from s3o_drake.abstraction.candidates import best_sums, connected_components
from s3o_drake.abstraction.shared_stop import stop_shares
from s3o_drake.abstraction.voronoi import ARM_REACH
from s3o_drake.belief.known_world import KnownWorld
from s3o_drake.feasibility.heatmaps import compute_heatmaps
from s3o_drake.feasibility.oracle import Heatmap
from s3o_drake.world.map import Room, Table
from s3o_drake.world.objects import Dish
from s3o_drake.world.robot import load_robot
from s3o_drake.world.scenario import Scenario, load_scenario
from tests.conftest import COARSE_MAPS

UR5E = load_robot("ur5e")

SMALL = Path(__file__).resolve().parents[2] / "scenarios" / "small"


def _chairs(scenario: Scenario) -> list[list[float]]:
    return [c.pose for c in scenario.chairs]


def _known(scenario, perceived_chairs) -> KnownWorld:
    """What the planner knows in `scenario` with these perceived chairs."""
    return KnownWorld.of(scenario, perceived_chairs=perceived_chairs)


@pytest.fixture(scope="module")
def two_dishes():
    scenario = load_scenario(SMALL / "two_dishes.yaml")
    heatmaps = compute_heatmaps(scenario, **COARSE_MAPS, progress=False)
    return scenario, heatmaps


@pytest.fixture(scope="module")
def opposite_sides():
    scenario = load_scenario(SMALL / "opposite_sides.yaml")
    heatmaps = compute_heatmaps(scenario, **COARSE_MAPS,
                                progress=False)
    return scenario, heatmaps


def _rated(scenario: Scenario, shared_stop: str) -> Scenario:
    return replace(scenario, planner=replace(
        scenario.planner, shared_stop=shared_stop))


def test_dishes_30_cm_apart_merge_in_the_top_ranked_state_space(two_dishes):
    scenario, heatmaps = two_dishes
    paper = _rated(scenario, "paper")  # every pickup at its Fea^m
    abstraction = build_abstraction(_known(paper, _chairs(paper)), heatmaps)
    assert abstraction.partition.edges() == [(0, 1)]
    assert abstraction.best.groups == (("plate_a", "cup_b"),)
    assert all(v > 0.5 for v in abstraction.best.task_feasibility.values())
    assert abstraction.complete and abstraction.exhaustive
    assert len(abstraction.ranked) == 2  # the merge and plain Voronoi


def test_a_merge_is_ranked_at_the_share_its_stop_size_achieves(two_dishes):
    """The recorded shares price the merged stop's pickups as executed pickups at two-dish
    stops went, and leave one-dish locations as they are."""
    scenario, heatmaps = two_dishes
    share = stop_shares(scenario.planner, robot=UR5E).of(2)
    assert share < 1.0
    values = {}
    for rating in ("paper", "execution"):
        rated = _rated(scenario, rating)
        ranked = build_abstraction(_known(rated, _chairs(rated)), heatmaps).ranked
        values[rating] = {len(s.groups): s for s in ranked}
    merged, plain = values["paper"][1], values["paper"][2]
    assert values["execution"][2].value == pytest.approx(plain.value)
    assert values["execution"][1].value == pytest.approx(
        merged.value - (1.0 - share) * merged.score)


def test_dishes_on_opposite_sides_are_never_one_location(opposite_sides):
    scenario, heatmaps = opposite_sides
    abstraction = build_abstraction(_known(scenario, _chairs(scenario)), heatmaps)
    # Their Voronoi regions border each other across the table, so merging them is a
    # candidate; no stop serves both, so it scores nothing and is never the one searched.
    assert abstraction.partition.edges() == [(0, 1)]
    merged = [s for s in abstraction.ranked if len(s.groups) == 1]
    assert all(s.score == pytest.approx(0.0, abs=1e-9) for s in merged)
    assert all(p == 0.0 for s, p in zip(abstraction.top_k, abstraction.probabilities,
                                          strict=True) if len(s.groups) == 1)
    assert abstraction.best.groups == (("bowl_north",), ("bowl_south",))


@pytest.mark.parametrize("name", ["two_dishes", "opposite_sides"])
def test_cell_areas_add_up_to_the_reachable_free_area(name):
    scenario = load_scenario(SMALL / f"{name}.yaml")
    partition = voronoi_partition(_known(scenario, _chairs(scenario)))
    reach = scenario.planner.reach_for(scenario.robot_value)
    discs = unary_union([Point(*d.position).buffer(reach, quad_segs=32)
                         for d in scenario.dishes])
    reachable_free = free_space(_known(scenario, _chairs(scenario))).intersection(discs)
    assert reachable_free.area > 0.5
    assert sum(c.area for c in partition.cells) == pytest.approx(reachable_free.area, rel=1e-6)
    # The cells do not overlap.
    assert partition.cells[0].intersection(partition.cells[1]).area < 1e-9


def test_sym_agrees_with_nearest_dish_on_random_points(two_dishes):
    scenario, _ = two_dishes
    partition = voronoi_partition(_known(scenario, _chairs(scenario)))
    rng = np.random.default_rng(0)
    x_min, y_min, x_max, y_max = scenario.room.bounds
    points = rng.uniform([x_min, y_min], [x_max, y_max], (500, 2))
    p_WO = partition.p_WO
    free_border = partition.free.boundary
    checked = 0
    for p in points:
        d = np.sort(np.linalg.norm(p_WO - p, axis=1))
        # Skip points within a millimetre of a border (cells, reach circle, obstacles).
        if d[1] - d[0] < 1e-3 or abs(d[0] - partition.reach) < 2e-3 or \
                free_border.distance(Point(*p)) < 1e-3:
            continue
        nearest = int(np.argmin(np.linalg.norm(p_WO - p, axis=1)))
        expected = nearest if d[0] <= partition.reach and partition.free.contains(Point(*p)) \
            else None
        assert partition.sym(p) == expected
        assert partition.sym_many(p[None])[0] == (-1 if expected is None else expected)
        checked += expected is not None
    assert checked > 20  # some points did land in cells


def test_sym_of_a_state_space_maps_to_the_merged_location(two_dishes):
    scenario, heatmaps = two_dishes
    abstraction = build_abstraction(_known(scenario, _chairs(scenario)), heatmaps)
    merged = next(s for s in abstraction.ranked if len(s.groups) == 1)
    plain = abstraction.plain_voronoi
    for cell in abstraction.partition.cells:
        p = cell.representative_point().coords[0]
        assert abstraction.sym(merged, p) == 0
        assert abstraction.sym(plain, p) == abstraction.partition.sym(p)
    assert abstraction.sym(merged, (0.1, 3.9)) is None


def test_ranking_is_the_same_on_a_second_run(two_dishes):
    scenario, heatmaps = two_dishes
    first = build_abstraction(_known(scenario, _chairs(scenario)), heatmaps)
    second = build_abstraction(_known(scenario, _chairs(scenario)), list(heatmaps))
    assert [(s.groups, s.score, s.task_feasibility) for s in first.ranked] == \
        [(s.groups, s.score, s.task_feasibility) for s in second.ranked]
    np.testing.assert_array_equal(first.probabilities, second.probabilities)


def _blocked_dish_scene(side: float = 3.2) -> Scenario:
    """A dish in the middle of a `side` m square table (3.2 m: 1.6 m from every edge, beyond
    the arm's full reach from any free position) and one that stands at the edge of a small
    table."""
    return Scenario(
        seed=3, room=Room(bounds=[0.0, 0.0, 6.0, 4.0]),
        tables=[Table(name="big", center=[1.8, 2.0], size=[side, side, 0.04]),
                Table(name="small", center=[4.8, 2.0], size=[0.8, 0.8, 0.04])],
        dishes=[Dish(name="far", table="big", position=[1.8, 2.0], kind="plate"),
                Dish(name="near", table="small", position=[4.8, 1.75], kind="cup")])


def _ones(scenario: Scenario) -> list[Heatmap]:
    """Fea^m = 1 everywhere: isolates the geometry from the feasibility source."""
    return [Heatmap(d.name, np.ones((80, 120)), 0.0, 0.0, 0.05) for d in scenario.dishes]


def test_a_dish_beyond_the_planner_s_reach_gets_its_cell_within_the_arm_s():
    """1.2 m from every edge of a 2.4 m table: no free position within the planner's 1 m,
    but some within the arm's full reach, which Fea^m then rates."""
    scenario = _blocked_dish_scene(side=2.4)
    partition = voronoi_partition(_known(scenario, []))
    assert partition.unreachable == []
    far = partition.cells[partition.dishes.index("far")]
    dish = Point(1.8, 2.0)
    assert far.distance(dish) > 1.0 and far.hausdorff_distance(dish) <= ARM_REACH + 1e-3


def test_a_dish_that_no_free_position_reaches_scores_0_and_is_reported():
    scenario = _blocked_dish_scene()
    abstraction = build_abstraction(_known(scenario, []), _ones(scenario))
    assert abstraction.unreachable == ["far"]
    assert abstraction.infeasible == ["far"]
    assert abstraction.partition.cells[0].is_empty
    assert abstraction.partition.dishes == ["far", "near"]  # kept, not dropped
    best = abstraction.best
    assert best.groups == (("far",), ("near",))
    assert best.task_feasibility == {"far": 0.0, "near": 1.0}
    assert best.score == 1.0


def _bell(n: int) -> int:
    row = [1]
    for _ in range(n - 1):
        new = [row[-1]]
        for value in row:
            new.append(new[-1] + value)
        row = new
    return row[-1]


@pytest.mark.parametrize("n", range(1, 9))
def test_candidate_counts_match_the_connected_partitions_of_known_graphs(n):
    path = [{j for j in (i - 1, i + 1) if 0 <= j < n} for i in range(n)]
    assert sum(1 for _ in connected_partitions(n, path)) == 2 ** (n - 1)
    complete = [set(range(n)) - {i} for i in range(n)]
    assert sum(1 for _ in connected_partitions(n, complete)) == _bell(n)
    if n >= 3:
        cycle = [{(i - 1) % n, (i + 1) % n} for i in range(n)]
        assert sum(1 for _ in connected_partitions(n, cycle)) == 2 ** n - n
    partitions = list(connected_partitions(n, path))
    assert partitions[0] == tuple((i,) for i in range(n))  # plain Voronoi first
    assert len(set(partitions)) == len(partitions)


def test_top_k_distribution_sums_to_1(two_dishes):
    scenario, heatmaps = two_dishes
    abstraction = build_abstraction(_known(scenario, _chairs(scenario)), heatmaps)
    assert len(abstraction.top_k) <= scenario.planner.top_k
    assert math.isclose(abstraction.probabilities.sum(), 1.0)
    assert np.all(abstraction.probabilities >= 0)
    np.testing.assert_allclose(top_k_distribution([0.0, 0.0]), [0.5, 0.5])
    assert math.isclose(top_k_distribution([3.0, 1.0, 0.5]).sum(), 1.0)
    rng = np.random.default_rng(0)
    assert abstraction.sample(rng) in abstraction.top_k
    assert abstraction.random_candidate(rng) in abstraction.ranked


def test_beam_search_finds_the_exhaustive_best(two_dishes):
    scenario, heatmaps = two_dishes
    exhaustive = build_abstraction(_known(scenario, _chairs(scenario)), heatmaps)
    beam = build_abstraction(_known(scenario, _chairs(scenario)), heatmaps,
                             exhaustive_max_dishes=0)
    assert not beam.exhaustive
    assert beam.best.groups == exhaustive.best.groups


def test_any_feasibility_source_with_values_works(two_dishes):
    scenario, heatmaps = two_dishes

    class Source:  # e.g. the learned model: anything with values(dish, points)
        def __init__(self):
            self.inner = HeatmapFeasibility(heatmaps)

        def values(self, dish, points):
            return self.inner.values(dish, points)

    by_heatmaps = build_abstraction(_known(scenario, _chairs(scenario)), heatmaps)
    by_source = build_abstraction(_known(scenario, _chairs(scenario)), Source())
    assert [s.score for s in by_heatmaps.ranked] == [s.score for s in by_source.ranked]


def test_unmapped_chairs_count_only_when_passed_as_perceived(two_dishes):
    scenario, _ = two_dishes
    assert not any(c.mapped for c in scenario.chairs)
    without = free_space(_known(scenario, []))
    with_chair = free_space(_known(scenario, _chairs(scenario)))
    assert with_chair.area < without.area - 0.1
    mapped = replace(scenario, chairs=[replace(c, mapped=True) for c in scenario.chairs])
    assert free_space(_known(mapped, [])).area == pytest.approx(with_chair.area)


def test_paper_ranking_without_location_cost_still_keeps_scores(two_dishes):
    scenario, heatmaps = two_dishes
    abstraction = build_abstraction(_known(scenario, _chairs(scenario)), heatmaps,
                                    location_cost=0.0)
    scores = [s.score for s in abstraction.ranked]
    assert scores == sorted(scores, reverse=True)


def test_best_sums_matches_brute_force():
    rng = np.random.default_rng(1)
    a = sorted([(((i,),), float(v)) for i, v in enumerate(rng.uniform(0, 3, 12))],
               key=lambda t: -t[1])
    b = sorted([(((100 + i,),), float(v)) for i, v in enumerate(rng.uniform(0, 3, 9))],
               key=lambda t: -t[1])
    brute = sorted((x[1] + y[1] for x in a for y in b), reverse=True)[:20]
    assert [v for _, v in best_sums(a, b, 20)] == pytest.approx(brute)
    assert connected_components(5, [{1}, {0}, set(), {4}, {3}]) == [[0, 1], [2], [3, 4]]


def _two_table_scene() -> tuple[Scenario, list[Heatmap]]:
    """Two tables, two dishes each; Fea^m a ring 0.45-1.0 m around each dish."""
    scenario = Scenario(
        seed=5, room=Room(bounds=[0.0, 0.0, 8.0, 4.0]),
        tables=[Table(name="west", center=[2.0, 2.0], size=[1.2, 0.8, 0.04]),
                Table(name="east", center=[6.0, 2.0], size=[1.2, 0.8, 0.04])],
        dishes=[Dish(name="w1", table="west", position=[1.8, 1.8], kind="cup"),
                Dish(name="w2", table="west", position=[2.3, 2.2], kind="cup"),
                Dish(name="e1", table="east", position=[5.7, 1.75], kind="cup"),
                Dish(name="e2", table="east", position=[6.4, 2.25], kind="cup")])
    heatmaps = []
    for d in scenario.dishes:
        grid = Heatmap(d.name, np.zeros((80, 160)), 0.0, 0.0, 0.05)
        r = np.linalg.norm(grid.centers() - np.array(d.position), axis=-1)
        values = np.clip(1.0 - np.abs(r - 0.75) / 0.3, 0.0, 1.0)
        heatmaps.append(Heatmap(d.name, np.round(values * 4) / 4, 0.0, 0.0, 0.05))
    return scenario, heatmaps


def test_components_combined_rank_like_enumerating_the_whole_graph():
    scenario, heatmaps = _two_table_scene()
    abstraction = build_abstraction(_known(scenario, []), heatmaps)
    components = connected_components(4, abstraction.partition.adjacency)
    assert len(components) == 2  # the two tables are far apart
    cost = scenario.planner.gamma / scenario.planner.reward
    task = TaskFeasibility(LocationGrid.of(abstraction.partition, heatmaps), samples=100,
                           seed=scenario.seed, positions=scenario.planner.group_positions)
    shares = stop_shares(scenario.planner, robot=UR5E)  # a merged group at its stop size's share
    brute = sorted(sum(shares.of(len(g)) * task.group_score(list(g)) for g in p) - cost * len(p)
                   for p in connected_partitions(4, abstraction.partition.adjacency))[::-1]
    assert abstraction.count == len(brute)
    assert [s.value for s in abstraction.ranked] == pytest.approx(brute)
    assert abstraction.exhaustive and abstraction.complete
    # S3O-Random: uniform over the product of the components' partitions.
    rng = np.random.default_rng(0)
    drawn = {abstraction.random_candidate(rng).indices for _ in range(400)}
    assert drawn == {s.indices for s in abstraction.ranked}


def test_benchmark_help_and_bad_input(tmp_path):
    import subprocess
    import sys

    command = [sys.executable, "-m", "s3o_drake.commands.abstraction_benchmark"]
    result = subprocess.run([*command, "--help"], capture_output=True, text=True, check=True)
    assert "--counts" in result.stdout and "<= 1 s" in result.stdout
    for bad in (["--counts", "0"], ["--base", str(tmp_path / "nope.yaml")], ["--fast"]):
        result = subprocess.run([*command, *bad], capture_output=True, text=True, cwd=tmp_path)
        assert result.returncode == 2, bad
        assert result.stderr.count("\n") == 1, result.stderr


def test_a_chair_between_two_cells_does_not_keep_their_dishes_apart():
    """task_002: a chair splits the floor in front of cup_1 and plate_1 on the bar. The
    cup's own cell picks it from nowhere; the plate's cell holds the stops that pick both.
    Adjacent by their Voronoi regions, the two may merge, and S3O's best state space does.
    Apart, the cup claims the plate's positions that pick it (`voronoi.py`, claims)."""
    scenario = load_scenario(Path("scenarios/generated/task_002.yaml"))
    known = KnownWorld.perfect(scenario)
    partition = voronoi_partition(known)
    cup, plate = partition.dishes.index("cup_1"), partition.dishes.index("plate_1")
    assert not partition.cells[cup].buffer(1e-3).intersects(partition.cells[plate])
    assert plate in partition.adjacency[cup]
    # The oracle's coarse maps (the test is about the cells, not the maps' accuracy).
    heatmaps = compute_heatmaps(known, ["cup_1", "plate_1"], progress=False,
                                obstacles=known.obstacles, **COARSE_MAPS)
    alone = build_abstraction(known, heatmaps, dishes=["cup_1", "plate_1"])
    claimed = alone.partition.claims
    assert [i for i, _ in claimed] == [alone.partition.dishes.index("cup_1")]
    assert claimed[0][1].intersects(partition.cells[plate])  # taken from the plate's cell
    assert alone.plain_voronoi.task_feasibility["cup_1"] > 0.5
    assert alone.plain_voronoi.task_feasibility["plate_1"] > 0.9  # the plate keeps its own
    assert alone.best.groups == (("cup_1", "plate_1"),)
    assert alone.best.task_feasibility["cup_1"] > 0.5


class _TwoSpots:
    """Fea^m of two dishes at two base positions: each dish is picked well from one spot and
    poorly from the other (x < 0.5: plate_a's spot; x >= 0.5: cup_b's)."""

    def values(self, dish, points):
        left = np.asarray(points)[:, 0] < 0.5
        good = left if dish == "plate_a" else ~left
        return np.where(good, 0.9, 0.1)


def test_a_merge_scores_the_stops_that_serve_the_whole_group_when_positions_are_shared():
    """Per dish, each dish is scored at its own best spot (0.82 each) although one stop must
    serve both; shared positions score the merge by the stops it really has (0.5 each)."""
    from shapely.geometry import box

    points = np.array([[0.0, 0.0], [1.0, 0.0]])
    grid = LocationGrid(points, np.array([0, 1]), [box(-0.5, -0.5, 0.5, 0.5),
                                                  box(0.5, -0.5, 1.5, 0.5)],
                        ["plate_a", "cup_b"], _TwoSpots(), ["plate_a", "cup_b"])
    per_dish = TaskFeasibility(grid, samples=100, seed=0).of_group([0, 1])
    shared = TaskFeasibility(grid, samples=100, seed=0, positions="shared").of_group([0, 1])
    assert per_dish == pytest.approx([0.82, 0.82])
    assert shared == pytest.approx([0.5, 0.5])
    # Alone, a dish is scored the same either way.
    for k in (0, 1):
        assert TaskFeasibility(grid, samples=100, seed=0, positions="shared").of_group([k]) \
            == pytest.approx(TaskFeasibility(grid, samples=100, seed=0).of_group([k]))
    with pytest.raises(ValueError, match="positions"):
        TaskFeasibility(grid, samples=10, seed=0, positions="joint")
