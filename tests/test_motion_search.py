"""Motion search (GROP*, GROP): regions, utility, optimisation quality, determinism."""

from __future__ import annotations

import numpy as np
import pytest
import shapely
from shapely.geometry import Point, box

from s3o_drake.abstraction import HeatmapFeasibility, voronoi_partition
from s3o_drake.feasibility.oracle import Heatmap
from s3o_drake.planning.motion_search import (
    PENALTY,
    MotionResult,
    grop,
    grop_star,
    location_regions,
)
from s3o_drake.planning.navigation import NavigationMap
from s3o_drake.scenario import load_scenario

CELL = 0.05
SEQUENCE = [("goto", "l0"), ("pickup", "plate_a"), ("goto", "l1"), ("pickup", "cup_b")]


def _grid(size: float = 4.0) -> tuple[np.ndarray, np.ndarray]:
    xs = np.arange(round(size / CELL)) * CELL + CELL / 2
    return np.meshgrid(xs, xs)  # X[i, j] = x of column j, Y[i, j] = y of row i


def _ring(center, radius: float = 0.6, width: float = 0.3) -> np.ndarray:
    """Fea^m peaking on a circle around the dish, 0 beyond `width` from it."""
    X, Y = _grid()
    r = np.hypot(X - center[0], Y - center[1])
    return np.clip(1 - np.abs(r - radius) / width, 0, 1)


@pytest.fixture(scope="module")
def scene():
    scenario = load_scenario("scenarios/small/two_dishes.yaml")
    chairs = [c.pose for c in scenario.chairs if not c.mapped]
    nav = NavigationMap(scenario, chairs)
    partition = voronoi_partition(scenario, chairs)
    regions = location_regions([["plate_a"], ["cup_b"]],
                               dict(zip(partition.dishes, partition.cells, strict=True)))
    fea = HeatmapFeasibility([Heatmap(d.name, _ring(d.position), 0.0, 0.0, CELL)
                              for d in scenario.dishes])
    return scenario, nav, regions, fea


def _hand_utility(result: MotionResult, scenario, nav, fea) -> float:
    """Σ R(a) of DESIGN.md 2.6 from single, unbatched queries."""
    p = scenario.planner
    here = np.asarray(scenario.robot.start[:2], float)
    k, total = 0, 0.0
    for name, arg in result.actions:
        if name == "goto":
            y = result.positions[k]
            total -= nav.path_length(here, y) / p.speed + p.gamma
            here, k = y, k + 1
        else:
            total += -p.delta + p.reward * float(fea.values(arg, here[None])[0])
    return total


@pytest.mark.parametrize("search", [grop_star, grop])
def test_positions_in_regions_and_utility_by_hand(scene, search):
    scenario, nav, regions, fea = scene
    result = search(SEQUENCE, regions, fea, nav, scenario.robot.start, scenario.planner, seed=1)
    assert result.valid and result.samples == 200
    assert result.locations == ("l0", "l1")
    for (x, y), loc in zip(result.positions, result.locations, strict=True):
        assert regions[loc].covers(Point(x, y))
    assert result.utility == pytest.approx(_hand_utility(result, scenario, nav, fea), abs=1e-6)
    p = scenario.planner
    assert result.predicted_time == pytest.approx(
        result.leg_lengths.sum() / p.speed + 2 * p.delta)
    assert set(result.feasibility) == {"plate_a", "cup_b"}
    assert all(v > 0.5 for v in result.feasibility.values())
    assert len(result.history) == 20 and result.early.shape == (10, 2, 2)


def test_deterministic_for_a_seed(scene):
    scenario, nav, regions, fea = scene
    for search in (grop_star, grop):
        a, b, c = (search(SEQUENCE, regions, fea, nav, scenario.robot.start, scenario.planner,
                          seed=s) for s in (7, 7, 8))
        assert np.array_equal(a.positions, b.positions) and a.utility == b.utility
        assert all(np.array_equal(x, y) for x, y in zip(a.history, b.history, strict=True))
        assert not np.array_equal(a.late, c.late)


