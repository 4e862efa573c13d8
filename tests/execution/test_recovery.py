"""Execution that recovers (execution.recovery): the stop check alone, the ExecutiveSystem's
corrections, retries and replans driven by hand, and each inside a short simulation."""

from __future__ import annotations

import dataclasses
import time

import numpy as np
import pytest
from shapely.geometry import LineString, Point

from s3o_drake.belief import scenario_unmapped_chairs
from s3o_drake.belief.known_world import KnownWorld
from s3o_drake.execution.controllers import make_executive_system
from s3o_drake.execution.execute import execute
from s3o_drake.execution.messages import Status
from s3o_drake.execution.recovery import StopCheck, localise, localiser
from s3o_drake.feasibility.heatmaps import make_oracle
from s3o_drake.planning.navigation.map import DRIVE_MARGIN, TIGHT_DRIVE_MARGIN
from s3o_drake.planning.pipeline import PlanningResult
from s3o_drake.planning.plan import Goto, Pickup
from s3o_drake.world.angles import facing_yaw
from s3o_drake.world.obstacles import CONTACT_RADIUS
from s3o_drake.world.robot import load_robot
from s3o_drake.world.scenario import load_scenario
from s3o_drake.world.settings import Uncertainty
from tests.conftest import ORACLE_MAPS_ONCE
from tests.execution.test_executive_system import _context, _step, _with_oracle

UR5E = load_robot("ur5e")

SCENE = "scenarios/small/opposite_sides.yaml"


def _executive(scenario, **kwargs):
    """The ExecutiveSystem, planning with the oracle's Fea^m of each scene computed once
    (tests/conftest.py: OracleMapsOnce)."""
    return make_executive_system(scenario, plan_from=ORACLE_MAPS_ONCE, **kwargs)


@pytest.fixture(scope="module")
def scenario():
    return _with_oracle(load_scenario(SCENE), recovery="replan")


@pytest.fixture(scope="module")
def check(scenario):
    known = KnownWorld.perfect(scenario)
    return StopCheck(known, tuple(ORACLE_MAPS_ONCE.heatmaps(known)))


def test_localisation_is_seeded_per_landing_and_exact_without_noise():
    pose = np.array([1.0, 2.0, 0.5])
    noise = Uncertainty(localization_xy_std=0.02, localization_yaw_std=0.02)
    a = localise(pose, uncertainty=noise, seed=3, command_id=7)
    assert np.array_equal(a, localise(pose, uncertainty=noise, seed=3, command_id=7))
    assert not np.array_equal(a, localise(pose, uncertainty=noise, seed=3, command_id=8))
    assert 0 < np.linalg.norm(a[:2] - pose[:2]) < 0.1
    assert np.array_equal(localise(pose, uncertainty=noise, seed=3, command_id=7, noise=False),
                          pose)
    many = np.array([localise(pose, uncertainty=noise, seed=3, command_id=i)
                     for i in range(400)])
    assert np.std(many[:, 0]) == pytest.approx(0.02, rel=0.2)


def test_a_robot_that_reports_its_localised_pose_is_believed_as_it_reports():
    pose = np.array([1.0, 2.0, 0.5, 0.7])
    at_stops = Uncertainty(localization_xy_std=0.02, localization_yaw_std=0.02)
    believe = localiser(uncertainty=at_stops, seed=3)
    assert np.array_equal(believe(pose, 7), localise(pose, uncertainty=at_stops, seed=3,
                                                     command_id=7))
    reported = dataclasses.replace(at_stops, localization="reported")
    assert np.array_equal(localiser(uncertainty=reported, seed=3)(pose, 7), pose[:3])


