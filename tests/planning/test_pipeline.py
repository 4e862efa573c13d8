"""What the robot knows (KnownWorld) and the planning pipeline that plans from it."""

import dataclasses

import numpy as np
import pytest

from s3o_drake.abstraction.voronoi import free_space
from s3o_drake.belief.known_world import KnownWorld
from s3o_drake.feasibility.heatmaps import compute_heatmaps
from s3o_drake.planning.pipeline import heatmaps_for, plan_from
from s3o_drake.planning.plan import Goto
from s3o_drake.world.map import Chair
from s3o_drake.world.obstacles import Obstacles
from tests.conftest import COARSE_MAPS


@pytest.fixture(scope="module")
def known(scenario) -> KnownWorld:
    return KnownWorld.perfect(scenario)


@pytest.fixture(scope="module")
def heatmaps(known):
    """Coarse oracle heatmaps of the known world (32 x 32 cells: fast)."""
    return compute_heatmaps(known, **COARSE_MAPS, progress=False,
                            obstacles=known.obstacles)


def test_the_known_world_holds_the_map_and_what_was_perceived_never_the_truth(scenario):
    """The unmapped chair of the scenario is not in the KnownWorld unless perceived; mapped
    chairs are, and the obstacles are exactly those."""
    blind = KnownWorld.of(scenario, perceived_chairs=[])
    assert blind.chair_poses == () and blind.map.chairs == ()
    assert blind.pose == tuple(scenario.robot.start)
    assert [d.name for d in blind.dishes] == ["plate_a", "cup_b"]
    assert len(blind.obstacles.footprints) == len(scenario.tables)
    seen = KnownWorld.of(scenario, perceived_chairs=[[3.0, 1.0, 0.5]], pose=[1.0, 1.2, 0.3],
                         dishes=["cup_b"])
    assert seen.perceived_chairs == ((3.0, 1.0, 0.5),) and seen.pose == (1.0, 1.2, 0.3)
    assert seen.dish_names == ["cup_b"]
    # Mapped chairs are part of the map.
    mapped = dataclasses.replace(scenario, chairs=[Chair(name="c", pose=[3.0, 1.0, 0.5],
                                                         mapped=True)])
    assert KnownWorld.of(mapped, perceived_chairs=[]).chair_poses == ((3.0, 1.0, 0.5),)


def test_the_known_world_s_plant_holds_the_perceived_chairs_and_what_remains(scenario):
    known = KnownWorld.of(scenario, perceived_chairs=[[3.0, 1.0, 0.5]], pose=[1.0, 1.2, 0.3],
                          dishes=["cup_b"])
    c = known.contents
    assert [(ch.name, ch.pose, ch.mapped) for ch in c.chairs] == [("perceived_0",
                                                                    [3.0, 1.0, 0.5], False)]
    assert [d.name for d in c.dishes] == ["cup_b"] and c.start == (1.0, 1.2, 0.3)
    assert c.tables == tuple(scenario.tables) and known.planner == scenario.planner
    # The oracle's clearance test of the known world sees the same obstacles.
    assert Obstacles.of_contents(c).union.equals(known.obstacles.union)
    # Neither the true world's unmapped chair nor its settings' robot start is in it.
    truth = {tuple(ch.pose) for ch in scenario.chairs if not ch.mapped}
    assert truth and not truth & {tuple(ch.pose) for ch in c.chairs}


def test_the_obstacle_geometry_is_built_once_and_shared(known):
    assert known.obstacles is known.obstacles
    assert free_space(known) is free_space(known)  # made once per clearance
    # Perfect perception: the scenario's chair, whose footprint is the last obstacle and
    # no free base position.
    x, y, _ = known.perceived_chairs[0]
    assert np.hypot(x - 2.0, y - 3.35) < 1e-9
    chair = known.obstacles.footprints[-1]
    assert chair.contains(chair.representative_point())
    assert not free_space(known).intersects(chair)


