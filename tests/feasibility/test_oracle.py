"""Fea^m under uncertainty: probabilities, heatmaps, determinism, the picture."""

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from s3o_drake.feasibility.check import FeasibilityChecker
from s3o_drake.feasibility.heatmaps import compute_heatmaps
from s3o_drake.feasibility.oracle import FeasibilityOracle
from s3o_drake.feasibility.oracle_cache import CACHE_VARIABLE
from s3o_drake.feasibility.pickup_geometry import (
    catch_probability,
    goal_probability,
    place_probability,
)
from s3o_drake.feasibility.reachability.map import ReachabilityMap
from s3o_drake.feasibility.scene import FeasibilityScene
from s3o_drake.world.angles import facing_yaw
from s3o_drake.world.goals import with_place_targets
from s3o_drake.world.map import Chair
from s3o_drake.world.placing import PLACE_TOLERANCE
from s3o_drake.world.robot import load_robot
from s3o_drake.world.scenario import load_scenario

UR5E = load_robot("ur5e")

REPO = Path(__file__).resolve().parents[2]
SMALL = REPO / "scenarios" / "small" / "two_dishes.yaml"
# plate_a stands 0.2 m inside the table's free south edge (y = 2.1); from here, facing
# north, the base's front is 0.1 m from the edge and the dish 0.7 m ahead.
OPEN_SPOT = np.array([1.85, 1.6])


@pytest.fixture(scope="module")
def rmap(scenario):
    return ReachabilityMap.load(robot=scenario.contents.robot)


def _oracle(scenario, rmap) -> FeasibilityOracle:
    return FeasibilityOracle(FeasibilityChecker(FeasibilityScene(scenario.contents), rmap),
                             scenario.uncertainty)


def _with_chair_beside_open_spot(scenario, gap: float):
    """A chair east of OPEN_SPOT, about `gap` metres beyond the base's padded side."""
    # Facing away from the robot (yaw 0), the chair's rear legs stand 0.19 m behind the
    # seat's centre, at the chassis' height; the 1 cm padding counts as contact.
    x = OPEN_SPOT[0] + UR5E.base_width / 2 + 0.01 + gap + 0.19
    chair = Chair(name="close_chair", pose=[x, OPEN_SPOT[1], 0.0])
    return dataclasses.replace(scenario, chairs=[*scenario.chairs, chair])


def test_facing_yaw_points_at_the_dish():
    assert facing_yaw(np.array([0.0, 0.0]), np.array([1.0, 1.0])) == pytest.approx(math.pi / 4)
    yaws = facing_yaw(np.array([[0.0, 0.0], [2.0, 0.0]]), np.array([1.0, 0.0]))
    np.testing.assert_allclose(yaws, [0.0, math.pi])


def test_noise_lowers_the_probability_next_to_an_obstacle_not_in_the_open(rmap):
    """A chair 5 cm beside the stop: a landing into it is approached from the stop and
    lands short of it (not a blocked drive), and picks from there less often."""
    scenario = load_scenario(SMALL)
    crowded = _with_chair_beside_open_spot(scenario, gap=0.05)
    exact = dataclasses.replace(scenario.uncertainty, nav_xy_std=0.0, nav_yaw_std=0.0,
                                reach_std=0.0)
    for world, expect_drop in ((scenario, False), (crowded, True)):
        oracle = _oracle(world, rmap)
        p_noisy = oracle.probability(OPEN_SPOT, "plate_a", rng=np.random.default_rng(0),
                                     samples=40)
        oracle.noise = exact
        p_exact = oracle.probability(OPEN_SPOT, "plate_a", rng=np.random.default_rng(0),
                                     samples=4)
        assert p_exact == 1.0
        if expect_drop:
            assert 0.6 < p_noisy < 0.9
        else:
            assert p_noisy >= 0.9


