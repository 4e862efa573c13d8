"""The clingo task planner: valid plans, optimal order, N-best, errors, time limit."""

import dataclasses
import itertools
import math
import time

import numpy as np
import pytest

from s3o_drake.planning.task.check import check_plan
from s3o_drake.planning.task.planner import (
    TaskPlanningError,
    TaskProblem,
    cost_lower_bound,
    plan_problem,
    plan_tasks,
)
from tests.conftest import clingo_proves


def random_problem(m: int, seed: int = 0, dishes_per_location: float = 1.3) -> TaskProblem:
    """Locations at random points, costs = straight-line distance x 10 (rounded)."""
    rng = np.random.default_rng(seed)
    pts = rng.uniform(0, 10, (m + 1, 2))  # the last row is the start
    locs = tuple(f"l{i}" for i in range(m))
    costs = np.round(np.linalg.norm(pts[:, None] - pts[None], axis=2) * 10)
    dishes = {f"d{i:02d}": locs[i % m] for i in range(round(m * dishes_per_location))}
    return TaskProblem(locations=locs, dishes=dishes, costs=costs)


def brute_force(problem: TaskProblem) -> int:
    """The cheapest order over all permutations of the non-empty locations."""
    locs = sorted({loc for loc in problem.dishes.values() if loc is not None})
    best = None
    for order in itertools.permutations(locs):
        here, total = problem.start, 0
        for loc in order:
            total += round(problem.cost(here, loc))
            here = loc
        best = total if best is None else min(best, total)
    return best


def test_plans_are_valid_and_distinct():
    problem = random_problem(5, seed=3)
    result = plan_tasks(problem, n_plans=5)
    assert len(result.plans) == 5 and result.complete
    for plan in result.plans:
        assert check_plan(problem, plan.actions) == plan.cost
        assert plan.optimal
    orders = [plan.gotos for plan in result.plans]
    assert len(set(orders)) == 5
    costs = [plan.cost for plan in result.plans]
    assert costs == sorted(costs)


def test_cheaper_order_wins_with_two_locations():
    # start -> a is 10, start -> b is 50, a <-> b is 30: a first costs 40, b first costs 80.
    costs = {("start", "a"): 10, ("start", "b"): 50, ("a", "b"): 30, ("b", "a"): 30}
    problem = TaskProblem(locations=("a", "b"), dishes={"cup": "b", "plate": "a"}, costs=costs)
    result = plan_tasks(problem, n_plans=3)
    assert result.best.actions == (("goto", "a"), ("pickup", "plate"),
                                   ("goto", "b"), ("pickup", "cup"))
    assert result.best.cost == 40 and result.best.optimal
    # only two visiting orders exist
    assert [p.cost for p in result.plans] == [40, 80]
    assert result.complete


def test_merged_location_one_goto_many_pickups_in_name_order():
    problem = TaskProblem(locations=("l0",), dishes={"c": "l0", "a": "l0", "b": "l0"},
                          costs=lambda a, b: 7)
    result = plan_tasks(problem, n_plans=3)
    assert len(result.plans) == 1  # pickup order is canonical: no duplicates
    assert result.best.actions == (("goto", "l0"), ("pickup", "a"), ("pickup", "b"),
                                   ("pickup", "c"))
    assert result.best.cost == 7


def test_robot_starting_in_a_location_does_not_goto_it():
    costs = {("l0", "l1"): 5, ("l1", "l0"): 5}
    problem = TaskProblem(locations=("l0", "l1"), dishes={"a": "l0", "b": "l1"},
                          costs=costs, start="l0")
    plan = plan_tasks(problem).best
    assert plan.actions == (("pickup", "a"), ("goto", "l1"), ("pickup", "b"))
    assert plan.cost == 5


def test_from_state_space_groups_and_unreachable_dish_is_reported():
    groups = (("d0", "d1"), ("d2",), ("d3",))
    result = plan_problem(groups, lambda a, b: 10, unreachable=["d3"], n_plans=2)
    assert result.unreachable == ("d3",)
    for plan in result.plans:
        picked = {arg for name, arg in plan.actions if name == "pickup"}
        assert picked == {"d0", "d1", "d2"}
    with pytest.raises(TaskPlanningError, match="d3"):
        plan_problem(groups, lambda a, b: 10, unreachable=["d3"], on_unreachable="raise")


def test_infinite_cost_makes_a_location_unreachable():
    costs = {("start", "a"): 10, ("start", "b"): float("inf"), ("a", "b"): None}
    problem = TaskProblem(locations=("a", "b"), dishes={"x": "a", "y": "b"}, costs=costs)
    with pytest.raises(TaskPlanningError, match=r"'y' \(location 'b'\)"):
        plan_tasks(problem, on_unreachable="raise")
    result = plan_tasks(problem)
    assert result.unreachable == ("y",)
    assert check_plan(problem, result.best.actions, dishes=["x"]) == 10


