"""Motion search (GROP*, GROP): regions, utility, optimisation quality, determinism."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import shapely
from shapely.geometry import Point, box

from s3o_drake.abstraction import HeatmapFeasibility, voronoi_partition
from s3o_drake.abstraction.shared_stop import stop_shares
from s3o_drake.belief.known_world import KnownWorld
from s3o_drake.feasibility.oracle import Heatmap
from s3o_drake.planning.motion.grop import (
    PENALTY,
    MotionResult,
    grop,
    grop_star,
    location_regions,
)
from s3o_drake.planning.navigation.map import NavigationMap
from s3o_drake.planning.time_model import CostModel
from s3o_drake.world.angles import facing_yaw, wrap
from s3o_drake.world.robot import load_robot
from s3o_drake.world.scenario import load_scenario, with_overrides

UR5E = load_robot("ur5e")

CELL = 0.05
SEQUENCE = [("goto", "l0"), ("pickup", "plate_a"), ("goto", "l1"), ("pickup", "cup_b")]
MERGED = [("goto", "l01"), ("pickup", "plate_a"), ("pickup", "cup_b")]


def _grid(size: float = 4.0) -> tuple[np.ndarray, np.ndarray]:
    xs = np.arange(round(size / CELL)) * CELL + CELL / 2
    return np.meshgrid(xs, xs)  # X[i, j] = x of column j, Y[i, j] = y of row i


def _known(scenario, perceived_chairs) -> KnownWorld:
    """What the planner knows in `scenario` with these perceived chairs."""
    return KnownWorld.of(scenario, perceived_chairs=perceived_chairs)


def _ring(center, radius: float = 0.6, width: float = 0.3) -> np.ndarray:
    """Fea^m peaking on a circle around the dish, 0 beyond `width` from it."""
    X, Y = _grid()
    r = np.hypot(X - center[0], Y - center[1])
    return np.clip(1 - np.abs(r - radius) / width, 0, 1)


@pytest.fixture(scope="module")
def scene():
    scenario = load_scenario("scenarios/small/two_dishes.yaml")
    chairs = [c.pose for c in scenario.chairs if not c.mapped]
    nav = NavigationMap(_known(scenario, chairs).obstacles, robot=UR5E)
    partition = voronoi_partition(_known(scenario, chairs))
    regions = location_regions([["plate_a"], ["cup_b"]],
                               dict(zip(partition.dishes, partition.cells, strict=True)))
    fea = HeatmapFeasibility([Heatmap(d.name, _ring(d.position), 0.0, 0.0, CELL)
                              for d in scenario.dishes])
    return scenario, nav, regions, fea


def _hand_utility(result: MotionResult, scenario, nav, fea) -> float:
    """Σ R(a) (GROP*'s utility) from single, unbatched queries."""
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


def _hand_robot_costs(result: MotionResult, scenario, nav, fea, costs: CostModel):
    """Utility and predicted time under the robot profile from single, unbatched queries:
    the navigator's segments along each path (BaseProfile.motion_time), the ExecutiveSystem's
    turn rule at a stop, the recorded pickup times, the shares of shared stops."""
    model, profile = costs.model, costs.base
    gamma = model.overheads.gamma
    dish_xy = {d.name: np.asarray(d.position, float) for d in scenario.dishes}
    kind = {d.name: d.kind for d in scenario.dishes}
    here = np.asarray(scenario.robot.start[:2], float)
    yaw = float(scenario.robot.start[2])
    cost, gain, k = 0.0, 0.0, -1
    for i, (name, arg) in enumerate(result.actions):
        if name == "goto":
            k += 1
            y = result.positions[k]
            first = next(a for n, a in result.actions[i + 1:] if n == "pickup")
            arrive = facing_yaw(y, dish_xy[first])
            cost += profile.motion_time(nav.path(here, y), yaw, arrive) + gamma
            here, yaw, turned = y, arrive, first
            served = next((j for j, (n, _) in enumerate(result.actions[i + 1:]) if n == "goto"),
                          len(result.actions) - i - 1)
            share = stop_shares(scenario.planner, robot=UR5E).of(served)  # s_k of a shared stop
        else:
            if arg != turned:
                delta = float(wrap(facing_yaw(here, dish_xy[arg]) - yaw))
                if abs(delta) > model.turn_tolerance:
                    cost += profile.turn_time(delta) + gamma
                    yaw += delta
            cost += float(model.pickup_time(kind[arg], np.linalg.norm(here - dish_xy[arg])))
            gain += scenario.planner.reward * share * float(fea.values(arg, here[None])[0])
    return gain - cost, cost + model.overheads.plan


@pytest.mark.parametrize("sequence", [SEQUENCE, MERGED])
def test_robot_profile_costs_by_hand(scene, sequence):
    """The robot cost profile's vectorised costs (one path batch per generation) are the
    time of the navigator's motions, the stop's turns and the pickups, query by query
    (stopping and going; tests/planning/test_time_model.py holds the smooth terms)."""
    scenario, nav, regions, fea = scene
    scenario = with_overrides(scenario, ("execution.motion=stop_and_go",))
    regions = {**regions, "l01": regions["l0"].union(regions["l1"])}
    costs = CostModel.for_known(KnownWorld.perfect(scenario))
    result = grop_star(sequence, regions, fea, nav, scenario.robot.start, scenario.planner,
                       seed=2, costs=costs)
    assert result.valid
    utility, predicted = _hand_robot_costs(result, scenario, nav, fea, costs)
    assert result.utility == pytest.approx(utility, abs=1e-6)
    assert result.predicted_time == pytest.approx(predicted, abs=1e-6)
    # Every sample of the search was costed the same way.
    for X, U in zip(result.history[:3], result.history_utility[:3], strict=True):
        for x, u in zip(X[:3], U[:3], strict=True):
            again = dataclasses.replace(result, positions=x)
            assert u == pytest.approx(_hand_robot_costs(again, scenario, nav, fea, costs)[0],
                                      abs=1e-6)


def test_deterministic_for_a_seed(scene):
    scenario, nav, regions, fea = scene
    for search in (grop_star, grop):
        a, b, c = (search(SEQUENCE, regions, fea, nav, scenario.robot.start, scenario.planner,
                          seed=s) for s in (7, 7, 8))
        assert np.array_equal(a.positions, b.positions) and a.utility == b.utility
        assert all(np.array_equal(x, y) for x, y in zip(a.history, b.history, strict=True))
        assert not np.array_equal(a.late, c.late)


def test_cma_runs_on_one_blas_thread_and_gives_the_setting_back(scene, monkeypatch):
    """CMA-ES's eigendecompositions are tiny: BLAS threads only contend for the cores that
    the other searches and clingo use (motion_search._BLAS)."""
    from threadpoolctl import threadpool_info, threadpool_limits

    def numpy_blas_threads() -> list[int]:  # scipy and torch bring BLAS libraries of their own
        return [i["num_threads"] for i in threadpool_info()
                if i["user_api"] == "blas" and "numpy" in i["filepath"]]

    seen = []
    eigh = np.linalg.eigh

    def counting_eigh(a, *args, **kwargs):
        seen.extend(numpy_blas_threads())
        return eigh(a, *args, **kwargs)

    monkeypatch.setattr(np.linalg, "eigh", counting_eigh)
    scenario, nav, regions, fea = scene
    with threadpool_limits(limits=2, user_api="blas"):
        grop_star(SEQUENCE, regions, fea, nav, scenario.robot.start, scenario.planner, seed=3)
        after = numpy_blas_threads()
    assert seen and set(seen) == {1}
    assert set(after) == {2}


def test_sequences_without_a_goto_need_no_search(scene):
    """A sequence without a goto is scored as it is, with no positions: the empty one (no
    dish left to collect) at 0, one picking a dish from the start at that pickup's
    utility."""
    scenario, nav, regions, fea = scene
    p = scenario.planner
    start_fea = fea.values("plate_a", np.asarray(scenario.robot.start[:2], float)[None])[0]
    for search in (grop_star, grop):
        for sequence, utility in (([], 0.0),
                                  ([("pickup", "plate_a")], p.reward * start_fea - p.delta)):
            result = search(sequence, regions, fea, nav, scenario.robot.start, p, seed=1)
            assert result.positions.shape == (0, 2) and result.samples == 1
            assert result.utility == pytest.approx(utility)


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
    nav = NavigationMap(_known(scenario, []).obstacles, robot=UR5E)
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