def test_a_stop_out_of_reach_is_corrected_to_a_feasible_one_nearby(scenario, check):
    dish = np.array([2.5, 1.65])  # bowl_south, 0.15 m inside the table's south edge
    out_of_reach = np.array([2.5, 0.5])  # 1.15 m from the dish: beyond the arm
    verdict = check.assess(out_of_reach, "bowl_south")
    assert not verdict.feasible and not verdict.acceptable(0.5)
    target, feasibility = check.correction(out_of_reach, "bowl_south", radius=0.3)
    assert np.linalg.norm(target - out_of_reach) <= 0.3 + 1e-9
    assert feasibility == check.feasibility(target, "bowl_south") > 0.5
    # The true world agrees: the arm can pick the dish from the corrected stop.
    pose = np.array([*target, facing_yaw(target, dish)])
    assert make_oracle(scenario).success(pose[None], "bowl_south")[0]
    # Nothing within reach of the correction: no correction.
    assert check.correction(np.array([0.5, 0.5]), "bowl_south", radius=0.3) is None


def test_a_dish_out_of_reach_across_the_table_is_reached_by_a_detour(scenario):
    """A stop on the far side of the table (a merged stop that suits the other dish) has no
    acceptable stop for bowl_south within the correction radius; the detour drives round
    the table, along the navigation map, to a stop the true world's arm picks it from."""
    from s3o_drake.planning.navigation.map import NavigationMap

    known = KnownWorld.perfect(scenario)
    nav = NavigationMap(known.obstacles, robot=known.robot)
    check = StopCheck(known, tuple(ORACLE_MAPS_ONCE.heatmaps(known)), nav)
    north = np.array([2.5, 3.0, -np.pi / 2])  # 0.65 m north of bowl_north, 1.35 m of south
    near = check.correction(north, "bowl_south", radius=0.3)
    assert near is None or near[1] < 0.5
    asked: list[tuple[float, float]] = []
    test = check._success

    def counted(positions, dish):
        asked.extend(map(tuple, np.asarray(positions).reshape(-1, 2).round(9)))
        return test(positions, dish)

    check._success = counted
    target, feasibility = check.correction(north, "bowl_south", radius=0.3, threshold=0.5,
                                           detour=True)
    assert asked and len(set(asked)) == len(asked)  # no cell's pickup test asked twice
    assert feasibility >= 0.5 and feasibility == check.feasibility(target, "bowl_south")
    assert target[1] < 1.65  # south of the dish: round the table
    assert np.isfinite(nav.path_length(north[:2], target))
    pose = np.array([*target, facing_yaw(target, np.array([2.5, 1.65]))])
    assert make_oracle(scenario).success(pose[None], "bowl_south")[0]
    # An acceptable stop within the radius needs no detour.
    south = np.array([2.5, 0.9, np.pi / 2])
    assert np.linalg.norm(check.correction(south, "bowl_south", radius=0.3, threshold=0.5,
                                           detour=True)[0] - south[:2]) <= 0.3 + 1e-9


def test_where_the_robot_stands_is_rated_by_the_model_and_moves_go_to_free_stops(scenario):
    """The stop check rates the believed position with the model's Fea^m (the robot stands
    there: whether a stop *sent* there would collide is not the question), and corrects
    only to free stops, the plan's heatmap cells with Fea^m > 0."""
    from s3o_drake.feasibility.planning_scene import PlanningScene

    known = KnownWorld.perfect(scenario)
    model = tuple(ORACLE_MAPS_ONCE.heatmaps(known))
    plan = PlanningScene(known).free_stops.restrict_all(model)
    check = StopCheck(known, plan, model_heatmaps=model)
    south = next(h for h in model if h.dish == "bowl_south")
    kept = next(h for h in plan if h.dish == "bowl_south")
    centers = south.centers()
    # A cell the model rates well that the free-stop rule dropped (a corner by the table).
    dropped = np.argwhere((south.values > 0.5) & (kept.values == 0.0))
    assert len(dropped)
    here = centers[tuple(dropped[0])]
    assert check.feasibility(here, "bowl_south") == south.values[tuple(dropped[0])] > 0.5
    assert StopCheck(known, plan).feasibility(here, "bowl_south") == 0.0  # the plan's value
    target, _ = check.correction(np.array([*here, 0.0]), "bowl_south", radius=0.3)
    assert kept.value_at(target) > 0.0


def _planner(scenario, plan_from=ORACLE_MAPS_ONCE, **changes):
    scenario = dataclasses.replace(scenario, execution=dataclasses.replace(
        scenario.execution, **changes))
    system = make_executive_system(scenario, method="V-GROP*", seed=0, noise=False,
                                   perceive=scenario_unmapped_chairs(scenario),
                                   plan_from=plan_from)
    context = _context(system, scenario)
    system.ExecuteInitializationEvents(context)
    return system, context


