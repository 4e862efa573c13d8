"""The pictures name locations, stops and dishes as plan.json does, and their labels keep
clear of the dish names (checked on the labels the figure functions return, not pixels)."""

import numpy as np
import pytest

from s3o_drake.belief.known_world import KnownWorld
from s3o_drake.feasibility.heatmaps import compute_heatmaps
from s3o_drake.planning.pipeline import plan_from
from s3o_drake.planning.plan import Goto, TaskMotionPlan
from s3o_drake.viz.floor import Floor
from s3o_drake.viz.pictures import (
    feasibility_figure,
    overhead_figure,
    plan_figure,
    search_figure,
    state_space_figure,
    stop_label,
)
from s3o_drake.world.camera import overhead_camera
from tests.conftest import COARSE_MAPS


@pytest.fixture(scope="module")
def heatmaps(scenario):
    """Coarse oracle heatmaps of the two dishes (32 x 32 cells: fast)."""
    known = KnownWorld.perfect(scenario)
    return compute_heatmaps(known, **COARSE_MAPS, progress=False,
                            obstacles=known.obstacles)


@pytest.fixture(scope="module", params=["S3O-GROP*", "V-GROP*"])
def result(request, scenario, heatmaps):
    return plan_from(KnownWorld.perfect(scenario), method=request.param, seed=0, workers=1,
                     heatmaps=heatmaps)


@pytest.fixture(scope="module")
def floor(scenario) -> Floor:
    """The floor the map pictures draw under their data."""
    return Floor.of(scenario, truth=True)


def _read_back(plan: TaskMotionPlan, tmp_path) -> TaskMotionPlan:
    plan.write(tmp_path / "plan.json")
    return TaskMotionPlan.read(tmp_path / "plan.json")


def test_plan_and_state_space_pictures_name_what_plan_json_names(result, scenario, floor,
                                                                  tmp_path):
    plan = _read_back(result.plan, tmp_path)
    groups = dict(zip(plan.locations, map(tuple, plan.groups), strict=True))
    space = state_space_figure(scenario, floor, result, tmp_path / "state_space.png")
    assert space.locations == groups
    drawn = plan_figure(scenario, floor, result.plan, tmp_path / "plan.png",
                        start=result.known.pose)
    # Each stop carries its location's name, in visiting order; the dishes picked from a
    # stop are its location's group.
    gotos = [a for a in plan.actions if isinstance(a, Goto)]
    assert drawn.stops == tuple(stop_label(k, g.location) for k, g in enumerate(gotos, 1))
    assert drawn.stops[0].startswith("1 · l")
    assert {name: set(dishes) for name, dishes in drawn.locations.items()} == \
        {name: set(dishes) for name, dishes in groups.items()}
    searched = search_figure(scenario, floor, list(result.heatmaps), result.plan,
                             tmp_path / "search.png")
    assert searched.stops == drawn.stops
    # The dishes stand 0.3 m apart: their names and the Fea^m numbers had to move apart.
    assert drawn.overlaps == 0 and space.overlaps == 0 and searched.overlaps == 0


def test_the_state_space_picture_says_the_rank_of_the_one_the_plan_searched(result, scenario,
                                                                            floor, tmp_path):
    title = state_space_figure(scenario, floor, result, tmp_path / "s.png").title
    if result.abstraction is None:
        assert "plain Voronoi" in title
        return
    ranks = [i for i, s in enumerate(result.abstraction.ranked)
             if {frozenset(g) for g in s.groups} == {frozenset(g) for g in result.plan.groups}]
    assert ranks and f"ranked {ranks[0] + 1} of {result.abstraction.count}" in title


def test_feasibility_shows_each_dish_in_a_panel_of_its_own(scenario, heatmaps, floor,
                                                            tmp_path):
    labels = feasibility_figure(scenario, floor, heatmaps, tmp_path / "feasibility.png")
    assert labels.panels == tuple(h.dish for h in heatmaps) == ("plate_a", "cup_b")
    assert (tmp_path / "feasibility.png").stat().st_size > 10_000


def test_overhead_picture_has_axes_in_metres(scenario, tmp_path):
    """The camera's image is drawn over the floor it sees: its outer pixels' edges are the
    extent's corners, and the room lies inside."""
    camera = overhead_camera(scenario.room, scenario.camera)
    x0, x1, y0, y1 = camera.floor_extent()
    assert camera.pixel_of([x0, y1, 0.0]) == pytest.approx([-0.5, -0.5])
    assert camera.pixel_of([x1, y0, 0.0]) == pytest.approx([camera.width - 0.5,
                                                            camera.height - 0.5])
    x_min, y_min, x_max, y_max = scenario.room.bounds
    assert x0 < x_min < x_max < x1 and y0 < y_min < y_max < y1
    color = np.full((camera.height, camera.width, 3), 120, dtype=np.uint8)
    labels = overhead_figure(scenario, camera, color, tmp_path / "overhead.png")
    assert "perspective" in labels.title and "metres at floor level" in labels.title
    assert (tmp_path / "overhead.png").stat().st_size > 5_000


