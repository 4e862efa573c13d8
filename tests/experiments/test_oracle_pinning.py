"""Fea^m's oracle is the ArmController's pickup: pinned on exact poses, and its heatmap is
the expectation of that success under the noise."""

from pathlib import Path

import numpy as np
import pytest

from s3o_drake.commands.oracle_pinning import executed, sample_poses, summarize
from s3o_drake.feasibility.heatmaps import make_oracle
from s3o_drake.feasibility.pickup_geometry import catch_probability
from s3o_drake.world.gripper import grasp_tolerance
from s3o_drake.world.robot import load_robot
from s3o_drake.world.scenario import load_scenario

REPO = Path(__file__).resolve().parents[2]
TASK = REPO / "scenarios" / "generated" / "task_003.yaml"


@pytest.fixture(scope="module")
def oracle():
    return make_oracle(load_scenario(TASK))


@pytest.fixture(scope="module")
def poses(oracle):
    """24 exact base poses around the dishes with the oracle's verdict: drawing them rates
    150 candidates per dish, whatever the count."""
    return sample_poses(oracle, 24, np.random.default_rng(7))


def test_feasible_by_the_oracle_is_executed_and_infeasible_fails(oracle, poses):
    """On 24 exact base poses around the dishes (no noise), 12 called feasible and 12
    infeasible by the oracle, the pickup that the ArmController plans and plays
    (`plan_pickup`: without noise its outcome is the plan's) agrees every time (`s3o bench
    oracle-pinning` measures it on more)."""
    assert len(poses) == 24
    assert sum(feasible for _, _, feasible in poses) == 12
    rows = [{"dish": dish, "oracle": feasible, "executed": executed(oracle, dish, base, k)}
            for k, (dish, base, feasible) in enumerate(poses)]
    figures = summarize(rows, [])
    assert figures["disagreements"] == 0, [r for r in rows
                                           if r["oracle"] != (r["executed"] == "ok")]
    # The infeasible ones fail for the reasons the oracle's test has, not a path search.
    assert {r["executed"] for r in rows if not r["oracle"]} <= {"no_ik", "no_path"}


def test_the_heatmap_is_the_expected_success_of_a_noisy_landing(oracle):
    """Where the heatmap is neither 0 nor 1, its value is the mean of S over landings drawn
    from the noise (S: the success from where a landing at that point picks), times the
    chance that the fingers catch the dish."""
    dish = oracle.checker.scene.contents.dishes[0]
    # The map the shipped network is compared on (test_fcn.py): computed once for both, the
    # second read from the oracle's cache.
    heatmap = oracle.heatmap(dish.name)
    values = heatmap.values.ravel()
    rng = np.random.default_rng(3)
    middle = rng.permutation(np.flatnonzero((values > 0.3) & (values < 0.7)))[:3]
    noise = oracle.noise
    sigma = np.hypot(noise.nav_xy_std, noise.reach_std)
    caught = catch_probability(dish.kind, noise.reach_std, robot=oracle.checker.scene.robot)
    for k in middle:
        y = heatmap.centers().reshape(-1, 2)[k]
        landings = y + rng.normal(0.0, sigma, (400, 2))
        estimate = caught * oracle.landing_success(landings, dish.name).mean()
        # 400 draws: standard error <= 0.025; the grid's resolution adds ~0.01.
        assert values[k] == pytest.approx(estimate, abs=0.09)


def test_the_catch_probability_is_that_of_the_rayleigh_radius():
    rng = np.random.default_rng(0)
    ur5e = load_robot("ur5e")
    for kind in ("cup", "bowl", "plate"):
        xi = rng.normal(0.0, 0.01, (200_000, 2))
        empirical = np.mean(np.linalg.norm(xi, axis=1) <= grasp_tolerance(kind, robot=ur5e))
        assert catch_probability(kind, 0.01, robot=ur5e) == pytest.approx(empirical, abs=0.003)
    assert catch_probability("cup", 0.01, robot=ur5e) == pytest.approx(1 - np.exp(-3.125))
    assert catch_probability("cup", 0.0, robot=ur5e) == 1.0


def test_a_studys_first_pickups_are_sampled_by_the_plans_value():
    """Every first attempt below 0.8 and a seeded draw per bin above; the table sets the
    plan, the oracle's two values and the outcomes side by side."""
    from s3o_drake.experiments.oracle_check import first_pickups, stratified, table

    pickups = [{"attempt": 1, "dish": f"d{i}", "planned": v, "planned_pose": [0, 0, 0],
                "outcome": "done" if i % 2 else "failed: no_ik"}
               for i, v in enumerate((0.5, 0.75, 0.82, 0.85, 0.88, 0.95, 0.97, 0.99))]
    retry = {"attempt": 2, "dish": "d0", "planned": 0.5, "planned_pose": [0, 0, 0],
             "outcome": "done"}
    rows = [{"key": "run/a", "path": "t.yaml", "pickups": [*pickups, retry]}]
    first = first_pickups(rows)
    assert len(first) == 8 and first[2].before == ("d1",)
    sample = stratified(first, {(0.8, 0.9): 2, (0.9, 1.0): 1}, seed=0)
    assert [p.planned for p in sample][:2] == [0.5, 0.75] and len(sample) == 5
    assert sample == stratified(first, {(0.8, 0.9): 2, (0.9, 1.0): 1}, seed=0)
    text = table([{"planned": p.planned, "done": p.done, "expectation": 0.9,
                   "monte_carlo": 0.9} for p in sample])
    assert "| 0.0-0.7 | 1 | 0.500 | 0.900 | 0.900 | 0.000 |" in text and "Brier" in text


