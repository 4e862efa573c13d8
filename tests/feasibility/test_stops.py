"""Free stops: the planner commands only base poses that are free as planned."""

import numpy as np
import pytest

from s3o_drake.belief.known_world import KnownWorld
from s3o_drake.feasibility.oracle import Heatmap
from s3o_drake.feasibility.planning_scene import PlanningScene
from s3o_drake.feasibility.stops import FreeStops
from s3o_drake.world.angles import facing_yaw

CELL = 4.0 / 64


@pytest.fixture(scope="module")
def stops(scenario) -> FreeStops:
    return PlanningScene(KnownWorld.perfect(scenario)).free_stops


def _disc_heatmap(scenario, dish: str, radius: float) -> Heatmap:
    """Fea^m 1 within `radius` of the dish, 0 beyond: every cell near it is asked."""
    p = np.asarray(next(d for d in scenario.dishes if d.name == dish).position[:2])
    h = Heatmap(dish, np.zeros((64, 64)), p[0] - 2.0, p[1] - 2.0, CELL)
    c = h.centers()
    return Heatmap(dish, (np.hypot(*(c - p).transpose(2, 0, 1)) < radius).astype(float),
                   h.x0, h.y0, CELL)


def _poses(points: np.ndarray, p_dish: np.ndarray) -> np.ndarray:
    return np.column_stack([points, facing_yaw(points, p_dish)])


def test_restrict_keeps_exactly_the_cells_whose_centre_and_corners_are_free(
        scenario, checker, stops):
    """Against the execution's own base check (the true world, which is the known one
    here): a kept cell's centre and corners are free facing the dish; a dropped cell has
    one that collides; cells next to the table are dropped, the open floor kept."""
    cup = scenario.dishes[1]
    h = _disc_heatmap(scenario, cup.name, 1.3)
    kept = stops.restrict(h)
    p_dish = np.asarray(cup.position[:2])
    rng = np.random.default_rng(0)
    offsets = np.array([[0.5, 0.5], [0, 0], [0, 1], [1, 0], [1, 1]])
    asked = np.argwhere(h.values > 0)
    was_kept = kept.values[asked[:, 0], asked[:, 1]] > 0
    assert 0 < was_kept.sum() < len(asked)  # the table takes some, the floor leaves some
    for keep in (True, False):
        rows = asked[was_kept == keep]
        for i, j in rows[rng.choice(len(rows), size=min(40, len(rows)), replace=False)]:
            points = np.column_stack([h.x0 + (j + offsets[:, 1]) * CELL,
                                      h.y0 + (i + offsets[:, 0]) * CELL])
            free = checker.base_free(_poses(points, p_dish))
            assert free.all() == keep, (i, j, free)
    # Fea^m itself is untouched where kept, and nothing is added.
    assert np.array_equal(kept.values[kept.values > 0], h.values[kept.values > 0])
    assert (kept.values <= h.values).all()


def test_any_free_cell_is_whether_restrict_keeps_a_cell(scenario, stops):
    """The generator's question (`any_free_cell`, which stops at the first free cell)
    has the answer of the full rule: on the floor around a dish, yes; within 0.2 m of
    it, under the table, or on no cell, no."""
    cup = scenario.dishes[1]
    floor = _disc_heatmap(scenario, cup.name, 1.3)
    under = _disc_heatmap(scenario, cup.name, 0.2)
    empty = Heatmap(cup.name, np.zeros((64, 64)), floor.x0, floor.y0, CELL)
    rng = np.random.default_rng(2)
    sparse = Heatmap(cup.name, floor.values * (rng.random((64, 64)) < 0.05),
                     floor.x0, floor.y0, CELL)
    for h, expected in ((floor, True), (under, False), (empty, False), (sparse, None)):
        full = stops.free_cells(h).any()
        assert stops.any_free_cell(h) == full
        assert stops.any_free_cell(h, batch=1) == full
        if expected is not None:
            assert full == expected


def test_free_tests_exact_positions_facing_the_dish(scenario, checker, stops):
    rng = np.random.default_rng(1)
    p_dish = np.asarray(scenario.dishes[0].position[:2])
    points = p_dish + rng.uniform(-1.2, 1.2, (200, 2))
    expected = checker.base_free(_poses(points, p_dish))
    assert 0 < expected.sum() < len(points)
    assert np.array_equal(stops.free(points, scenario.dishes[0].name), expected)


@pytest.mark.parametrize("method", ["V-PETLON"])
def test_planned_stops_are_free_in_a_crowded_task(method):
    """On a generated task (chairs close to the tables), with Fea^m 1 everywhere near each
    dish, so that only the free-stop rule keeps the stops off the furniture: every stop of
    every seed's plan is free as planned, by the execution's own check of the known world.
    (Before the rule, V-PETLON's uniform goals collided in about one stop in five.)"""
    from s3o_drake.feasibility.check import FeasibilityChecker
    from s3o_drake.feasibility.scene import FeasibilityScene
    from s3o_drake.planning.methods import plan_task
    from s3o_drake.planning.plan import Goto
    from s3o_drake.world.scenario import load_scenario

    scenario = load_scenario("scenarios/generated/task_003.yaml")
    known = KnownWorld.perfect(scenario)
    heatmaps = [_disc_heatmap(scenario, d.name, 1.3) for d in scenario.dishes]
    check = FeasibilityChecker(FeasibilityScene(known.contents), method="ik")
    model = {h.dish: h for h in heatmaps}
    scene = PlanningScene(known)  # one belief, planned with every seed
    poses = []
    for seed in range(3):
        plan = plan_task(known, method=method, heatmaps=heatmaps, seed=seed, workers=1,
                         scene=scene).plan
        stop = None
        for a in plan.actions:
            if isinstance(a, Goto):
                stop = a.pose
                poses.append(stop)
            else:
                # The plan rates a pickup as the model does: no stop lies in a cell that
                # the rule dropped (where the plan would read 0 for a free position).
                assert a.feasibility == model[a.dish].value_at(np.asarray(stop[:2]))
    assert len(poses) >= 3 * len(scenario.dishes) // 2
    assert check.base_free(np.array(poses)).all()