def test_only_perceived_chairs_grow_by_the_margin_and_contacts_stay(scenario):
    """The generator's check plans on the room as it may be when perception errs: a
    perceived chair grows by the margin; a mapped chair, a table and a contact do not."""
    mapped = dataclasses.replace(scenario, chairs=[Chair(name="m", pose=[0.8, 0.8, 0.0],
                                                         mapped=True)])
    known = dataclasses.replace(
        KnownWorld.of(mapped, perceived_chairs=[[3.0, 1.0, 0.5]]), contacts=((1.5, 2.5),))
    exact, grown = known.obstacles, known.obstacles_grown(0.015)
    assert known.obstacles_grown(0.0) is exact
    assert len(grown.footprints) == len(exact.footprints)
    changed = [not a.equals(b) for a, b in zip(exact.footprints, grown.footprints, strict=True)]
    perceived = len(mapped.tables) + 1
    assert changed == [i == perceived for i in range(len(changed))]
    # Grown by the margin on every side: its area grows by about perimeter x margin.
    chair, bigger = exact.footprints[perceived], grown.footprints[perceived]
    assert bigger.area - chair.area == pytest.approx(chair.length * 0.015, rel=0.05)
    assert bigger.buffer(1e-9).contains(chair.buffer(0.015 - 1e-6, join_style="mitre"))


def test_moved_keeps_the_map_and_changes_what_changes(known):
    later = known.moved(pose=[1.5, 1.0, 0.2], dishes=["plate_a"])
    assert later.pose == (1.5, 1.0, 0.2) and later.dish_names == ["plate_a"]
    assert later.perceived_chairs == known.perceived_chairs
    assert later.map == known.map and later.settings == known.settings
    assert later.contents.start == (1.5, 1.0, 0.2)


def test_plan_from_returns_the_plan_and_what_it_was_made_on(known, heatmaps):
    result = plan_from(known, method="S3O-GROP*", seed=0, workers=1, heatmaps=heatmaps)
    assert result.error == "" and result.plan is not None
    plan = result.plan
    assert {a.dish for a in plan.pickups} == {"plate_a", "cup_b"}
    assert result.known is known
    # The heatmaps it was made on: the given ones, Fea^m kept only at free stops.
    assert [h.dish for h in result.heatmaps] == [h.dish for h in heatmaps]
    for made, given in zip(result.heatmaps, heatmaps, strict=True):
        assert (made.x0, made.y0, made.cell) == (given.x0, given.y0, given.cell)
        kept = made.values > 0
        assert (made.values <= given.values).all() and kept.any()
        assert np.array_equal(made.values[kept], given.values[kept])
    assert result.partition is not None and result.abstraction is not None
    assert result.abstraction.partition is result.partition
    # The plan starts where the robot stands, and its drives are paths on its own map.
    first = next(a for a in plan.actions if isinstance(a, Goto))
    assert first.path[0] == pytest.approx(known.pose[:2])
    assert result.navigation.path_length(first.path[0], first.path[-1]) == \
        pytest.approx(first.length, rel=1e-6)
    assert result.planning_time == plan.planning_time > 0
    # The V- methods search the plain cells: no abstraction.
    plain = plan_from(known, method="V-GROP*", seed=0, workers=1, heatmaps=heatmaps)
    assert plain.plan is not None and plain.abstraction is None
    assert sorted(plain.plan.groups) == [("cup_b",), ("plate_a",)]


def test_a_plan_that_cannot_be_made_is_a_result_that_says_why(known, heatmaps):
    result = plan_from(known, method="S3O-GROP*", seed=0, workers=1, heatmaps=heatmaps,
                       time_budget=0.0)
    assert result.plan is None and result.error.startswith("no plan:")
    assert result.heatmaps == tuple(heatmaps) and result.planning_time >= 0


def test_a_replan_from_a_later_pose_plans_what_remains(known, heatmaps):
    later = known.moved(pose=[1.2, 1.4, 0.0], dishes=["cup_b"])
    result = plan_from(later, method="V-GROP*", seed=0, workers=1,
                       heatmaps=[h for h in heatmaps if h.dish == "cup_b"])
    assert [a.dish for a in result.plan.pickups] == ["cup_b"]
    first = next(a for a in result.plan.actions if isinstance(a, Goto))
    assert first.path[0] == pytest.approx((1.2, 1.4))


