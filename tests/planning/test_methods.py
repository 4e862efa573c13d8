"""The planner by method name: valid plans, merging, JSON, budget, determinism."""

from __future__ import annotations

import math

import numpy as np
import pytest
from shapely.geometry import Point

from s3o_drake.abstraction import voronoi_partition
from s3o_drake.abstraction.shared_stop import stop_shares
from s3o_drake.belief.known_world import KnownWorld
from s3o_drake.feasibility.check import FeasibilityChecker
from s3o_drake.feasibility.heatmaps import compute_heatmaps
from s3o_drake.feasibility.planning_scene import PlanningScene
from s3o_drake.feasibility.scene import FeasibilityScene
from s3o_drake.planning.failure_price import failure_reward, priced_planner
from s3o_drake.planning.methods import PlanningTimeoutError, plan_task
from s3o_drake.planning.plan import Goto, Pickup, TaskMotionPlan
from s3o_drake.planning.task.check import check_plan
from s3o_drake.planning.task.planner import TaskProblem
from s3o_drake.planning.time_model import TimeModel
from s3o_drake.world.choices import METHODS
from s3o_drake.world.robot import load_robot
from s3o_drake.world.scenario import load_scenario
from tests.conftest import COARSE_MAPS, StepClock, clingo_proves

UR5E = load_robot("ur5e")

SCENES = ("two_dishes", "opposite_sides")


@pytest.fixture(scope="module")
def scenes():
    """Scenario, coarse heatmaps and perceived chairs per scene, computed once."""
    out = {}
    for name in SCENES:
        scenario = load_scenario(f"scenarios/small/{name}.yaml")
        heatmaps = compute_heatmaps(scenario, **COARSE_MAPS, progress=False)
        chairs = [c.pose for c in scenario.chairs if not c.mapped]
        out[name] = (scenario, heatmaps, chairs)
    return out


@pytest.fixture(scope="module")
def planning_scenes(scenes):
    """Per scene, the Drake scene of the world the planner knows: one belief planned by
    every method, as `plan_and_check` plans it."""
    return {name: PlanningScene(_known(sc, chairs)) for name, (sc, _, chairs) in scenes.items()}


@pytest.fixture(scope="module")
def known_checkers(scenes):
    """Per scene, the execution's base check on the world the planner knows."""
    return {name: FeasibilityChecker(FeasibilityScene(_known(sc, chairs).contents))
            for name, (sc, _, chairs) in scenes.items()}


def _known(scenario, perceived_chairs) -> KnownWorld:
    """What the planner knows in `scenario` with these perceived chairs."""
    return KnownWorld.of(scenario, perceived_chairs=perceived_chairs)


def plan(scenario, *, perceived_chairs, scene: PlanningScene | None = None,
         **kwargs) -> TaskMotionPlan:
    """The plan of `scenario` from its start with these perceived chairs: the planner's own
    call, `plan_task`, which raises when no plan can be made. Its Drake scene (`scene`, one
    of the same belief, or built here) is built first, as the pipeline builds it, outside
    the planning budget."""
    known = _known(scenario, perceived_chairs)
    scene = PlanningScene(known) if scene is None else scene
    return plan_task(known, scene=scene, **kwargs).plan


@pytest.fixture(scope="module")
def plans(scenes, planning_scenes):
    """Every method's plan of every scene (seed 0)."""
    return {(scene, method): plan(scenes[scene][0], method=method, heatmaps=scenes[scene][1],
                                  perceived_chairs=scenes[scene][2], seed=0,
                                  scene=planning_scenes[scene])
            for scene in SCENES for method in METHODS}


def _problem(p: TaskMotionPlan) -> TaskProblem:
    dishes = {d: name for name, group in zip(p.locations, p.groups, strict=True) for d in group}
    for d in p.unreachable:
        dishes[d] = None
    return TaskProblem(locations=p.locations, dishes=dishes, costs=lambda a, b: 0.0)