def test_no_plan_at_all_is_a_clear_error():
    problem = TaskProblem(locations=("a",), dishes={"x": "a", "y": "a"},
                          costs=lambda a, b: 1, capacity=1)
    with pytest.raises(TaskPlanningError, match="capacity"):
        plan_tasks(problem)


def test_capacity_with_depot_makes_trips():
    costs = lambda a, b: 10  # noqa: E731
    problem = TaskProblem(locations=("a", "b"), dishes={"x": "a", "y": "a", "z": "b"},
                          costs=costs, capacity=2, depot="sink")
    plan = plan_tasks(problem).best
    assert check_plan(problem, plan.actions) == plan.cost
    assert sum(1 for name, _ in plan.actions if name == "unload") == 2


def test_time_limit_returns_quickly_on_a_large_problem(monkeypatch):
    """A limit far below what 12 locations take to prove cuts the search: valid plans, or
    a timeout that says so, after little work. Only the limit ends it: no stall rule."""
    from s3o_drake.planning.task import planner as task_planner

    monkeypatch.setattr(task_planner, "LARGE_STALL", math.inf)
    problem = random_problem(12, seed=1)
    # The work done, this process's CPU time, which the machine's other work does not
    # inflate (clingo solves in a thread of this process).
    start = time.process_time()
    try:
        result = plan_tasks(problem, n_plans=5, time_limit=0.05)
    except TaskPlanningError as error:
        assert "time limit" in str(error)
    else:
        assert result.plans
        for plan in result.plans:
            check_plan(problem, plan.actions)
        assert not result.complete
    assert time.process_time() - start < 0.5


def test_deterministic():
    problem = random_problem(6, seed=5)
    a = plan_tasks(problem, n_plans=4)
    b = plan_tasks(problem, n_plans=4)
    assert a.plans == b.plans


@pytest.mark.parametrize("seed", range(3))
def test_matches_brute_force(seed):
    problem = random_problem(6, seed=seed, dishes_per_location=1.5)
    result = plan_tasks(problem, time_limit=10)
    assert result.best.optimal
    assert result.best.cost == brute_force(problem)
    assert check_plan(problem, result.best.actions) == result.best.cost


@pytest.mark.parametrize("seed", range(4))
def test_the_lower_bound_is_below_every_order_and_tight_once_proven(seed):
    """The bound that a plan cut by the clock reports its gap against never exceeds the
    optimum (brute force); a proven plan reports its own cost as the bound."""
    problem = random_problem(6, seed=seed, dishes_per_location=1.5)
    optimum = brute_force(problem)
    assert 0 < cost_lower_bound(problem) <= optimum
    proven = plan_tasks(problem, n_plans=2, time_limit=10)
    assert proven.best.optimal and proven.lower_bound == optimum == proven.best.cost
    assert proven.asked == 2 and len(proven.plans) == 2


def test_a_cut_search_says_what_it_found_and_its_bound():
    """On 20 locations clingo proves nothing before its search stalls (the limit is far):
    the plans found (local search's, as clingo's models) say they are not optimal, and the
    bound lies below the optimum (solved exactly), and above the cheapest drive into each
    location."""
    from s3o_drake.planning.task.exact_order import exact_order
    from s3o_drake.planning.task.visit_order import visit_matrix

    problem = random_problem(20, seed=1)
    result = plan_tasks(problem, n_plans=3, time_limit=60.0)
    assert result.asked == 3 and not result.complete
    assert not any(p.optimal for p in result.plans)
    for plan in result.plans:
        assert check_plan(problem, plan.actions) == plan.cost
    _, optimum = exact_order(visit_matrix(problem)[1])
    assert cost_lower_bound(problem) < result.lower_bound <= optimum <= result.best.cost
    assert result.problem == problem


@pytest.mark.parametrize("seed", range(3))
def test_the_visit_order_encoding_gives_the_time_step_encodings_answers(seed, monkeypatch):
    """A problem that only collects is solved by order.lp; domain.lp, which every other
    problem takes, gives the same three best costs, and both plans pass the checker."""
    from s3o_drake.planning.task import planner as task_planner

    problem = random_problem(7, seed=seed, dishes_per_location=1.5)
    problem = dataclasses.replace(problem, start="l0")  # it picks l0's dishes first
    assert task_planner.visits_only(problem)
    by_order = plan_tasks(problem, n_plans=3, time_limit=20)
    monkeypatch.setattr(task_planner, "visits_only", lambda problem: False)
    by_steps = plan_tasks(problem, n_plans=3, time_limit=20)
    assert by_order.complete and by_steps.complete
    assert [p.cost for p in by_order.plans] == [p.cost for p in by_steps.plans]
    assert by_order.best.actions[0][0] == "pickup"
    for plan in (*by_order.plans, *by_steps.plans):
        assert check_plan(problem, plan.actions) == plan.cost