def test_cma_beats_random_sampling(scene):
    """A narrow Fea^m peak per dish: CMA-ES with 200 samples does at least as well as 200
    uniform samples of the regions (and as GROP, which sees the heatmap)."""
    scenario, nav, regions, _ = scene
    X, Y = _grid()
    peaks = {"plate_a": (1.55, 1.75), "cup_b": (2.45, 1.75)}
    fea = HeatmapFeasibility([
        Heatmap(d, np.exp(-((X - c[0]) ** 2 + (Y - c[1]) ** 2) / (2 * 0.15 ** 2)), 0.0, 0.0, CELL)
        for d, c in peaks.items()])
    start = scenario.robot.start
    for seed in range(3):
        star = grop_star(SEQUENCE, regions, fea, nav, start, scenario.planner, seed=seed)
        rng = np.random.default_rng(seed)
        draws = []
        for loc in ("l0", "l1"):
            region = regions[loc]
            x0, y0, x1, y1 = region.bounds
            P = rng.uniform((x0, y0), (x1, y1), size=(5000, 2))
            P = P[shapely.contains_xy(region, P[:, 0], P[:, 1])][:200]
            draws.append(P)
        best_random = -np.inf
        for y0, y1 in zip(*draws, strict=True):
            fake = MotionResult("random", tuple(SEQUENCE), ("l0", "l1"), np.array([y0, y1]),
                                0.0, True, 0.0, np.zeros(2), {}, 200, 0.0)
            best_random = max(best_random, _hand_utility(fake, scenario, nav, fea))
        base = grop(SEQUENCE, regions, fea, nav, start, scenario.planner, seed=seed)
        assert star.utility >= best_random - 1e-9
        assert star.utility >= base.utility - 1.0  # within 1 s-equivalent of GROP, or above


def test_prefers_the_near_spot():
    """One location with two equally feasible spots: the one near the start wins (the far
    spot is larger so that the initial point starts in it)."""
    scenario = load_scenario("scenarios/small/two_dishes.yaml")
    nav = NavigationMap(scenario, [])
    X, Y = _grid()
    near, far = (0.9, 1.2), (3.1, 1.2)
    values = ((np.hypot(X - near[0], Y - near[1]) < 0.2)
              | (np.hypot(X - far[0], Y - far[1]) < 0.3)).astype(float)
    fea = HeatmapFeasibility([Heatmap("plate_a", values, 0.0, 0.0, CELL)])
    regions = {"l0": box(0.5, 0.7, 3.5, 1.7)}
    sequence = [("goto", "l0"), ("pickup", "plate_a")]
    for search in (grop_star, grop):
        result = search(sequence, regions, fea, nav, scenario.robot.start, scenario.planner,
                        seed=0)
        assert result.feasibility["plate_a"] == 1.0
        assert np.hypot(*(result.positions[0] - near)) < 0.25, search.__name__


def test_grop_samples_only_where_feasible(scene):
    scenario, nav, regions, fea = scene
    result = grop(SEQUENCE, regions, fea, nav, scenario.robot.start, scenario.planner, seed=2)
    samples = np.concatenate(result.history)
    assert samples.shape == (200, 2, 2)
    assert (fea.values("plate_a", samples[:, 0]) > 0).all()
    assert (fea.values("cup_b", samples[:, 1]) > 0).all()
    assert len(np.unique(samples[:, 0], axis=0)) > 20  # spread, not a single cell


def test_outside_samples_penalised_and_bad_sequences(scene):
    scenario, nav, regions, fea = scene
    result = grop_star(SEQUENCE, regions, fea, nav, scenario.robot.start, scenario.planner,
                       seed=3)
    utilities = np.concatenate(result.history_utility)
    samples = np.concatenate(result.history)
    inside = np.array([all(regions[loc].covers(Point(*s[k])) for k, loc in enumerate(("l0", "l1")))
                       for s in samples])
    assert (utilities[~inside] < -PENALTY).all()
    assert (utilities[inside] > -PENALTY).all()
    with pytest.raises(ValueError, match="no region"):
        grop_star([("goto", "nowhere")], regions, fea, nav, scenario.robot.start,
                  scenario.planner)