@pytest.mark.parametrize("scene", SCENES)
@pytest.mark.parametrize("method", METHODS)
def test_valid_plan_for_every_method(scenes, plans, known_checkers, scene, method):
    scenario, _, chairs = scenes[scene]
    p = plans[scene, method]
    assert p.method == method and p.unreachable == ()
    check_plan(_problem(p), p.task_actions)  # raises at a violated precondition
    assert {a.dish for a in p.pickups} == {d.name for d in scenario.dishes}
    assert math.isfinite(p.utility) and math.isfinite(p.predicted_time)
    # Poses: inside their location's region, facing the dish picked next; paths end there.
    partition = voronoi_partition(_known(scenario, chairs))
    cells = dict(zip(partition.dishes, partition.cells, strict=True))
    dish_xy = {d.name: np.asarray(d.position) for d in scenario.dishes}
    here = np.asarray(scenario.robot.start[:2], float)
    for i, a in enumerate(p.actions):
        if isinstance(a, Goto):
            x, y, yaw = a.pose
            group = p.groups[p.locations.index(a.location)]
            assert any(cells[d].buffer(1e-6).covers(Point(x, y)) for d in group)
            nxt = next(b for b in p.actions[i + 1:] if isinstance(b, Pickup))
            d = dish_xy[nxt.dish] - (x, y)
            assert yaw == pytest.approx(math.atan2(d[1], d[0]))
            assert np.allclose(a.path[0], here) and np.allclose(a.path[-1], (x, y))
            # Free as planned: the base at the stop, facing the dish, collides with nothing
            # the planner knows (feasibility/stops.py).
            assert known_checkers[scene].base_free(np.array([a.pose]))[0]
            here = np.array([x, y])
    # Utility as GROP* defines it, under the robot cost profile (the default): the
    # costs are the predicted execution time (without its once-per-plan start and end),
    # the gains λ Fea^m (the paper profile: tests/planning/test_time_model.py), λ as the
    # execution's mode prices a failure (planning/failure_price.py), at the share of a
    # shared stop's size (abstraction/shared_stop.py).
    assert scenario.planner.cost_profile == "robot"
    offset = TimeModel.load(UR5E.files.time_model).overheads.plan
    lam = failure_reward(scenario.settings, robot=UR5E)
    # At a shared stop: s_k Fea^m.
    shares = stop_shares(priced_planner(scenario.settings, robot=UR5E), robot=UR5E)
    stops = [[]]
    for a in p.actions:
        if isinstance(a, Goto):
            stops.append([])
        elif isinstance(a, Pickup):
            stops[-1].append(a.feasibility)
    gains = sum(lam * shares.of(len(stop)) * f for stop in stops for f in stop)
    utility = -(p.predicted_time - offset) + gains
    assert p.utility == pytest.approx(utility, abs=1e-6)
    assert set(p.timing) >= {"feasibility", "abstraction", "task_planning", "motion_search"}


def test_s3o_merges_close_dishes(plans):
    """Two plates 30 cm apart: S3O picks both from one stop, V needs one per dish."""
    p = plans["two_dishes", "S3O-GROP*"]
    assert len(p.gotos) == 1 and len(p.pickups) == 2
    for method in ("V-GROP*", "V-GROP", "V-PETLON"):
        v = plans["two_dishes", method]
        assert len(v.gotos) == 2 and all(len(g) == 1 for g in v.groups)
    assert p.utility > plans["two_dishes", "V-GROP*"].utility


@pytest.mark.parametrize("method", METHODS)
def test_opposite_sides_need_two_stops(plans, method):
    if method == "S3O-Random-Paper":
        pytest.skip("one uniform draw may merge the two sides: see the next test")
    assert len(plans["opposite_sides", method].gotos) == 2


def test_the_papers_random_ablation_plans_on_one_drawn_state_space(scenes, planning_scenes,
                                                                   plans):
    """S3O-Random-Paper draws one state space uniformly among all candidates and searches
    it alone: every plan keeps the groups of a candidate, and on opposite_sides (two bowls
    across a table, whose cells border) the draws of five seeds are both of its candidates,
    the merged one that one stop cannot serve and the two locations S3O-GROP* chooses."""
    scenario, heatmaps, chairs = scenes["opposite_sides"]
    drawn = {plans["opposite_sides", "S3O-Random-Paper"].groups}  # seed 0
    drawn |= {plan(scenario, method="S3O-Random-Paper", heatmaps=heatmaps,
                   perceived_chairs=chairs, seed=seed,
                   scene=planning_scenes["opposite_sides"]).groups for seed in range(1, 5)}
    assert drawn == {(("bowl_north", "bowl_south"),), (("bowl_north",), ("bowl_south",))}
    best = plans["opposite_sides", "S3O-GROP*"]  # seed 0
    assert best.groups == (("bowl_north",), ("bowl_south",))