def test_feasibility_sources_are_checked(known):
    with pytest.raises(ValueError, match="unknown feasibility source"):
        heatmaps_for(known, source="guess")
    with pytest.raises(ValueError, match="overhead images"):
        heatmaps_for(known, source="fcn")  # perfect perception carries no images
    with pytest.raises(ValueError, match="unknown planning method"):
        plan_from(known, method="S3O-GROP**", heatmaps=[])


def test_best_stops_are_free_and_can_be_driven_to():
    """A cup at the edge of two tables that close off the room's corner: the stops in the
    corner pick it at 0.99 but cannot be driven to; the best stop a plan can command is
    the one above the tables (0.6). A dish no such stop picks has 0."""
    from s3o_drake.feasibility.oracle import Heatmap
    from s3o_drake.planning.pipeline import best_stops
    from s3o_drake.world.scenario import parse_scenario

    scenario = parse_scenario("""
seed: 4
room: {bounds: [0.0, 0.0, 6.0, 4.0]}
tables:
  - {name: post, center: [4.0, 0.6], yaw: 0.0, size: [0.2, 1.2, 0.04], height: 0.75}
  - {name: bar, center: [5.06, 1.1], yaw: 0.0, size: [1.88, 0.2, 0.04], height: 0.75}
dishes:
  - {name: cup, table: bar, position: [5.0, 1.1], kind: cup}
  - {name: lost, table: bar, position: [5.6, 1.1], kind: cup}
robot: {start: [1.0, 3.0, 0.0]}
""")
    known = KnownWorld.perfect(scenario)
    grid = Heatmap("cup", np.zeros((80, 120)), 0.0, 0.0, 0.05)
    c = grid.centers()
    corner = (c[..., 0] > 4.6) & (c[..., 0] < 5.4) & (c[..., 1] > 0.4) & (c[..., 1] < 0.6)
    above = (c[..., 0] > 4.7) & (c[..., 0] < 5.3) & (c[..., 1] > 1.7) & (c[..., 1] < 1.9)
    cup = Heatmap("cup", np.where(corner, 0.99, np.where(above, 0.6, 0.0)), 0.0, 0.0, 0.05)
    lost = Heatmap("lost", np.where(corner, 0.99, 0.0), 0.0, 0.0, 0.05)
    assert best_stops(known, [cup, lost]) == {"cup": pytest.approx(0.6), "lost": 0.0}


def test_dishes_left_out_on_the_network_alone_are_unchecked(known, heatmaps, monkeypatch):
    """With the network's Fea^m, a dish the plan leaves out is `unchecked` unless the
    Drake check of the known world ran and found no stop for it."""
    import s3o_drake.planning.pipeline as pipeline

    lost = known.dish_names[0]
    real = pipeline._plan

    def losing(known, scene, method, maps, seed, budget, *rest):
        result = real(known, scene, method, maps, seed, 60.0, *rest)
        return dataclasses.replace(result, plan=dataclasses.replace(
            result.plan, unreachable=(lost,)))

    monkeypatch.setattr(pipeline, "_plan", losing)
    # What follows a plan is the pipeline's, whichever method made it: V-PETLON, the
    # cheapest, makes them here.
    # No budget left for the check (planning "started" long ago): unchecked.
    result = plan_from(known, method="V-PETLON", heatmaps=heatmaps, feasibility="fcn",
                       time_budget=1.0, started=0.0)
    assert result.unchecked == (lost,)
    # The check ran and found no stop: left out for good.
    empty = [dataclasses.replace(h, values=np.zeros_like(h.values)) for h in heatmaps]
    monkeypatch.setattr(pipeline, "oracle_heatmaps",
                        lambda oracle, dishes, **kwargs: [
                            next(h for h in empty if h.dish == d) for d in dishes])
    result = plan_from(known, method="V-PETLON", heatmaps=heatmaps, feasibility="fcn",
                       time_budget=60.0)
    assert result.plan.unreachable == (lost,) and result.unchecked == ()
    # The oracle's Fea^m is exact: nothing is unchecked.
    assert plan_from(known, method="V-PETLON", heatmaps=heatmaps, feasibility="oracle",
                     time_budget=60.0).unchecked == ()