def test_thirty_dishes_in_eight_locations_are_ordered_and_proven_at_once(monkeypatch):
    """The visit-order encoding: 30 dishes in 8 locations, 3 orders, each proven, in well
    under a second of work (the time-step encoding proved none in 10 s)."""
    clingo_proves(monkeypatch)
    problem = random_problem(8, seed=2, dishes_per_location=30 / 8)
    assert len(problem.dishes) == 30
    start = time.process_time()  # the work, whatever else the machine runs
    result = plan_tasks(problem, n_plans=3, time_limit=5)
    assert time.process_time() - start < 1.0
    assert result.complete and [p.optimal for p in result.plans] == [True] * 3
    assert result.best.cost == brute_force(problem)


def test_check_plan_rejects_violations():
    problem = TaskProblem(locations=("a", "b"), dishes={"x": "a", "y": "b"},
                          costs=lambda a, b: 1)
    with pytest.raises(ValueError, match="pickup"):
        check_plan(problem, [("pickup", "x")])
    with pytest.raises(ValueError, match="goal"):
        check_plan(problem, [("goto", "a"), ("pickup", "x")])
    with pytest.raises(ValueError, match="already stands"):
        check_plan(problem, [("goto", "a"), ("goto", "a")])


def test_degenerate_problems():
    # no dishes: the empty plan, once
    empty = TaskProblem(locations=("a",), dishes={}, costs=lambda a, b: 1)
    result = plan_tasks(empty, n_plans=3)
    assert [p.actions for p in result.plans] == [()]
    # already standing at the only location: pickups only, no second sequence
    here = TaskProblem(locations=("a",), dishes={"y": "a", "x": "a"}, costs=lambda a, b: 1,
                       start="a")
    result = plan_tasks(here, n_plans=3)
    assert [p.actions for p in result.plans] == [(("pickup", "x"), ("pickup", "y"))]


def test_matrix_costs_follow_nodes_order():
    problem = TaskProblem(locations=("a", "b"), dishes={"x": "a", "y": "b"},
                          costs=[[0, 3, 99], [3, 0, 99], [20, 1, 0]])
    assert problem.nodes == ("a", "b", "start")
    plan = plan_tasks(problem).best
    assert plan.gotos == ("b", "a") and plan.cost == 4


def _tidy(places: dict, costs: dict | None = None) -> TaskProblem:
    """The tidy-home demonstration: two cans and the apple in l0, the plate (the apple's
    place) in l1, the last can in l2; symmetric costs from `costs` (start "start")."""
    c = costs or {("start", "l0"): 10, ("start", "l1"): 40, ("start", "l2"): 30,
                  ("l0", "l1"): 30, ("l0", "l2"): 25, ("l1", "l2"): 20}
    both = {**c, **{(b, a): v for (a, b), v in c.items()}}
    return TaskProblem(locations=("l0", "l1", "l2"),
                       dishes={"can_1": "l0", "can_2": "l0", "apple": "l0", "can_3": "l2"},
                       costs=both, places=places)


def test_the_tidy_home_plan_picks_at_one_stop_places_at_the_next():
    """The paper's demonstration: both cans then the apple at the first stop (the apple
    takes the gripper, so it comes last), the apple put down at the second, the last can
    collected at the third."""
    problem = _tidy({"apple": "l1"})
    result = plan_tasks(problem, n_plans=3, time_limit=10.0)
    best = result.best
    assert best.actions == (("goto", "l0"), ("pickup", "can_1"), ("pickup", "can_2"),
                            ("pickup", "apple"), ("goto", "l1"), ("place", "apple"),
                            ("goto", "l2"), ("pickup", "can_3"))
    assert best.optimal and best.cost == 60
    for plan in result.plans:
        assert check_plan(problem, plan.actions) == plan.cost
        held = [a for a in plan.actions if a in (("pickup", "apple"), ("place", "apple"))]
        assert held == [("pickup", "apple"), ("place", "apple")]