@pytest.fixture(scope="module")
def replanning(scenario):
    """`_planner` of the scenario's own settings (recovery by replanning), planned once for
    the tests that walk it: each walks a copy of its context (`_copy`)."""
    return _planner(scenario)


def _copy(planned):
    """The planned system and a copy of its context (whose outputs are never evaluated: a
    context copies its computed outputs too, and a PlanningResult cannot be copied)."""
    system, context = planned
    return system, context.Clone()


def _land(system, context, pose):
    system.GetInputPort("robot_state").FixValue(
        context, UR5E.desired_state(UR5E.positions(*pose)))


def _finish(system, context, port, command, state="done", reason=""):
    system.GetInputPort(port).FixValue(context, Status(id=command.id, state=state,
                                                       reason=reason))
    _step(system, context)


def _first_stop(system, context):
    """Sends the plan's first goto; returns it and its pickup."""
    goto, pickup = system.GetOutputPort("plan").Eval(context).actions[:2]
    assert isinstance(goto, Goto) and isinstance(pickup, Pickup)
    _step(system, context)
    return goto, pickup, system.GetOutputPort("base_command").Eval(context)


def test_a_landing_out_of_reach_gets_a_corrective_move_then_the_pick(scenario, replanning):
    system, context = _copy(replanning)
    goto, pickup, command = _first_stop(system, context)
    dish = next(d for d in scenario.dishes if d.name == pickup.dish).position
    away = np.asarray(goto.pose[:2]) - dish
    landing = np.asarray(dish) + away * (1.0 + 0.35 / np.linalg.norm(away))  # 35 cm further
    _land(system, context, (*landing, facing_yaw(landing, dish)))
    _finish(system, context, "base_status", command)
    _step(system, context)  # the stop check: a corrective move, not a pick
    move = system.GetOutputPort("base_command").Eval(context)
    assert move.id > command.id and not move.turn
    assert np.linalg.norm(np.asarray(move.pose[:2]) - landing) <= 0.3 + 1e-9
    assert system.GetOutputPort("pick_command").Eval(context).id == 0
    _land(system, context, move.pose)
    _finish(system, context, "base_status", move)
    _step(system, context)
    pick = system.GetOutputPort("pick_command").Eval(context)
    assert pick.dish == pickup.dish and pick.id > move.id
    _finish(system, context, "arm_status", pick)
    progress = system.GetOutputPort("progress").Eval(context)
    (correction,) = progress.recoveries
    assert correction.kind == "correction" and correction.dish == pickup.dish
    assert "not feasible" in correction.trigger and correction.result == "done"
    (record,) = progress.pickups
    assert record.succeeded and record.planned_pose[:2] == pytest.approx(move.pose[:2])
    # Its prediction is the Fea^m of the corrected stop, the stop it was picked from.
    heatmaps = system.GetOutputPort("planning_result").Eval(context).heatmaps
    heatmap = next(h for h in heatmaps if h.dish == pickup.dish)
    assert record.predicted == heatmap.value_at(np.asarray(move.pose[:2])) > 0.5


def test_failed_pickups_are_retried_then_left_with_retry(scenario):
    system, context = _planner(scenario, recovery="retry", max_tries=3)
    goto, pickup, command = _first_stop(system, context)
    _land(system, context, goto.pose)
    _finish(system, context, "base_status", command)
    _step(system, context)
    first = system.GetOutputPort("pick_command").Eval(context)
    # A miss: tried again from where the base stands.
    _finish(system, context, "arm_status", first, "failed", "missed")
    _step(system, context)
    second = system.GetOutputPort("pick_command").Eval(context)
    assert second.dish == pickup.dish and second.id > first.id
    # No IK from here: the base moves before the third try.
    _finish(system, context, "arm_status", second, "failed", "no_ik")
    _step(system, context)
    move = system.GetOutputPort("base_command").Eval(context)
    assert move.id > second.id and not move.turn
    _land(system, context, move.pose)
    _finish(system, context, "base_status", move)
    _step(system, context)
    third = system.GetOutputPort("pick_command").Eval(context)
    assert third.id > move.id
    _finish(system, context, "arm_status", third, "failed", "no_ik")
    progress = system.GetOutputPort("progress").Eval(context)
    assert [r.attempt for r in progress.pickups] == [1, 2, 3]
    assert [r.kind for r in progress.recoveries] == ["retry", "correction", "retry", "give_up"]
    assert progress.recoveries[-1].dish == pickup.dish
    assert not progress.finished  # on with the next dish
    _step(system, context)
    assert system.GetOutputPort("base_command").Eval(context).id > third.id


