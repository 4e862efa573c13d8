"""The location grid: one lattice, Fea^m once, one joint-feasibility rule and its fallbacks,
shared by Fea^t, the representative points and the motion search."""

from __future__ import annotations

import numpy as np
import pytest
import shapely
from shapely.geometry import box

from s3o_drake.abstraction import (
    GRID_CELL,
    GridFallback,
    HeatmapFeasibility,
    LocationGrid,
    TaskFeasibility,
    joint_feasible,
    region_location,
    voronoi_partition,
)
from s3o_drake.belief.known_world import KnownWorld
from s3o_drake.feasibility.oracle import Heatmap
from s3o_drake.planning.methods import plan_task
from s3o_drake.world.scenario import load_scenario


def _scene():
    scenario = load_scenario("scenarios/small/two_dishes.yaml")
    known = KnownWorld.of(scenario, perceived_chairs=[c.pose for c in scenario.chairs
                                                      if not c.mapped])
    return scenario, known, voronoi_partition(known)


def _rings(scenario, inner: float = 0.45, outer: float = 0.95):
    """0.9 on a ring around each dish, 0 elsewhere."""
    out = []
    for d in scenario.dishes:
        grid = Heatmap(d.name, np.zeros((80, 80)), 0.0, 0.0, GRID_CELL)
        r = np.linalg.norm(grid.centers() - np.asarray(d.position), axis=-1)
        out.append(Heatmap(d.name, np.where((r > inner) & (r < outer), 0.9, 0.0), 0.0, 0.0,
                           GRID_CELL))
    return out


class _Counting(HeatmapFeasibility):
    """Counts Fea^m evaluations."""

    calls = 0

    def values(self, dish, points):
        _Counting.calls += 1
        return super().values(dish, points)


def test_the_rule():
    fea = np.array([[0.5, 0.0, 0.2], [0.1, 0.9, 0.0]])
    assert joint_feasible(fea).tolist() == [True, False, False]
    assert joint_feasible(fea, 0.3).tolist() == [False, False, False]
    assert joint_feasible(np.zeros((0, 3))).tolist() == [True, True, True]


def test_lattice_fea_m_once_and_cache():
    scenario, _, partition = _scene()
    _Counting.calls = 0
    grid = LocationGrid.of(partition, _Counting(_rings(scenario)))
    assert _Counting.calls == len(partition.dishes)
    # Anchored at multiples of the cell: every point is a heatmap cell's centre.
    steps = grid.points / GRID_CELL - 0.5
    assert np.allclose(steps, np.round(steps), atol=1e-6)
    merged = grid.location(["plate_a", "cup_b"])
    assert grid.location(["cup_b", "plate_a"], ["plate_a", "cup_b"]) is merged
    assert _Counting.calls == len(partition.dishes)  # the locations read the grid's Fea^m
    region = grid.region(["plate_a", "cup_b"])
    assert shapely.contains_xy(region, merged.points[:, 0], merged.points[:, 1]).all()
    assert merged.fallback is GridFallback.NONE
    assert (merged.weight[~merged.joint] == 0).all()
    assert np.allclose(merged.weight[merged.joint], merged.fea.sum(axis=0)[merged.joint])


def test_fea_m_is_0_where_the_base_cannot_drive_and_the_search_starts_where_it_can():
    """Chairs across plate_a's cell at x = 1.5 (as `drivable` has it): the points beyond
    keep their place in the grid but pick nothing, so Fea^t and the motion search's start
    and draws see only the side the base reaches."""
    from s3o_drake.planning.motion.grop import draw, initial_point

    scenario, _, partition = _scene()
    rings = _rings(scenario)
    plain = LocationGrid.of(partition, rings)
    asked = []

    def west(points):
        asked.append(len(points))
        return points[:, 0] < 1.5

    grid = LocationGrid.of(partition, rings, drivable=west)
    np.testing.assert_array_equal(grid.points, plain.points)
    beyond = grid.points[:, 0] >= 1.5
    assert (plain.fea[:, beyond] > 0).any() and (grid.fea[:, beyond] == 0).all()
    np.testing.assert_array_equal(grid.fea[:, ~beyond], plain.fea[:, ~beyond])
    assert sum(asked) == int((plain.fea > 0).any(axis=0).sum())  # only where it matters
    here, rng = np.array([2.0, 0.5]), np.random.default_rng(0)
    before, after = plain.location(["plate_a"]), grid.location(["plate_a"])
    assert initial_point(before, here, 1.0, 0.4)[0] >= 1.5
    assert (draw(before, rng, 50)[:, 0] >= 1.5).any()
    assert initial_point(after, here, 1.0, 0.4)[0] < 1.5
    assert (draw(after, rng, 50)[:, 0] < 1.5).all()


def test_no_joint_point():
    """plate_a feasible only from the west end of the table, cup_b only from the east end:
    no joint point. Fea^t is 0 for the merged location; the motion search weighs every
    point."""
    _, _, partition = _scene()
    x = Heatmap("plate_a", np.zeros((80, 80)), 0.0, 0.0, GRID_CELL).centers()[..., 0]
    sides = [Heatmap("plate_a", np.where(x < 1.5, 0.9, 0.0), 0.0, 0.0, GRID_CELL),
             Heatmap("cup_b", np.where(x > 2.5, 0.9, 0.0), 0.0, 0.0, GRID_CELL)]
    grid = LocationGrid.of(partition, sides)
    merged = grid.location(["plate_a", "cup_b"])
    assert merged.fallback is GridFallback.NOT_JOINT
    assert merged.weight.sum() > 0 and np.allclose(merged.weight, merged.fea.sum(axis=0))
    task = TaskFeasibility(grid, samples=50, seed=0)
    assert task.of_group([0, 1]).tolist() == [0.0, 0.0]


def test_a_sliver_has_its_representative_point():
    """A region thinner than a cell holds no lattice point: its representative point."""
    scenario, _, _ = _scene()
    sliver = box(1.0, 1.0, 1.02, 1.3)
    location = region_location(sliver, HeatmapFeasibility(_rings(scenario)), ["plate_a"])
    assert location.fallback is GridFallback.NO_POINT
    assert len(location.points) == 1 and sliver.contains(shapely.Point(location.points[0]))


@pytest.mark.parametrize("method", ["S3O-GROP*", "V-GROP", "V-PETLON"])
def test_planner_shares_one_grid(method, monkeypatch):
    """The S3O methods plan on the abstraction's grid, the V- searches on one of the plain
    partition; V-PETLON reads no grid, and no search rasterises a region of its own."""
    from s3o_drake.planning.motion import grop as motion_search

    def no_own_grid(*args, **kwargs):
        raise AssertionError("a region rasterised outside the plan's grid")

    monkeypatch.setattr(motion_search, "region_location", no_own_grid)
    if method == "V-PETLON":
        monkeypatch.setattr(LocationGrid, "location", no_own_grid)
    scenario, known, _ = _scene()
    result = plan_task(known, method=method, heatmaps=_rings(scenario), seed=0)
    assert result.plan is not None and result.plan.actions
    if method == "V-PETLON":
        assert result.grid is None
    elif method.startswith("S3O"):
        assert result.grid is result.abstraction.grid
    else:
        assert result.grid is not None and result.abstraction is None