def test_pickups_are_drawn_by_the_dishes_their_stop_served():
    """A run's first attempts planned at one pose share a stop; the draw takes up to N from
    each stop size, and the table sets the executed landings against the Monte Carlo per
    size, with an interval over runs."""
    from s3o_drake.experiments.oracle_check import (
        by_group,
        first_pickups,
        group_of,
        group_table,
        stop_group,
    )

    def pickup(dish, pose, outcome="done", attempt=1):
        return {"attempt": attempt, "dish": dish, "kind": "cup", "planned": 0.9,
                "planned_pose": pose, "actual_pose": [pose[0] + 0.1, pose[1], 0.0],
                "reach_noise": [0.0, 0.01], "outcome": outcome}

    shared, alone = [1.0, 2.0, 0.5], [3.0, 1.0, 0.0]
    rows = [{"key": f"run/{k}", "path": "t.yaml", "method": method,
             "pickups": [pickup("a", shared), pickup("b", shared, "missed"),
                         pickup("b", alone, attempt=2), pickup("c", shared),
                         pickup("d", alone)]}
            for k, method in enumerate(("S3O-GROP*", "V-GROP*"))]
    first = first_pickups(rows, methods=["S3O-GROP*"])
    assert [(p.dish, stop_group(p)) for p in first] == [
        ("a", "3+ dishes"), ("b", "3+ dishes"), ("c", "3+ dishes"), ("d", "1 dish")]
    assert first[0].landed == (1.1, 2.0) and first[0].reach_noise == (0.0, 0.01)
    assert first[3].before == ("a", "b", "c")  # the retry collected b
    assert len(first_pickups(rows)) == 8
    sample = by_group(first, 2, by="stop", seed=0)
    assert len(sample) == 3 and sample == by_group(first, 2, by="stop", seed=0)
    assert sum(stop_group(p) == "3+ dishes" for p in sample) == 2

    results = [{"key": p.key, "stop": stop_group(p), "planned": 0.9, "expectation": 0.9,
                "monte_carlo": 0.9, "landed": p.dish != "b", "done": p.done}
               for p in first_pickups(rows)]
    text = group_table(results, by="stop")
    assert "| 3+ dishes | 6 | 2 | 0.900 | 0.900 | 0.900 | 0.667 | 0.667 | -0.233" in text
    assert "| 1 dish | 2 | 2 | 0.900 | 0.900 | 0.900 | 1.000 | 1.000 | +0.100" in text
    assert group_of(first[0], "distance") == "position unknown"  # no file t.yaml

    # plate_a at (1.85, 2.3): stops 0.5 and 1.2 m away.
    task = [{"key": "run/9", "path": "scenarios/small/two_dishes.yaml", "method": "V-GROP*",
             "pickups": [pickup("plate_a", [1.35, 2.3, 0.0]),
                         pickup("plate_a", [0.65, 2.3, 0.0], "no_ik")]}]
    near, far = first_pickups(task)
    assert (near.distance, far.distance) == pytest.approx((0.5, 1.2))
    assert [group_of(p, "distance") for p in (near, far)] == ["0.00-0.80 m", "1.00 m or more"]
    assert by_group([near, far], 1, by="distance", seed=0) == [near, far]
    rows = [{"key": p.key, "distance": group_of(p, "distance"), "planned": 0.9,
             "expectation": 0.9, "monte_carlo": 0.8, "landed": p.done, "done": p.done}
            for p in (near, far)]
    text = group_table(rows, by="distance")
    assert "stop's distance to the dish" in text and "| 1.00 m or more | 1 | 1 |" in text


def test_a_pickup_is_tested_where_the_base_landed_with_the_reach_drawn(oracle, poses):
    """The landing's test is the oracle's S at the executed landing, and the fingers catch
    only within the grasp tolerance: a reach error beyond it fails a landing that picks."""
    from s3o_drake.experiments.oracle_check import ExecutedPickup, evaluate

    dish, base = next((d, b) for d, b, _ in poses
                      if oracle.landing_success(np.array([b[:2]]), d)[0])
    tolerance = grasp_tolerance("plate", robot=oracle.checker.scene.robot)
    for noise, expected in (((0.0, 0.0), True), ((2 * tolerance, 0.0), False)):
        pickup = ExecutedPickup("run/a#0", "t.yaml", dish, 0.9, tuple(base), True, (),
                        landed=(float(base[0]), float(base[1])), reach_noise=noise,
                        kind=oracle.checker.scene.dishes[dish].kind)
        row = evaluate(pickup, oracle, samples=4, seed=0)
        assert row["landed"] is expected and row["stop"] == "1 dish"