def test_a_dish_whose_replan_finds_no_plan_is_left_and_the_old_plan_goes_on(scenario):
    """A replan after a dish failed its tries that finds no plan (the dense study's runs
    ended so, other dishes still on the tables) leaves that dish, and the plan goes on."""
    plans_found = [True]

    def plan_from(known, **kwargs):
        if plans_found[0]:
            return ORACLE_MAPS_ONCE(known, **kwargs)
        # The pipeline's answer when it finds no plan; no search needed to give it.
        return PlanningResult(known=known, method=kwargs["method"], seed=kwargs["seed"],
                              plan=None, error="no plan: none valid (test)")

    system, context = _planner(scenario, plan_from, recovery="replan", max_tries=1)
    plan = system.GetOutputPort("plan").Eval(context)
    goto, pickup, command = _first_stop(system, context)
    plans_found[0] = False
    _land(system, context, goto.pose)
    _finish(system, context, "base_status", command)
    _step(system, context)
    pick = system.GetOutputPort("pick_command").Eval(context)
    assert pick.dish == pickup.dish
    _finish(system, context, "arm_status", pick, "failed", "no_ik")
    progress = system.GetOutputPort("progress").Eval(context)
    assert [r.kind for r in progress.recoveries] == ["replan", "give_up"]
    assert progress.recoveries[0].result == "no plan: none valid (test)"
    assert progress.recoveries[1].dish == pickup.dish and len(progress.plans) == 2
    assert not progress.finished
    assert system.GetOutputPort("plan").Eval(context) is plan
    # On with the old plan's next action.
    _step(system, context)
    step = system.GetOutputPort("progress").Eval(context).step
    assert plan.actions[step - 1] is not pickup and not progress.finished
    nxt = plan.actions[plan.actions.index(pickup) + 1]
    port = "base_command" if isinstance(nxt, Goto) else "pick_command"
    assert system.GetOutputPort(port).Eval(context).id > pick.id


def _walk(system, context, limit=60):
    """Finishes every command the planner sends (drives land where they were sent) until
    the execution finishes; returns its progress."""
    seen = 0
    for _ in range(limit):
        _step(system, context)
        progress = system.GetOutputPort("progress").Eval(context)
        if progress.finished:
            return progress
        base = system.GetOutputPort("base_command").Eval(context)
        pick = system.GetOutputPort("pick_command").Eval(context)
        if max(base.id, pick.id) <= seen:
            continue
        seen = max(base.id, pick.id)
        if base.id == seen:
            _land(system, context, base.pose)
            _finish(system, context, "base_status", base)
        else:
            _finish(system, context, "arm_status", pick)
    raise AssertionError("the execution did not finish")


