"""The motion search's stops are free: a search result whose stop collides is moved."""

from __future__ import annotations

import numpy as np
import pytest
from shapely.geometry import Point

from s3o_drake.abstraction import HeatmapFeasibility, voronoi_partition
from s3o_drake.belief.known_world import KnownWorld
from s3o_drake.experiments.plan_checks import plan_faults, ring_heatmaps
from s3o_drake.feasibility.check import FeasibilityChecker
from s3o_drake.feasibility.oracle import Heatmap
from s3o_drake.feasibility.planning_scene import PlanningScene
from s3o_drake.feasibility.scene import FeasibilityScene
from s3o_drake.planning.methods import plan_task
from s3o_drake.planning.motion.free_positions import RADIUS, with_free_stops
from s3o_drake.planning.motion.grop import SequenceProblem, grop_star, location_regions
from s3o_drake.planning.navigation.map import NavigationMap
from s3o_drake.world.random_scenes import SceneShape, random_scene
from s3o_drake.world.scenario import load_scenario
from s3o_drake.world.settings import PlanningSettings
from tests.conftest import still_clock

SEQUENCE = [("goto", "l0"), ("pickup", "plate_a"), ("goto", "l1"), ("pickup", "cup_b")]


@pytest.fixture(scope="module")
def searched():
    """A GROP* result on two_dishes, with its problem."""
    scenario = load_scenario("scenarios/small/two_dishes.yaml")
    known = KnownWorld.perfect(scenario)
    nav = NavigationMap(known.obstacles, robot=known.robot)
    partition = voronoi_partition(known)
    regions = location_regions([["plate_a"], ["cup_b"]],
                               dict(zip(partition.dishes, partition.cells, strict=True)))
    fea = HeatmapFeasibility(ring_heatmaps(known))
    start = scenario.robot.start
    result = grop_star(SEQUENCE, regions, fea, nav, start, scenario.planner, seed=1)
    problem = SequenceProblem(SEQUENCE, regions, fea, nav, start, scenario.planner, None)
    assert result.valid
    return result, problem


def test_free_stops_are_kept_as_they_are(searched):
    result, problem = searched
    assert with_free_stops(result, problem, lambda p, ds: np.ones(len(p), bool)) is result


def test_a_stop_that_collides_moves_to_a_free_position_near_it_in_its_region(searched):
    """The plate's stop is declared blocked within 5 cm of where the search put it: it
    moves just outside that disc (no farther than RADIUS), stays in its region, and the
    other stop and the result's bookkeeping stay consistent."""
    result, problem = searched
    blocked = result.positions[0].copy()

    def free(points: np.ndarray, dishes) -> np.ndarray:
        far = np.hypot(*(points - blocked).T) > 0.05
        return far | (np.array(dishes) != "plate_a")

    moved = with_free_stops(result, problem, free)
    assert moved is not result and moved.valid
    d = np.hypot(*(moved.positions[0] - blocked))
    assert 0.05 < d <= RADIUS + 1e-9
    assert problem.regions[0].covers(Point(*moved.positions[0]))
    assert np.array_equal(moved.positions[1], result.positions[1])
    u = problem.evaluate(moved.positions[None])[0][0]
    assert moved.utility == pytest.approx(u)
    assert moved.samples == result.samples


def test_a_region_with_no_free_position_leaves_the_stop(searched):
    result, problem = searched
    moved = with_free_stops(result, problem, lambda p, ds: np.zeros(len(p), bool))
    assert moved is result


def test_soak_scene_33_plans_free_stops(monkeypatch):
    """The soak's scene 33 (ring heatmaps): a chair's corner cuts a heatmap cell that the
    free-stop rule keeps, and S3O-GROP planned dish_2's stop inside it, 1 cm from free
    space. Every goto pose must be free by the execution's own check."""
    import s3o_drake.planning.methods as methods

    # clingo's own cap per state space is wall time, 2 s: on a busy machine it can order
    # none of V-GROP's 28 locations. Idle clingo ends each search by its stall, well before.
    monkeypatch.setattr(methods, "TASK_TIME_LIMIT", 60.0)
    scene = random_scene(0, 33, SceneShape(max_dishes=30),
                         planner=PlanningSettings(time_budget=5.0, workers=1))
    known = KnownWorld.perfect(scene)
    # The execution's base check, which needs no reachability map ("ik" loads none).
    checker = FeasibilityChecker(FeasibilityScene(known.contents), method="ik")
    heatmaps: list[Heatmap] = ring_heatmaps(known)
    planning = PlanningScene(known)  # one belief, planned by both methods
    for method in ("S3O-GROP", "V-GROP"):
        # The plan an idle machine makes within the budget (2.5 s of 5 s), on any machine.
        plan = plan_task(known, method=method, heatmaps=heatmaps, seed=scene.seed,
                         scene=planning, time_budget=5.0, clock=still_clock).plan
        assert plan_faults(known, plan, checker.base_free) == [], method