@pytest.mark.parametrize("method", METHODS)
def test_the_plan_says_what_clingo_proved_of_its_order(plans, method):
    """Small scenes: every method's order is proven (in its rank), its bound is no more
    than its cost, and as many orders were found as asked for (or every one there is);
    the line the run command prints says so."""
    from s3o_drake.commands.run_scenario import describe_plan

    for scene in SCENES:
        order = plans[scene, method].order
        assert order is not None and order.optimal
        assert 0 <= order.lower_bound <= order.cost and 0 <= order.gap < 1
        assert 1 <= order.found <= order.asked
        assert order.describe() in describe_plan(plans[scene, method])
        if order.gap == 0:
            assert order.describe().startswith("task order proven optimal")


@pytest.mark.parametrize("method", ["S3O-GROP*", "V-PETLON"])
def test_json_round_trip(plans, tmp_path, method):
    p = plans["two_dishes", method]
    assert TaskMotionPlan.from_json(p.to_json()) == p
    p.write(tmp_path / "plan.json")
    assert TaskMotionPlan.read(tmp_path / "plan.json") == p


@pytest.mark.parametrize("method", ["S3O-GROP*", "V-PETLON", "S3O-Random"])
def test_deterministic_for_a_seed(scenes, plans, method):
    scenario, heatmaps, chairs = scenes["opposite_sides"]
    again = plan(scenario, method=method, heatmaps=heatmaps, perceived_chairs=chairs, seed=0)
    first = plans["opposite_sides", method]
    assert again.actions == first.actions and again.utility == first.utility


STAGES = ("the free stops", "the navigation map", "the abstraction", "task planning",
          "the motion search")
"""plan_task's stages, in their order, as its timeout error names them."""


def _watch_stages(monkeypatch, method: str, clock: StepClock, passing: str) -> list[str]:
    """The stages of `method`'s plan_task, recorded as they start their work (the free
    stops once per dish); the deadline passes on `clock` (an hour at once) as the stage
    `passing` starts."""
    import dataclasses

    import s3o_drake.planning.methods as methods
    from s3o_drake.feasibility.stops import FreeStops

    ran: list[str] = []

    def watched(stage: str, work):
        def run(*args, **kwargs):
            ran.append(stage)
            if stage == passing:
                clock.advance(3600.0)
            return work(*args, **kwargs)
        return run

    monkeypatch.setattr(FreeStops, "restrict", watched(STAGES[0], FreeStops.restrict))
    monkeypatch.setattr(methods, "NavigationMap", watched(STAGES[1], methods.NavigationMap))
    for name in ("build_abstraction", "voronoi_partition"):  # S3O's, the V- methods'
        monkeypatch.setattr(methods, name, watched(STAGES[2], getattr(methods, name)))
    monkeypatch.setattr(methods, "plan_problem", watched(STAGES[3], methods.plan_problem))
    spec = methods.REGISTRY[method]
    monkeypatch.setitem(methods.REGISTRY, method,
                        dataclasses.replace(spec, search=watched(STAGES[4], spec.search)))
    return ran