def test_a_dish_left_out_unchecked_is_planned_for_again_at_the_plan_s_end(scenario):
    """A first plan that left a dish out on the network's Fea^m alone (no time for the
    Drake check) is followed, at its end, by a replan for that dish."""
    real = ORACLE_MAPS_ONCE
    asked, margins = [], []

    def first_without_north(known, **kwargs):
        asked.append(sorted(known.dish_names))
        margins.append(kwargs["drive_margin"])
        if len(asked) > 1:
            return real(known, **kwargs)
        result = real(known.moved(pose=known.pose, dishes=["bowl_south"]), **kwargs)
        plan = dataclasses.replace(result.plan, unreachable=("bowl_north",))
        return dataclasses.replace(result, plan=plan, unchecked=("bowl_north",))

    system, context = _planner(scenario, first_without_north, recovery="replan")
    assert [a.dish for a in system.GetOutputPort("plan").Eval(context).pickups] == [
        "bowl_south"]
    progress = _walk(system, context)
    assert asked == [["bowl_north", "bowl_south"], ["bowl_north"]]
    # Asked again on a map that keeps only the collision check's padding.
    assert margins == [DRIVE_MARGIN, TIGHT_DRIVE_MARGIN]
    replan = next(r for r in progress.recoveries if r.kind == "replan")
    assert replan.trigger == "left out: bowl_north" and replan.result == "done"
    picked = [r.dish for r in progress.pickups if r.outcome == "done"]
    assert picked == ["bowl_south", "bowl_north"] and progress.unreachable == ()
    # Asked once: a dish still left out after the check is not asked for again.
    assert len(progress.plans) == 2


def test_a_blocked_drive_is_replanned_from_where_the_robot_stands(scenario, replanning):
    system, context = _copy(replanning)
    _goto, _, command = _first_stop(system, context)
    stopped = (1.2, 0.8, 0.3)
    _land(system, context, stopped)
    # What blocked the drive, where the base touched it: 30 cm ahead on its heading.
    contact = (1.2 + 0.3 * np.cos(0.3), 0.8 + 0.3 * np.sin(0.3))
    system.GetInputPort("base_status").FixValue(context, Status(
        id=command.id, state="failed", reason="blocked", contact=contact))
    _step(system, context)
    progress = system.GetOutputPort("progress").Eval(context)
    (replan,) = progress.recoveries
    assert replan.kind == "replan" and replan.trigger.endswith("failed: blocked")
    assert replan.result == "done" and replan.planning_time > 0 and not progress.finished
    # Each plan's time against its own budget: the first the planner's, the replan's own.
    first, again_ = progress.plans
    assert first.budget == scenario.planner.time_budget
    assert again_.budget == scenario.execution.replan_budget
    assert again_.planning_time == replan.planning_time
    assert 0 <= again_.feasibility_time <= again_.planning_time
    result = system.GetOutputPort("planning_result").Eval(context)
    assert result.known.pose[:2] == pytest.approx(stopped[:2])
    assert {a.dish for a in result.plan.pickups} == {d.name for d in scenario.dishes}
    # The replan knows the contact as an obstacle: its drives keep clear of it.
    assert result.known.contacts == (contact,)
    assert any(f.contains(Point(*contact)) for f in result.known.obstacles.footprints)
    _step(system, context)
    again = system.GetOutputPort("base_command").Eval(context)
    assert again.id > command.id and again.path[0] == pytest.approx(stopped[:2])
    route = LineString(again.path)
    assert route.distance(Point(*contact)) > CONTACT_RADIUS


def test_with_no_recovery_a_blocked_drive_still_ends_the_run(scenario):
    system, context = _planner(scenario, recovery="none")
    _, _, command = _first_stop(system, context)
    _finish(system, context, "base_status", command, "failed", "blocked")
    progress = system.GetOutputPort("progress").Eval(context)
    assert progress.finished and not progress.recoveries


# ------------------------------------------------------------------ short simulations
def _run(path, recovery, **kwargs):
    scenario = load_scenario(path)
    uncertainty = kwargs.pop("uncertainty", None)
    motion = kwargs.pop("motion", scenario.execution.motion)
    scenario = dataclasses.replace(
        scenario, planner=dataclasses.replace(scenario.planner, feasibility="oracle"),
        execution=dataclasses.replace(scenario.execution, recovery=recovery, motion=motion),
        uncertainty=uncertainty or scenario.uncertainty)
    scenario = dataclasses.replace(scenario, simulation=dataclasses.replace(
        scenario.simulation, publish_period=1.0))
    kwargs.setdefault("plan_from", ORACLE_MAPS_ONCE)
    return execute(scenario, meshcat=None, progress=False, **kwargs).report


