"""The lower bound on a task's execution time: its parts on geometry whose answer is known.
(That no executed run falls below it is checked on the local study's runs,
tests/experiments/test_evaluate.py.)"""

import math

import numpy as np
import pytest
import shapely

from s3o_drake.experiments.limit import (
    pickable_region,
    stroke_time,
    tour_length,
)
from s3o_drake.feasibility.oracle import Heatmap
from s3o_drake.world.robot import load_robot

UR5E = load_robot("ur5e")


def test_a_stroke_is_a_trapezoid_or_a_triangle():
    # 0.07 m at 0.1 m/s and 0.5 m/s²: cruises (0.02 m to reach 0.1 m/s and stop).
    assert stroke_time(0.07, 0.1, 0.5) == pytest.approx(0.07 / 0.1 + 0.1 / 0.5)
    # 0.01 m never reaches the cruise speed: accelerate half way, brake the rest.
    assert stroke_time(0.01, 0.1, 0.5) == pytest.approx(2 * math.sqrt(0.01 / 0.5))
    assert stroke_time(0.0, 0.1, 0.5) == 0.0


def test_the_tour_is_the_spanning_tree_of_the_start_and_the_regions():
    square = shapely.box(0, 0, 1, 1)
    # A row of squares 1 m apart, east of the start: 2 + 1 + 1.
    row = [shapely.affinity.translate(square, 2 + 2 * k, 0) for k in range(3)]
    assert tour_length((0.0, 0.5), row) == pytest.approx(4.0)
    # Two regions that overlap cost nothing between them (one stop may serve both), and
    # the tree still joins the third: 2 (start to the first) + 0 + 1.
    overlapping = [row[0], shapely.affinity.translate(row[0], 0.5, 0), row[1]]
    assert tour_length((0.0, 0.5), overlapping) == pytest.approx(2.5)
    assert tour_length((0.0, 0.0), []) == 0.0


def test_the_pickable_region_is_the_cells_with_a_chance():
    values = np.zeros((4, 4))
    values[1, 2] = 0.3
    values[2, 2] = 1e-6
    region = pickable_region(Heatmap("d", values, x0=10.0, y0=20.0, cell=0.5))
    assert region.equals(shapely.box(11.0, 20.5, 11.5, 21.5))
    assert pickable_region(Heatmap("d", np.zeros((2, 2)), 0.0, 0.0, 1.0)).is_empty


def test_each_ration_lifts_its_own_setting_and_all_give_the_reference_budget(scenario):
    from s3o_drake.experiments.limit import (
        ALL_CANDIDATES,
        RATIONS,
        REFERENCE_BUDGET,
        SEARCH_FACTOR,
        rationed_scenario,
    )

    planner = scenario.planner
    assert rationed_scenario(scenario, ()).planner == planner
    assert rationed_scenario(scenario, ("true_chairs",)).planner == planner  # an input
    assert rationed_scenario(scenario, ("oracle",)).planner.feasibility == "oracle"
    assert rationed_scenario(scenario, ("all_candidates",)).planner.top_k == ALL_CANDIDATES
    long = rationed_scenario(scenario, ("long_search",)).planner
    assert long.cma_generations == SEARCH_FACTOR * planner.cma_generations
    assert long.time_budget == planner.time_budget
    assert rationed_scenario(scenario, RATIONS).planner.time_budget >= REFERENCE_BUDGET
    with pytest.raises(ValueError, match="top_k"):
        rationed_scenario(scenario, ("top_k",))


def test_every_plan_is_priced_for_the_open_loop_that_judges_and_executes_it(scenario):
    """A task file that asks for recovery would price a failed pickup at the recovery's
    time; the limit's plans lose the dish, as their judged completion and their open-loop
    execution do."""
    from dataclasses import replace

    from s3o_drake.experiments.limit import RATIONS, rationed_scenario
    from s3o_drake.planning.failure_price import failure_reward

    recovering = replace(scenario, execution=replace(scenario.execution, recovery="replan"),
                         planner=replace(scenario.planner, failure_price="execution"))
    assert failure_reward(recovering, robot=UR5E) != recovering.planner.reward
    for lifted in ((), RATIONS):
        planned = rationed_scenario(recovering, lifted)
        assert planned.execution.recovery == "none"
        assert failure_reward(planned, robot=UR5E) == recovering.planner.reward


def test_a_plan_is_judged_by_the_true_world_at_the_stops_it_commands(scenario):
    """two_dishes, true chairs and every candidate: a plan, judged by the oracle's maps of
    the scenario at its stops; a map that gives a dish nothing there makes it 0."""
    from s3o_drake.experiments.limit import judged_completion, plan_rationed
    from s3o_drake.feasibility.heatmaps import compute_heatmaps
    from tests.conftest import COARSE_MAPS

    result = plan_rationed(scenario, ("true_chairs", "all_candidates"), seed=0)
    plan = result.plan
    assert plan is not None and plan.order is not None and plan.order.optimal
    truth = compute_heatmaps(scenario, progress=False, **COARSE_MAPS)
    judged = judged_completion(plan, truth)
    expected = np.prod([p.feasibility for p in plan.pickups])
    assert 0.5 < judged <= 1.0 and judged == pytest.approx(expected, abs=0.15)
    nothing = [Heatmap(h.dish, np.zeros_like(h.values), h.x0, h.y0, h.cell) for h in truth]
    assert judged_completion(plan, nothing) == 0.0


def test_no_timed_leg_from_over_the_tray_to_stow_beats_the_arms_bound(scene):
    """Drake's TOPPRA times the stow motion from every release configuration over the
    tray: none is faster than the bound's leg (at TIMING_SLACK of it)."""
    from s3o_drake.execution.arm.pickup import timed_segment
    from s3o_drake.experiments.limit import TIMING_SLACK, tray_leg_time
    from s3o_drake.feasibility.pickup_geometry import tray_arms

    leg = tray_leg_time(scene.plant, robot=scene.robot)
    assert 0.5 < leg < 2.0
    durations = []
    for grasp in ("top", "side"):
        for arm in tray_arms(grasp, robot=scene.robot)[:6]:
            start, stow = scene.q(np.zeros(3), arm=np.asarray(arm)), scene.q(np.zeros(3))
            path = np.stack([start, stow])
            durations.append(timed_segment("stow", path, scene.checker,
                                           robot=scene.robot).duration)
    assert min(durations) >= TIMING_SLACK * leg