@pytest.mark.parametrize("passing", STAGES)
@pytest.mark.parametrize("method", ["S3O-GROP*", "V-GROP"])
def test_a_budget_that_runs_out_stops_at_the_next_check_and_says_why(scenes, monkeypatch,
                                                                      method, passing):
    """The deadline passes while one stage works (on a clock of the test's, so whatever
    the machine's speed): planning goes no further than its next check. Before any plan
    exists the error names that stage; once clingo has sequences, the first search's first
    generation is the plan, marked incomplete, and no other search starts."""
    scenario, heatmaps, chairs = scenes["two_dishes"]
    clock = StepClock()
    ran = _watch_stages(monkeypatch, method, clock, passing)
    k = STAGES.index(passing)
    if passing in ("task planning", "the motion search"):
        p = plan(scenario, method=method, heatmaps=heatmaps, perceived_chairs=chairs, seed=0,
                 time_budget=1.0, clock=clock)
        assert not p.complete and p.pickups and math.isfinite(p.utility)
        assert p.searches == 1 and p.samples == scenario.planner.cma_population
        assert ran.count("task planning") == ran.count("the motion search") == 1
    else:
        with pytest.raises(PlanningTimeoutError,
                           match=f"time budget of 1 s expired during {passing}, before"):
            plan(scenario, method=method, heatmaps=heatmaps, perceived_chairs=chairs, seed=0,
                 time_budget=1.0, clock=clock)
        assert list(dict.fromkeys(ran)) == list(STAGES[:k + 1])  # no later stage started
    # The free stops' work stops at its next check: before the second dish.
    assert ran.count("the free stops") == (1 if k == 0 else len(scenario.dishes))


def _count_generations(monkeypatch, clock: StepClock) -> None:
    """Each generation of a motion search (GROP*'s and GROP's, generation 0 included)
    moves `clock` one second on: a budget counted in the searches' work, the same on any
    machine, in this process and in the search workers it forks."""
    from s3o_drake.planning.motion import grop

    add = grop._Tally.add

    def add_and_tick(self, X, u):
        add(self, X, u)
        clock.advance(1.0)

    monkeypatch.setattr(grop._Tally, "add", add_and_tick)


def test_budget_cuts_the_search_short(scenes, monkeypatch):
    """A budget that expires after the first searches returns their best, marked
    incomplete, within the budget: on a clock that counts the searches' generations, 30
    generations, where one search takes 20 and a full plan 15 searches."""
    scenario, heatmaps, chairs = scenes["opposite_sides"]
    clock = StepClock()
    _count_generations(monkeypatch, clock)
    budget = 30.0
    p = plan(scenario, method="V-GROP*", heatmaps=heatmaps, perceived_chairs=chairs, seed=0,
             time_budget=budget, clock=clock)
    assert not p.complete and len(p.gotos) == 2
    assert 2 <= p.searches < scenario.planner.top_k * 3
    # No generation ran past the deadline: GROP* stops before one that would end past it.
    assert clock() <= budget
    assert p.samples == clock() * scenario.planner.cma_population


def test_clingo_cut_by_its_budget_share_is_a_budget_timeout(scenes, monkeypatch):
    """clingo cut by its share of the budget before any order is the budget's timeout,
    named as such, not clingo's own time limit."""
    import s3o_drake.planning.methods as planner

    scenario, heatmaps, chairs = scenes["two_dishes"]
    monkeypatch.setattr(planner, "TASK_SHARE", 1e-9)
    with pytest.raises(PlanningTimeoutError, match="time budget of 30 s expired during task"):
        plan(scenario, method="S3O-GROP*", heatmaps=heatmaps, perceived_chairs=chairs, seed=0,
             time_budget=30.0)


def test_unknown_method_is_named(scenes):
    scenario, heatmaps, chairs = scenes["two_dishes"]
    with pytest.raises(ValueError, match="S3O-GROP\\*\\*"):
        plan(scenario, method="S3O-GROP**", heatmaps=heatmaps, perceived_chairs=chairs, seed=0)


def _ring_heatmaps(scenario, inner: float = 0.45, outer: float = 0.95):
    """Synthetic Fea^m: 0.9 on a ring around each dish, 0 elsewhere (cheap, for the budget)."""
    from s3o_drake.feasibility.oracle import Heatmap

    out = []
    for d in scenario.dishes:
        grid = Heatmap(d.name, np.zeros((64, 64)), d.position[0] - 2.0, d.position[1] - 2.0,
                       4.0 / 64)
        r = np.linalg.norm(grid.centers() - np.asarray(d.position), axis=-1)
        out.append(Heatmap(d.name, np.where((r > inner) & (r < outer), 0.9, 0.0), grid.x0,
                           grid.y0, grid.cell))
    return out