def _ending_with_pickup_of(dish):
    """The planner (`plan_from`), its plans cut after `dish`'s pickup, the dishes after it
    left out: a run that has nothing to show after that pickup ends there."""

    def plan_from(known, **kwargs):
        result = ORACLE_MAPS_ONCE(known, **kwargs)
        actions = result.plan.actions
        end = next(k for k, a in enumerate(actions)
                   if isinstance(a, Pickup) and a.dish == dish) + 1
        rest = tuple(a.dish for a in actions[end:] if isinstance(a, Pickup))
        return dataclasses.replace(result, plan=dataclasses.replace(
            result.plan, actions=actions[:end], unreachable=result.plan.unreachable + rest))

    return plan_from


def test_in_simulation_a_landing_out_of_reach_is_corrected():
    """Seed 2 with 35 cm landing noise: the open loop lands out of the arm's reach of the
    south bowl and fails it (no_ik); with recovery the stop is corrected and both are
    collected. (The seed's landings are those of the stop-and-go plan.) The open loop runs
    its plan up to that pickup: the same drives and the same seeded landings, and nothing
    after can change how the pickup ends."""
    noisy = Uncertainty(nav_xy_std=0.35)
    open_loop = _run(SCENE, "none", seed=2, uncertainty=noisy, motion="stop_and_go",
                     plan_from=_ending_with_pickup_of("bowl_south"))
    assert ["pickup", "bowl_south", "failed: no_ik"] in open_loop["outcomes"]
    recovered = _run(SCENE, "replan", seed=2, uncertainty=noisy, motion="stop_and_go")
    assert recovered["collected"] == 2
    corrections = [r for r in recovered["recoveries"] if r["kind"] == "correction"]
    assert corrections and corrections[0]["dish"] == "bowl_south"
    assert corrections[0]["cost"] > 0


def test_in_simulation_a_blocked_path_is_replanned():
    """Perception misses the two chairs that close the west aisle at first: the first drive
    is blocked; the replan sees them and goes round the east end."""
    scenario = load_scenario("scenarios/small/blocked_aisle.yaml")
    chairs = [list(c.pose) for c in scenario.chairs]
    looks = []

    def perceive(color, depth, label):
        looks.append(1)
        return [] if len(looks) == 1 else [list(c) for c in chairs]

    report = _run("scenarios/small/blocked_aisle.yaml", "replan", perceive=perceive)
    assert report["outcomes"][0] == ["goto", "l0", "failed: blocked"]
    (replan,) = report["recoveries"]
    assert replan["kind"] == "replan" and len(looks) == 2
    assert len(report["plans"]) == 2
    assert report["planning_time"] == pytest.approx(sum(p["planning_time"]
                                                        for p in report["plans"]))
    assert report["collected"] == 1 and report["reason"] == "plan ended"


def test_in_simulation_a_dish_behind_a_wall_is_reported_unreachable_quickly():
    start = time.perf_counter()
    report = _run("scenarios/small/behind_wall.yaml", "replan")
    assert time.perf_counter() - start < 120  # no hang: seconds, not the time limit
    assert report["unreachable"] == ["plate_back"]
    assert report["collected_dishes"] == ["bowl_front"] and report["finished"]
    # Asked for once more at the plan's end, on the tight map: still no stop behind a wall.
    (again,) = [r for r in report["recoveries"] if r["kind"] == "replan"]
    assert again["trigger"] == "left out: plate_back" and "0 actions" in again["action"]