def test_heatmap_is_a_probability_map_around_the_dish(rmap):
    scenario = load_scenario(SMALL)
    oracle = _oracle(scenario, rmap)
    heatmap = oracle.heatmap("plate_a")
    assert heatmap.values.shape == (64, 64)
    assert heatmap.cell == pytest.approx(4.0 / 64)
    assert np.all((heatmap.values >= 0) & (heatmap.values <= 1))
    # Feasible in front of the dish; beyond the arm's reach (about 1.35 m from the base's
    # centre, with a side grasp) only the Gaussian tail of landing noise past 3 sigma.
    assert heatmap.value_at(OPEN_SPOT) >= 0.6
    dish = np.array(scenario.dishes[0].position)
    far = np.linalg.norm(heatmap.centers() - dish, axis=-1) > 1.35 + 3 * 0.1
    assert heatmap.values[far].max() < 2e-3


def test_heatmaps_do_not_depend_on_the_worker_count(monkeypatch):
    """An expectation, not a sample: a map computed again, in the process that computed
    another map first or in a worker of its own, is the same bit for bit. Coarse maps: the
    computation is the full-resolution one's on a coarser grid."""
    monkeypatch.delenv(CACHE_VARIABLE, raising=False)  # both computed, neither read back
    scenario = load_scenario(SMALL)
    kwargs = {"cells": 16, "fine_cell": 0.25, "progress": False}
    one = compute_heatmaps(scenario, workers=1, **kwargs)
    two = compute_heatmaps(scenario, workers=2, **kwargs)
    assert [h.dish for h in one] == ["plate_a", "cup_b"]
    for a, b in zip(one, two, strict=True):
        np.testing.assert_array_equal(a.values, b.values)



def test_benchmark_rejects_bad_arguments_in_one_line(capsys):
    from s3o_drake.commands.feasibility_benchmark import main as benchmark_main

    with pytest.raises(SystemExit) as info:
        benchmark_main(["--queries", "3"])
    assert info.value.code == 2
    assert capsys.readouterr().err.count("\n") == 1


def test_a_place_is_rated_by_the_chance_the_object_stands_within_tolerance(scenario):
    """Putting an object down is not caught: the reach errors of its pickup (the offset in
    the hand, across the fingers centred for an object held whole) and of the place add up,
    and Fea^m's factor is the chance the object ends within PLACE_TOLERANCE."""
    robot = scenario.contents.robot
    assert place_probability("cup", 0.0, robot=robot) == 1.0
    # A pinched rim keeps the whole pickup error: 2 sigma² per axis, a Rayleigh radius.
    assert place_probability("plate", 0.01, robot=robot) == pytest.approx(
        1 - math.exp(-PLACE_TOLERANCE**2 / (4 * 0.01**2)), abs=1e-5)
    # Held whole, one axis loses the pickup's error: between the two isotropic cases.
    whole = place_probability("apple", 0.01, robot=robot)
    assert 1 - math.exp(-PLACE_TOLERANCE**2 / (4 * 0.01**2)) < whole < \
        1 - math.exp(-PLACE_TOLERANCE**2 / (2 * 0.01**2))
    assert place_probability("apple", 0.02, robot=robot) < whole
    # The same object picked is rated by its catch, placed by its place.
    assert goal_probability("apple", "apple", 0.01, robot=robot) == catch_probability(
        "apple", 0.01, robot=robot)
    assert goal_probability("apple__place", "apple", 0.01, robot=robot) == whole


def test_a_place_targets_heatmap_is_its_monte_carlo_expectation(rmap):
    """The oracle's two computations agree for a place target: the heatmap (the blurred
    success times `place_probability`) and the Monte Carlo reference (each landing, the
    place's reach noise and the object's offset in the hand drawn)."""
    tidy = with_place_targets(load_scenario(REPO / "scenarios" / "tidy_home.yaml"))
    oracle = _oracle(tidy, rmap)
    # The crop the network is compared on (test_fcn.py): computed once for both, the second
    # read from the oracle's cache.
    heatmap = oracle.heatmap("apple__place")
    best = heatmap.centers()[np.unravel_index(np.argmax(heatmap.values), heatmap.values.shape)]
    assert heatmap.values.max() <= place_probability("apple", tidy.uncertainty.reach_std,
                                                     robot=tidy.robot_value)
    p = oracle.probability(best, "apple__place", rng=np.random.default_rng(0), samples=400)
    # 400 samples near p = 0.9: a standard error of 0.015.
    assert p == pytest.approx(heatmap.values.max(), abs=0.05)