def test_a_held_object_is_put_down_before_anything_else_is_picked():
    """The apple's place is in l2, beyond the last can: holding the apple the robot cannot
    pick can_3, so it places the apple first, in the same stop, then picks the can."""
    problem = _tidy({"apple": "l2"})
    best = plan_tasks(problem, time_limit=10.0).best
    i_place, i_can = best.actions.index(("place", "apple")), best.actions.index(
        ("pickup", "can_3"))
    assert i_place < i_can
    assert best.gotos == ("l0", "l2") and check_plan(problem, best.actions) == 35


def test_a_place_in_the_location_of_its_object_needs_no_drive():
    problem = _tidy({"apple": "l0"})
    best = plan_tasks(problem, time_limit=10.0).best
    assert best.actions[:5] == (("goto", "l0"), ("pickup", "can_1"), ("pickup", "can_2"),
                                ("pickup", "apple"), ("place", "apple"))


def test_an_object_whose_place_has_no_location_is_reported_and_the_rest_planned():
    problem = _tidy({"apple": None})
    result = plan_tasks(problem, time_limit=10.0)
    assert result.unreachable == ("apple",)
    assert ("pickup", "apple") not in result.best.actions
    check_plan(problem, result.best.actions)


def test_check_plan_holds_the_gripper_and_the_place():
    problem = _tidy({"apple": "l1"})
    with pytest.raises(ValueError, match="while the gripper holds apple"):
        check_plan(problem, [("goto", "l0"), ("pickup", "apple"), ("pickup", "can_1")])
    with pytest.raises(ValueError, match="its place is at l1"):
        check_plan(problem, [("goto", "l0"), ("pickup", "apple"), ("place", "apple")])
    with pytest.raises(ValueError, match="gripper holds None"):
        check_plan(problem, [("goto", "l1"), ("place", "apple")])
    with pytest.raises(ValueError, match=r"\['apple'\] not collected or placed"):
        check_plan(problem, [("goto", "l0"), ("pickup", "can_1"), ("pickup", "can_2"),
                             ("goto", "l2"), ("pickup", "can_3")])


def test_an_object_held_at_the_start_is_put_down_without_a_pickup():
    """A replan while the apple is in the gripper: it stands at no location, the plan
    drives to its place and puts it down before it picks anything."""
    problem = dataclasses.replace(_tidy({"apple": "l1"}), held="apple",
                                  dishes={"can_1": "l0", "can_2": "l0", "apple": None,
                                          "can_3": "l2"})
    best = plan_tasks(problem, time_limit=10.0).best
    assert ("pickup", "apple") not in best.actions
    assert best.actions[:2] == (("goto", "l1"), ("place", "apple"))
    assert check_plan(problem, best.actions) == best.cost
    with pytest.raises(ValueError, match=r"pickup\(can_1\) while the gripper holds apple"):
        check_plan(problem, [("goto", "l0"), ("pickup", "can_1"), ("pickup", "can_2")])


def test_plan_problem_reads_the_held_object_off_its_place_target():
    """The known world of a replan holds the apple's place target but not the apple."""
    groups = [("can_1", "can_2"), ("apple__place",), ("can_3",)]
    costs = {(a, b): 10.0 for a in ("start", "l0", "l1", "l2")
             for b in ("l0", "l1", "l2") if a != b}
    best = plan_problem(groups, costs, places={"apple": "apple__place"}).best
    assert best.actions.index(("place", "apple")) == 1
    assert ("pickup", "apple") not in best.actions


def test_a_large_order_starts_from_local_search_and_is_near_the_optimum(monkeypatch):
    """30 locations: clingo proves nothing, but its first model is local search's best
    order, and it looks only for cheaper ones. The best order is within 2 % of the exact
    optimum, three distinct valid orders come back, and clingo stops once its search
    stalls, long before the limit."""
    from s3o_drake.planning.task import visit_order
    from s3o_drake.planning.task.exact_order import exact_order
    from s3o_drake.planning.task.visit_order import visit_matrix

    # Local search ends by its own count of kicks, not by the time a busy machine leaves
    # it: how near the optimum it gets is the claim (its time is the scale benchmark's).
    limit = 60.0
    monkeypatch.setattr(visit_order, "HINT_LIMIT", limit)
    problem = random_problem(30, seed=1)
    result = plan_tasks(problem, n_plans=3, time_limit=limit)
    _, optimum = exact_order(visit_matrix(problem)[1])
    assert optimum <= result.best.cost <= 1.02 * optimum
    assert len(result.plans) == 3 and len({p.gotos for p in result.plans}) == 3
    assert [p.cost for p in result.plans] == sorted(p.cost for p in result.plans)
    for plan in result.plans:
        assert check_plan(problem, plan.actions) == plan.cost
    assert result.elapsed < limit / 2 and not result.complete