def test_a_study_s_recovery_figures_count_what_the_runs_report():
    from s3o_drake.experiments.recovery_summary import recovery_figures, recovery_table

    def pickup(dish, outcome):
        return {"dish": dish, "outcome": outcome}

    runs = [
        {"task": "t0", "method": "M", "complete": True, "reason": "plan complete",
         "pickups": [pickup("a", "no_ik"), pickup("a", "done"), pickup("b", "done")],
         "recoveries": [{"kind": "correction", "cost": 4.0, "planning_time": 0.0},
                        {"kind": "retry", "cost": 7.0, "planning_time": 0.0}]},
        {"task": "t1", "method": "M", "complete": False, "reason": "goto l1 failed: blocked",
         "pickups": [pickup("c", "done")],
         "recoveries": [{"kind": "replan", "cost": 0.0, "planning_time": 3.0}]},
        {"task": "t1", "method": "M", "error": "RuntimeError: x"},
        # Results written before issue 18 said "plan complete" for a plan that ran to its
        # end; those of now say "plan ended". Neither ended early.
        {"task": "t2", "method": "M", "complete": False, "reason": "plan ended",
         "pickups": [pickup("f", "no_ik")], "recoveries": []},
    ]
    areas = {"t0": {"a": 0.5, "b": 0.2}, "t1": {"c": 0.4, "d": 0.3, "e": 0.0},
             "t2": {"f": 0.0}}
    f = recovery_figures(runs, ["M"], areas)["M"]
    assert f["runs"] == 3 and f["complete"] == 1 and f["runs_with_recovery"] == 2
    assert f["recoveries"] == {"correction": 1, "retry": 1, "replan": 1}
    assert f["cost_per_run"] == pytest.approx(11.0 / 3)
    assert f["replan_planning_per_run"] == pytest.approx(1.0)
    # e cannot be picked from any free pose: not counted against the run.
    assert (f["pickable"], f["pickable_collected"]) == (4, 3)
    assert f["pickable_missed"] == ["t1/d"] and f["ended_early"] == 1
    assert "| pickable dishes collected | 3 of 4 |" in recovery_table({"M": f})
    assert f["incomplete"] == {"no plan": 0, "blocked drive": 1, "dish given up": 0,
                               "dish unreachable on the map": 0, "other": 1}
    assert "| incomplete runs: blocked drive | 1 |" in recovery_table({"M": f})


def test_incomplete_runs_are_told_apart_by_what_ended_them():
    from s3o_drake.experiments.recovery_summary import incomplete_cause

    give_up = {"kind": "give_up"}
    assert incomplete_cause({"planned": False, "reason": "no plan: x"}) == "no plan"
    # A replan that found no plan ends the run as surely as a first plan that did not.
    assert incomplete_cause({"reason": "no plan: S3O: no valid plan",
                             "recoveries": [give_up]}) == "no plan"
    assert incomplete_cause({"reason": "goto l0 failed: blocked"}) == "blocked drive"
    assert incomplete_cause({"reason": "plan ended", "recoveries": [give_up],
                             "unreachable": ["a"]}) == "dish given up"
    assert incomplete_cause({"reason": "plan ended", "recoveries": [],
                             "unreachable": ["a"]}) == "dish unreachable on the map"
    assert incomplete_cause({"reason": "the simulation failed at t = 3 s"}) == "other"


def test_recovery_is_set_against_the_same_runs_in_open_loop():
    """Each run with recovery meets its open-loop twin (task, method, run seed); the time
    recovery adds counts only pairs where both collected every dish."""
    from s3o_drake.experiments.recovery_summary import recovery_figures, recovery_table

    def run(task, seed, complete, time, recovery="replan"):
        return {"task": task, "method": "M", "run_seed": seed, "complete": complete,
                "execution_time": time, "reason": "plan ended", "recovery": recovery,
                "pickups": [], "recoveries": []}

    runs = [run("t0", 1, True, 110.0), run("t1", 2, True, 130.0), run("t2", 3, True, 90.0)]
    open_loop = [run("t0", 1, True, 100.0, "none"), run("t1", 2, False, 60.0, "none"),
                 run("t2", 4, True, 10.0, "none")]  # another seed: not t2's twin
    f = recovery_figures(runs, ["M"], {}, open_loop)["M"]["open_loop"]
    assert (f["pairs"], f["complete"], f["complete_with_recovery"]) == (2, 1, 2)
    assert f["time"] == pytest.approx(80.0) and f["time_with_recovery"] == pytest.approx(120.0)
    assert f["both_complete"] == 1 and f["extra_time_both_complete"] == pytest.approx(10.0)
    table = recovery_table({"M": recovery_figures(runs, ["M"], {}, open_loop)["M"]})
    assert "| completion, open loop -> recovery | 0.50 -> 1.00 |" in table
    assert "| time recovery adds where both collected all (s, runs) | +10.0 (1) |" in table
    assert "open loop" not in recovery_table({"M": recovery_figures(runs, ["M"], {})["M"]})