def test_thirty_stops_get_thirty_colours(scenario, floor, tmp_path):
    """A plan of 30 stops (a plain Voronoi state space of 30 cups has one per cup) draws
    each in a colour of its own; tab10 repeated after 10. state_space.png takes its
    locations' colours from the same `location_colours`."""
    from s3o_drake.planning.plan import Pickup
    from s3o_drake.viz.pictures import location_colours

    dish = scenario.dishes[0]
    x_min, y_min, x_max, y_max = scenario.room.bounds
    actions, here = [], tuple(scenario.robot.start[:2])
    for k in range(30):
        p = (x_min + 0.3 + (x_max - x_min - 0.6) * (k % 6) / 5,
             y_min + 0.3 + (y_max - y_min - 0.6) * (k // 6) / 4)
        actions += [Goto(location=f"l{k}", pose=(*p, 0.0), path=(here, p), length=1.0),
                    Pickup(dish=dish.name, location=f"l{k}", feasibility=0.9)]
        here = p
    plan = TaskMotionPlan(method="V-GROP*", seed=0, groups=tuple((dish.name,) for _ in
                                                                   range(30)),
                          locations=tuple(f"l{k}" for k in range(30)), actions=tuple(actions),
                          utility=0.0, predicted_time=0.0, planning_time=0.0)
    drawn = plan_figure(scenario, floor, plan, tmp_path / "plan.png")
    assert len(drawn.stops) == 30 and len(set(drawn.colours)) == 30
    for n in (3, 10, 15, 20, 40):
        assert len(set(location_colours(n))) == n
    assert location_colours(3) == location_colours(10)[:3]  # small plans keep their look


def test_thirty_cups_close_together_keep_their_labels_clear(tmp_path):
    """30 cups 0.22 m apart along the tables' edges, each picked from a stop of its own:
    the names, stop labels and Fea^m numbers cannot all fit, so those with no clear spot
    become numbers keyed beside the plot, and no label covers another."""
    import dataclasses

    from PIL import Image

    from s3o_drake.planning.plan import Pickup
    from s3o_drake.world.scenario import load_scenario
    from tests.conftest import cups_along_edges

    room = load_scenario("scenarios/restaurant.yaml")
    cups = [(d, np.asarray(d.position) + 0.6 * out) for d, out in cups_along_edges(room, 30)]
    scenario = dataclasses.replace(room, dishes=[d for d, _ in cups], chairs=[])
    actions, here = [], tuple(scenario.robot.start[:2])
    for k, (dish, stop) in enumerate(cups):
        p = (float(stop[0]), float(stop[1]))
        actions += [Goto(location=f"l{k}", pose=(*p, 0.0), path=(here, p), length=1.0),
                    Pickup(dish=dish.name, location=f"l{k}", feasibility=0.9)]
        here = p
    plan = TaskMotionPlan(method="V-GROP*", seed=0, groups=tuple((d.name,) for d, _ in cups),
                          locations=tuple(f"l{k}" for k in range(30)), actions=tuple(actions),
                          utility=0.0, predicted_time=0.0, planning_time=0.0)
    drawn = plan_figure(scenario, Floor.of(scenario), plan, tmp_path / "plan.png")
    assert len(drawn.stops) == 30 and drawn.overlaps == 0
    with Image.open(tmp_path / "plan.png") as image:
        assert image.size[0] > 500


@pytest.mark.parametrize("name", ["restaurant", "tidy_home"])
def test_map_pictures_draw_each_table_where_it_stands(name, tmp_path, monkeypatch):
    """The floor is drawn from the world's geometry: each table's drawn outline within
    2 cm of its footprint (read back from the plotted artists), and no camera image under
    the data (which drew table tops up to 0.3 m off, with streaks)."""
    import matplotlib.pyplot as plt

    from s3o_drake.world.furniture import table_footprint
    from s3o_drake.world.scenario import load_scenario

    scenario = load_scenario(f"scenarios/{name}.yaml")
    made = []
    subplots = plt.subplots
    monkeypatch.setattr(plt, "subplots", lambda *a, **k: made.append(subplots(*a, **k))
                        or made[-1])
    x, y, _ = scenario.robot.start
    plan = TaskMotionPlan(method="V-GROP*", seed=0, groups=(), locations=("l0",),
                          actions=(Goto("l0", (x + 0.5, y, 0.0), ((x, y), (x + 0.5, y)),
                                        0.5),),
                          utility=0.0, predicted_time=1.0, planning_time=0.1, timing={})
    drawn = plan_figure(scenario, Floor.of(scenario), plan, tmp_path / "plan.png").tables
    assert set(drawn) == {t.name for t in scenario.tables}
    for table in scenario.tables:
        true = table_footprint(table.center, table.yaw, table.size).bounds
        assert np.allclose(drawn[table.name], true, atol=0.02), table.name
    ((_, ax),) = made
    assert ax.get_images() == []
