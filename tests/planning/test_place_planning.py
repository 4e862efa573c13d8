"""Planning tasks with objects to place: the known world's place targets, the six methods,
the plan's place actions and their JSON form (execution comes later: issue 20)."""

from pathlib import Path

import pytest

from s3o_drake.belief.known_world import KnownWorld
from s3o_drake.experiments.plan_checks import plan_faults, ring_heatmaps
from s3o_drake.feasibility.check import FeasibilityChecker
from s3o_drake.feasibility.planning_scene import PlanningScene
from s3o_drake.feasibility.scene import FeasibilityScene
from s3o_drake.planning.methods import plan_task
from s3o_drake.planning.plan import Goto, Pickup, Place, TaskMotionPlan
from s3o_drake.world.choices import METHODS
from s3o_drake.world.scenario import load_scenario, with_overrides
from tests.conftest import still_clock

TIDY = Path(__file__).resolve().parents[2] / "scenarios" / "tidy_home.yaml"


@pytest.fixture(scope="module")
def known() -> KnownWorld:
    return KnownWorld.perfect(load_scenario(TIDY))


@pytest.fixture(scope="module")
def few_spaces() -> tuple[KnownWorld, PlanningScene]:
    """tidy_home with each method searching K = 2 state spaces (iterations) instead of 5,
    and its Drake scene, shared by the methods: each iteration plans the put-down as the
    others do, and what is asserted holds for any plan a method returns."""
    known = KnownWorld.perfect(with_overrides(load_scenario(TIDY), ["planner.top_k=2"]))
    return known, PlanningScene(known)


@pytest.fixture(scope="module")
def base_free(known):
    """The execution's own base check of the known world: a check that asks nothing else
    needs no reachability map ("ik" loads none)."""
    return FeasibilityChecker(FeasibilityScene(known.contents), method="ik").base_free


def _plan(overrides: list[str]):
    """S3O-GROP*'s plan of tidy_home with these overrides, on a budget that never runs out."""
    known = KnownWorld.perfect(with_overrides(load_scenario(TIDY), overrides))
    return plan_task(known, method="S3O-GROP*", heatmaps=ring_heatmaps(known), seed=0,
                     time_budget=10.0, clock=still_clock).plan


@pytest.fixture(scope="module")
def stop_and_go_plan():
    """The paper's motion's plan: the demonstration's, and the smooth plan's comparison."""
    return _plan(["execution.motion=stop_and_go"])


def test_the_known_world_plans_for_objects_and_place_targets(known):
    """The plate stays: an obstacle, no target. The apple is picked, and its place target
    (an apple standing on the plate's top) is planned for like a dish."""
    assert known.dish_names == ["can_1", "can_2", "apple", "can_3", "apple__place"]
    assert [d.name for d in known.fixtures] == ["plate"]
    assert known.places == {"apple": "apple__place"}
    assert {d.name for d in known.contents.dishes} == {*known.dish_names, "plate"}
    later = known.moved(pose=(1.0, 1.0, 0.0), dishes=["can_3", "apple"])
    assert later.dish_names == ["apple", "can_3", "apple__place"]
    assert later.moved(pose=(1.0, 1.0, 0.0), dishes=["can_3"]).places == {}


@pytest.mark.parametrize("method", METHODS)
def test_every_method_picks_the_apple_then_puts_it_down_on_the_plate(few_spaces, base_free,
                                                                     method):
    known, scene = few_spaces
    plan = plan_task(known, method=method, heatmaps=ring_heatmaps(known), seed=0,
                     scene=scene, time_budget=10.0, clock=still_clock).plan
    assert plan_faults(known, plan, base_free) == []
    (place,) = plan.places
    # (V-PETLON draws its stops at random in the location's region: Fea^m may be 0 there.)
    assert place.dish == "apple" and 0.0 <= place.feasibility <= 1.0
    actions = list(plan.actions)
    picked = actions.index(next(a for a in plan.pickups if a.dish == "apple"))
    put = actions.index(place)
    # Put down at another stop than the one it was picked at, facing the plate.
    stop = next(a for a in reversed(actions[:put]) if isinstance(a, Goto))
    assert picked < actions.index(stop) < put and stop.location == place.location
    assert {a.dish for a in plan.pickups} == {"can_1", "can_2", "can_3", "apple"}
    # Nothing is picked while the apple is in the gripper.
    assert not any(isinstance(a, Pickup) for a in actions[picked + 1:put])
    assert TaskMotionPlan.from_json(plan.to_json()) == plan


def test_s3o_plans_the_demonstrations_stops(stop_and_go_plan):
    """The paper's demonstration, with the paper's motion: two cans and the apple at the
    first stop, the apple put down at the second, the last can at the third. (A smooth
    drive makes a stop cheaper, and S3O then serves the first can from a stop of its own:
    the next test.)"""
    plan = stop_and_go_plan
    kinds = [(type(a).__name__, getattr(a, "dish", "")) for a in plan.actions]
    assert kinds == [("Goto", ""), ("Pickup", "can_1"), ("Pickup", "can_2"),
                     ("Pickup", "apple"), ("Goto", ""), ("Place", "apple"), ("Goto", ""),
                     ("Pickup", "can_3")]
    assert isinstance(plan.actions[5], Place) and plan.actions[5].feasibility > 0.5
    assert all(a.feasibility > 0.5 for a in plan.pickups)


def test_with_smooth_motion_a_stop_still_holds_a_pick_and_the_apple(stop_and_go_plan):
    """With the default smooth motion a stop costs less: the first can gets a stop of its
    own, and one stop still picks a can and the apple, which is put down at a later stop;
    the plan is predicted faster than the paper's motion's."""
    plan = _plan([])
    kinds = [(type(a).__name__, getattr(a, "dish", "")) for a in plan.actions]
    assert kinds == [("Goto", ""), ("Pickup", "can_1"), ("Goto", ""), ("Pickup", "can_2"),
                     ("Pickup", "apple"), ("Goto", ""), ("Place", "apple"), ("Goto", ""),
                     ("Pickup", "can_3")]
    assert plan.predicted_time < stop_and_go_plan.predicted_time