def _thirty_dishes():
    """The restaurant with 30 cups along its tables' long edges."""
    import dataclasses

    from s3o_drake.world.scenario import dump_scenario, parse_scenario
    from tests.conftest import cups_along_edges

    scenario = load_scenario("scenarios/restaurant.yaml")
    cups = [d for d, _ in cups_along_edges(scenario, 30)]
    # Through the YAML, so that the scenario checks (overlaps, on the table) run.
    return parse_scenario(dump_scenario(dataclasses.replace(scenario, dishes=cups)))


@pytest.fixture(scope="module")
def thirty_dishes():
    """What the planner knows of the 30-dish task, its Drake scene and a ring Fea^m: the
    same belief for both budget tests, whose subject is the search, not the scene."""
    scenario = _thirty_dishes()
    known = _known(scenario, [c.pose for c in scenario.chairs if not c.mapped])
    return known, PlanningScene(known), _ring_heatmaps(scenario)


@pytest.mark.parametrize("workers", [1, 2])
def test_budget_holds_on_a_30_dish_task(monkeypatch, thirty_dishes, workers):
    """On 30 dishes, in one process or with search workers, a budget that expires in the
    middle of the searches holds: it is counted in the searches' generations (the same on
    any machine; the workers read the same clock), 110 of the full plan's 360."""
    import s3o_drake.planning.methods as methods

    known, scene, heatmaps = thirty_dishes
    budget = 110.0
    # clingo's own limits are wall time, and what this budget holds is the searches' work:
    # its cap per state space (2 s once ordered none of the 30 plain Voronoi locations on
    # a busy machine) and its wait for a proof (`clingo_proves`). Idle each call ends well
    # before either.
    monkeypatch.setattr(methods, "TASK_TIME_LIMIT", 60.0)
    clingo_proves(monkeypatch)
    clock = StepClock()
    _count_generations(monkeypatch, clock)
    p = plan_task(known, scene=scene, method="S3O-GROP*", heatmaps=heatmaps, seed=0,
                  time_budget=budget, workers=workers, clock=clock).plan
    # No generation ran past the deadline, nor did a search handed to a worker start.
    assert not p.complete and clock() <= budget
    # Cups whose Voronoi cell holds no free space (walled in by their neighbours) are
    # reported unreachable by the abstraction; the others are all planned.
    assert len(p.pickups) + len(p.unreachable) == 30 and len(p.pickups) >= 10
    check_plan(_problem(p), p.task_actions)
    # 30 dishes in 9-10 locations: the visit-order encoding proves the order.
    assert p.order.optimal and p.order.found == p.order.asked == 3


def test_workers_give_the_same_plan(scenes, planning_scenes, plans):
    scenario, heatmaps, chairs = scenes["opposite_sides"]
    one = plans["opposite_sides", "S3O-GROP*"]  # seed 0, one process
    two = plan(scenario, method="S3O-GROP*", heatmaps=heatmaps, perceived_chairs=chairs, seed=0,
               workers=2, scene=planning_scenes["opposite_sides"])
    assert one.actions == two.actions and one.utility == two.utility
    assert one.searches == two.searches


def test_an_unreachable_dish_is_reported_and_the_rest_planned():
    """A cup in the far corner of a table pushed into the room's corner cannot be picked;
    the plate at the open edge still is."""
    from s3o_drake.world.scenario import parse_scenario

    scenario = parse_scenario("""
seed: 3
room: {bounds: [0.0, 0.0, 4.0, 4.0]}
tables:
  - {name: corner, center: [0.75, 3.25], yaw: 0.0, size: [1.4, 1.4, 0.04], height: 0.75}
dishes:
  - {name: far_cup, table: corner, position: [0.2, 3.8], kind: cup}
  - {name: near_plate, table: corner, position: [1.3, 2.75], kind: plate}
robot: {start: [3.0, 1.0, 0.0]}
""")
    heatmaps = compute_heatmaps(scenario, **COARSE_MAPS, progress=False)
    assert heatmaps[0].values.max() == 0.0  # the oracle agrees: nowhere to pick it from
    for method in ("S3O-GROP*", "V-PETLON"):
        p = plan(scenario, method=method, heatmaps=heatmaps, perceived_chairs=[], seed=0)
        assert p.unreachable == ("far_cup",)
        assert [a.dish for a in p.pickups] == ["near_plate"]
        check_plan(_problem(p), p.task_actions)


