"""The exact solution of the visiting-order problem (the scale benchmark's reference) and
the assignment bound (the task planner's gap), against brute force and clingo."""

import itertools
import math

import numpy as np
import pytest

from s3o_drake.planning.task.exact_order import assignment_bound, exact_order
from s3o_drake.planning.task.first_order import path_cost
from s3o_drake.planning.task.planner import TaskProblem, plan_tasks
from s3o_drake.planning.task.visit_order import visit_matrix
from tests.conftest import clingo_proves


def random_costs(n: int, seed: int) -> np.ndarray:
    """Asymmetric costs: distances between random points, plus a random extra per arc."""
    rng = np.random.default_rng(seed)
    points = rng.uniform(0, 10, (n, 2))
    costs = np.linalg.norm(points[:, None] - points[None], axis=-1) * 10
    return np.round(costs + rng.uniform(0, 5, (n, n)))


@pytest.mark.parametrize(("n", "seed"), [(2, 0), (3, 1), (5, 2), (7, 3), (8, 4), (8, 5)])
def test_the_exact_order_is_the_cheapest_of_all_orders(n, seed):
    costs = random_costs(n, seed)
    best = min(path_cost(costs, list(p)) for p in itertools.permutations(range(1, n)))
    order, cost = exact_order(costs)
    assert sorted(order) == list(range(1, n))
    assert cost == pytest.approx(best) == pytest.approx(path_cost(costs, order))
    assert assignment_bound(costs) <= best


def test_missing_drives_are_kept_out_and_no_path_raises():
    costs = random_costs(5, 6)
    costs[0, 1:4] = np.inf  # from the start only node 4 is reached...
    costs[1:, 4] = np.inf  # ...and node 4 only from the start
    order, cost = exact_order(costs)
    assert order[0] == 4 and math.isfinite(cost)
    costs[:, 2] = np.inf  # nothing enters node 2
    with pytest.raises(ValueError, match="no open path"):
        exact_order(costs)


def test_clingo_proves_the_same_optimum_on_eight_locations(monkeypatch):
    """The reference and clingo agree where clingo proves its order."""
    clingo_proves(monkeypatch)
    rng = np.random.default_rng(7)
    points = rng.uniform(0, 10, (9, 2))
    locations = tuple(f"l{i}" for i in range(8))
    problem = TaskProblem(locations=locations,
                          dishes={f"d{i}": locations[i] for i in range(8)},
                          costs=np.round(np.linalg.norm(points[:, None] - points[None],
                                                        axis=-1) * 10))
    result = plan_tasks(problem, time_limit=30)
    assert result.best.optimal
    _, optimum = exact_order(visit_matrix(problem)[1])
    assert result.best.cost == optimum


def test_forty_locations_are_solved_in_seconds():
    costs = random_costs(41, 8)
    order, cost = exact_order(costs, time_limit=60)
    assert sorted(order) == list(range(1, 41))
    assert assignment_bound(costs) <= cost


def test_local_search_gives_distinct_orders_the_same_each_time_near_the_optimum():
    from s3o_drake.planning.task.first_order import good_orders

    for seed in (9, 10, 11):
        costs = random_costs(21, seed)
        orders = good_orders(costs, 3, time_limit=10)
        assert orders == good_orders(costs, 3, time_limit=10)
        assert len({tuple(o) for o in orders}) == 3
        assert all(sorted(o) == list(range(1, 21)) for o in orders)
        prices = [path_cost(costs, o) for o in orders]
        assert prices == sorted(prices)
        assert prices[0] <= 1.01 * exact_order(costs)[1]
