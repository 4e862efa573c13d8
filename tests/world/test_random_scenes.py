"""Random valid scenes planned by every method (issue 19, item 1): no crash, a plan or a
"no plan" that says why, every plan through the plan checker with its goto poses free in
the known world, and no budget overrun by more than 5 %. The budgets are this process's
CPU time (`plan_and_check`'s clock): the machine's other work does not eat them.

Bounded: the suite stays fast (a few small scenes, a cheap Fea^m, tiny budgets).
S3O_PROPERTY_EXAMPLES=200 tries many more, S3O_PROPERTY_DISHES=30 larger scenes,
S3O_PROPERTY_LARGE=1 adds a 28-dish scene; the soak
(`s3o bench soak`) runs the full-size version.
"""

import os
import time

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from s3o_drake.belief.known_world import KnownWorld
from s3o_drake.experiments.plan_checks import plan_and_check, ring_heatmaps
from s3o_drake.feasibility.check import FeasibilityChecker
from s3o_drake.feasibility.scene import FeasibilityScene
from s3o_drake.world.choices import METHODS
from s3o_drake.world.random_scenes import SceneShape, random_scene
from s3o_drake.world.scenario_checks import validate_scenario
from s3o_drake.world.settings import PlanningSettings

EXAMPLES = settings(max_examples=int(os.environ.get("S3O_PROPERTY_EXAMPLES", "3")),
                    deadline=None, database=None, derandomize=True,
                    suppress_health_check=[HealthCheck.too_slow])
SHAPE = SceneShape(max_dishes=int(os.environ.get("S3O_PROPERTY_DISHES", "8")), max_chairs=8,
                   boxed_in=0.3)
# Small searches: the properties hold for any size, and the suite's time is short.
CHEAP = PlanningSettings(feasibility="oracle", top_k=2, cma_generations=2, cma_population=4,
                location_samples=10, workers=1)
# Stages that cannot be interrupted (building the collision checker, the navigation map)
# overshoot a passed deadline by their length, up to ~0.1 s: 5 % of 2 s.
BUDGET = 2.0


def _check(scene, budget: float = BUDGET) -> dict[str, dict]:
    known = KnownWorld.perfect(scene)
    # The execution's base check, which needs no reachability map ("ik" loads none).
    checker = FeasibilityChecker(FeasibilityScene(known.contents), method="ik")
    rows = plan_and_check(known, heatmaps=ring_heatmaps(known), budget=budget,
                          base_free=checker.base_free, clock=time.process_time)
    for method, row in rows.items():
        assert not row["crash"], (method, row["crash"], row.get("traceback"))
        assert row["planned"] or row["error"].startswith("no plan: "), (method, row)
        assert not row["faults"], (method, row["faults"])
        assert not row["overrun"], (method, f"{row['seconds']:.3f} s for {budget} s")
    return rows


@EXAMPLES
@given(seed=st.integers(0, 2**31 - 1))
def test_random_scenes_plan_or_say_why(seed):
    scene = random_scene(seed, 0, SHAPE, planner=CHEAP)
    validate_scenario(scene)  # a valid scene, as a user's file would be
    rows = _check(scene)
    assert set(rows) == set(METHODS)
    if not scene.dishes:  # nothing to collect: the empty plan, by every method
        assert all(r["planned"] for r in rows.values())


@pytest.mark.skipif(not os.environ.get("S3O_PROPERTY_LARGE"),
                    reason="S3O_PROPERTY_LARGE=1: a 28-dish scene, 12 s; S3O-GROP* takes 2.0 s "
                           "of CPU of its 2 s budget, so its uninterruptible stages can "
                           "overrun it on a slower machine (docs/reliability.md)")
@pytest.mark.parametrize("seed, index", [(0, 0)])
def test_a_large_random_scene(seed, index):
    """One scene near the top of the range (28 dishes, 4 tables): the budget holds."""
    scene = random_scene(seed, index, planner=CHEAP)
    assert len(scene.dishes) >= 25
    _check(scene)


# Regressions: what the random scenes found (issue 19).

def test_petlon_keeps_a_small_budget_in_a_crowded_scene():
    """A dish whose cell has no free goal cost V-PETLON all its rejection rounds, past any
    deadline (3.5 s for a 0.5 s budget): the draws now stop at the deadline."""
    scene = random_scene(0, 0, SHAPE, planner=CHEAP)
    known = KnownWorld.perfect(scene)
    checker = FeasibilityChecker(FeasibilityScene(known.contents), method="ik")
    heatmaps = ring_heatmaps(known)
    # Warm: the free-stop checker is built once.
    plan_and_check(known, heatmaps=heatmaps, budget=1.0, base_free=checker.base_free,
                   methods=["V-PETLON"], clock=time.process_time)
    row = plan_and_check(known, heatmaps=heatmaps, budget=0.5, base_free=checker.base_free,
                         methods=["V-PETLON"], clock=time.process_time)["V-PETLON"]
    # Under twice the budget: the regression took 7 times it.
    assert row["seconds"] < 2 * 0.5, row
    assert row["planned"] or "time budget" in row["error"]


def test_a_dish_with_no_feasible_free_stop_is_left_out_not_driven_to():
    """dish_5 has Fea^m 0 at every free stop of its cell: the plans drove to a stop where
    the base collides; now it is reported unreachable and every stop is free."""
    scene = random_scene(273063, 0, SHAPE, planner=CHEAP)
    rows = _check(scene, budget=5.0)
    from s3o_drake.planning.pipeline import plan_from

    known = KnownWorld.perfect(scene)
    result = plan_from(known, method="V-GROP*", heatmaps=ring_heatmaps(known), workers=1,
                       feasibility="oracle", time_budget=5.0, clock=time.process_time)
    assert "dish_5" in result.plan.unreachable
    assert all(r["planned"] for r in rows.values())