@pytest.mark.parametrize("method", METHODS)
def test_a_task_without_dishes_has_the_empty_plan(method):
    scenario = load_scenario("scenarios/small/empty_room.yaml")
    assert not scenario.dishes
    p = plan(scenario, method=method, heatmaps=[], perceived_chairs=[], seed=0)
    assert p.actions == () and p.utility == 0.0 and p.complete


def test_a_location_whose_best_spots_are_boxed_in_is_driven_to_elsewhere():
    """task_004: the best stops by Fea^m for a dish lay in a corner that two chairs close
    off, and the dish was left out as unreachable though spots of its location outside the
    corner could pick it (0.99). The representative point is the best spot that can be
    driven to; a location with no such spot has none."""
    from shapely.geometry import box

    from s3o_drake.planning.navigation.map import NavigationMap
    from s3o_drake.planning.task.costs import REPRESENTATIVE_CANDIDATES, representative_points
    from s3o_drake.world.obstacles import Obstacles

    # A pocket 1.5 m x 1 m in the room's lower-right corner, closed by two walls of boxes.
    obstacles = Obstacles(room=box(0.0, 0.0, 6.0, 4.0),
                          footprints=(box(4.0, 0.0, 4.2, 1.2), box(4.0, 1.0, 6.0, 1.2)))
    nav = NavigationMap(obstacles, robot=UR5E)
    xs, ys = np.meshgrid(np.linspace(4.5, 5.7, 8), np.linspace(0.3, 0.8, 4))
    pocket = np.column_stack([xs.ravel(), ys.ravel()])
    outside = np.array([[3.0, 2.0], [3.5, 2.5], [2.0, 3.0]])
    start = np.array([1.0, 1.0])
    assert not np.isfinite(nav.path_lengths(np.broadcast_to(start, pocket.shape), pocket)).any()
    assert len(pocket) > REPRESENTATIVE_CANDIDATES  # more than the candidates asked first

    class Location:  # what representative_points reads of a location grid's location
        def __init__(self, points, weight):
            self.points, self.weight = points, weight

    class Grid:
        def __init__(self, location):
            self._location = location

        def location(self, group):
            return self._location

    points = np.vstack([pocket, outside])
    weight = np.concatenate([np.full(len(pocket), 0.99), [0.8, 0.9, 0.0]])
    region = {"l0": box(0.0, 0.0, 6.0, 4.0)}
    best = representative_points(region, [["bowl"]], ["l0"], Grid(Location(points, weight)),
                                 nav, start)["l0"]
    np.testing.assert_allclose(best, [3.5, 2.5])  # the best spot outside the pocket
    only_pocket = Grid(Location(np.vstack([pocket, outside[2:]]),
                                np.append(np.full(len(pocket), 0.99), 0.0)))
    assert representative_points(region, [["bowl"]], ["l0"], only_pocket, nav, start)["l0"] \
        is None  # a reachable spot with Fea^m 0 does not make the dish pickable


def test_the_unmerged_space_is_searched_too_when_asked(scenes):
    """With K = 1 two plates 30 cm apart leave only their merge to search; with
    `search_plain_voronoi` the unmerged space is searched after it, so S3O never searches
    less than the Voronoi methods."""
    import dataclasses

    scenario, heatmaps, chairs = scenes["two_dishes"]
    searched = {}
    for flag in (False, True):
        s = dataclasses.replace(scenario, planner=dataclasses.replace(
            scenario.planner, top_k=1, search_plain_voronoi=flag))
        result = plan_task(_known(s, chairs), method="S3O-GROP*", heatmaps=heatmaps, seed=0)
        searched[flag] = {groups for groups, _ in result.task_plans}
    merged, plain = (("plate_a", "cup_b"),), (("plate_a",), ("cup_b",))
    assert searched[False] == {merged}
    assert searched[True] == {merged, plain}


def test_one_location_price_ranks_with_the_search_s_gamma(scenes):
    """The ranking's price of a location is the paper's γ / λ (20 / 150), or with
    `location_price: search` the robot profile's own γ / λ, the one its search pays."""
    import dataclasses

    scenario, heatmaps, chairs = scenes["two_dishes"]
    values = {}
    for price in ("paper", "search"):
        s = dataclasses.replace(scenario, planner=dataclasses.replace(
            scenario.planner, location_price=price, failure_price="paper",
            shared_stop="paper"))
        result = plan_task(_known(s, chairs), method="S3O-GROP*", heatmaps=heatmaps, seed=0)
        values[price] = {sp.groups: sp.score - sp.value for sp in result.abstraction.ranked}
    gamma = TimeModel.load(UR5E.files.time_model).overheads.gamma
    for groups, cost in values["paper"].items():
        assert cost == pytest.approx(len(groups) * 20.0 / 150.0)
        assert values["search"][groups] == pytest.approx(len(groups) * gamma / 150.0)


def test_the_registry_holds_every_method_the_settings_name():
    """The settings' choices (light, for --help) and the planner's registry agree."""
    from s3o_drake.planning.methods import REGISTRY, method_of
    from s3o_drake.world.choices import METHODS

    assert tuple(REGISTRY) == METHODS
    assert method_of("V-PETLON").spaces is None and method_of("S3O-GROP*").abstraction
    with pytest.raises(ValueError, match="unknown planning method 'S3O'"):
        method_of("S3O")


@pytest.mark.parametrize("method", ["S3O-GROP*", "V-GROP*"])
def test_when_no_stop_picks_any_dish_the_plan_is_to_stay(scenes, method):
    """Every dish out of reach (a plate at the middle of a large table, say): a plan with
    no actions, no predicted time, no search, and the dishes named unreachable, said so.
    (V-PETLON reads no Fea^m: it goes and tries.)"""
    from s3o_drake.commands.run_scenario import describe_plan, execution_time_line
    from s3o_drake.feasibility.oracle import Heatmap

    scenario, heatmaps, chairs = scenes["two_dishes"]
    nowhere = [Heatmap(h.dish, np.zeros_like(h.values), h.x0, h.y0, h.cell) for h in heatmaps]
    p = plan(scenario, perceived_chairs=chairs, method=method, heatmaps=nowhere, seed=0)
    assert p.actions == () and p.predicted_time == 0.0 and p.utility == 0.0
    assert (p.searches, p.samples, p.order) == (0, 0, None)
    assert set(p.unreachable) == {"plate_a", "cup_b"}
    text = describe_plan(p)
    assert "0 stops, 0 pickups, unreachable: cup_b, plate_a" in text
    assert "nothing to do" in text and "searches" not in text and "optimal" not in text
    assert execution_time_line(p.predicted_time, 0.0, actions=0) == \
        "Execution time: nothing to execute (the plan has no actions)."


def test_the_execution_time_line_says_which_way_the_prediction_was_off():
    from s3o_drake.commands.run_scenario import execution_time_line

    assert execution_time_line(136.0, 143.8).startswith(
        "Execution time: predicted 136.0 s, simulated 143.8 s: the simulation took 7.8 s "
        "(5.7 % of the prediction) longer than predicted")
    assert "took 6.0 s (5.0 % of the prediction) less than predicted" in \
        execution_time_line(120.0, 114.0)
    # With the noise on, against the time the plan expected with it, and said so.
    line = execution_time_line(120.0, 130.0, expected=128.0)
    assert line.startswith("Execution time: predicted 128.0 s, simulated 130.0 s: the "
                           "simulation took 2.0 s") and "what the noise adds" in line
    # A run's recoveries are no part of any prediction: their time is said beside the gap.
    line = execution_time_line(93.8, 124.6, expected=93.8, recoveries=[12.0, 9.1, 11.3])
    assert "took 30.8 s (32.8 % of the prediction) longer" in line
    assert line.endswith("; 3 recoveries, which it leaves out, took 32.4 s).")
    assert "recover" not in execution_time_line(93.8, 124.6, expected=93.8)
