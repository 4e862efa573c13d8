"""The ExecutiveSystem LeafSystem alone (fixed inputs, forced updates, and a short
simulation): it plans at initialization and walks the plan, one command at a time,
advancing on the controllers' reports."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from pydrake.common.value import AbstractValue
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantValueSource, ConstantVectorSource
from pydrake.systems.sensors import ImageDepth32F, ImageLabel16I, ImageRgba8U

from s3o_drake.belief import scenario_unmapped_chairs
from s3o_drake.execution.controllers import make_executive_system
from s3o_drake.execution.messages import NO_COMMAND, PickupRecord, Status
from s3o_drake.planning.plan import Goto, Pickup, Place
from s3o_drake.world.robot import load_robot
from s3o_drake.world.scenario import load_scenario
from tests.conftest import ORACLE_MAPS_ONCE

UR5E = load_robot("ur5e")

SCENE = "scenarios/small/opposite_sides.yaml"


def _executive(scenario, **kwargs):
    """The ExecutiveSystem, planning with the oracle's Fea^m of each scene computed once
    (tests/conftest.py: OracleMapsOnce)."""
    return make_executive_system(scenario, plan_from=ORACLE_MAPS_ONCE, **kwargs)


def _with_oracle(scenario, recovery="none", motion="stop_and_go"):
    """These tests feed blank images: the heatmaps come from the Drake oracle (the FCN reads
    the images; tests/commands/test_run.py runs it end to end). They walk the paper's open
    loop, stopping and going, unless they say otherwise (tests/execution/test_recovery.py has
    the recoveries, tests/execution/test_executive.py the smooth walk)."""
    return dataclasses.replace(
        scenario, planner=dataclasses.replace(scenario.planner, feasibility="oracle"),
        execution=dataclasses.replace(scenario.execution, recovery=recovery, motion=motion))


def _one_stop_for_both(scenario):
    """two_dishes rated as the paper rates a shared stop, under which S3O-GROP* picks both
    plates from one stop (with the UR5e's recorded shares it may stop twice)."""
    return dataclasses.replace(scenario, planner=dataclasses.replace(
        scenario.planner, shared_stop="paper"))


@pytest.fixture(scope="module")
def scenario():
    return _with_oracle(load_scenario(SCENE))


def _context(system, scenario):
    context = system.CreateDefaultContext()
    system.GetInputPort("overhead_color_image").FixValue(context, ImageRgba8U(8, 8))
    system.GetInputPort("overhead_depth_image").FixValue(context, ImageDepth32F(8, 8))
    system.GetInputPort("overhead_label_image").FixValue(context, ImageLabel16I(8, 8))
    state = UR5E.desired_state(UR5E.positions(*scenario.robot.start))
    system.GetInputPort("robot_state").FixValue(context, state)
    system.GetInputPort("base_status").FixValue(context, Status())
    system.GetInputPort("arm_status").FixValue(context, Status())
    return context


def _land(system, context, goto):
    """The base reports the drive out done, landed exactly at `goto`'s pose."""
    command = system.GetOutputPort("base_command").Eval(context)
    system.GetInputPort("base_status").FixValue(context, Status(command.id, "done"))
    system.GetInputPort("robot_state").FixValue(
        context, UR5E.desired_state(UR5E.positions(*goto.pose)))


def _step(system, context):
    system.CalcForcedUnrestrictedUpdate(context, context.get_mutable_state())


@pytest.fixture(scope="module")
def planned(scenario):
    """The system planned at initialization (V-GROP*), with what its `plan_from` was asked
    then. Each test reads or walks a copy of its context (`_copy`): the system keeps all
    it knows there, and one plan serves them all.

    On the coarse maps that tests/execution/test_recovery.py plans this scene on too: the
    tests are about planning at initialization and walking the plan, not the maps'
    accuracy, and the full maps were most of this file's time."""
    asked = []

    def plan_from(known, **kwargs):
        asked.append(known)
        return ORACLE_MAPS_ONCE(known, **kwargs)

    system = make_executive_system(scenario, method="V-GROP*", seed=0, plan_from=plan_from,
                                   perceive=scenario_unmapped_chairs(scenario))
    context = _context(system, scenario)
    system.ExecuteInitializationEvents(context)
    return system, context, tuple(asked)


def _copy(planned):
    """The planned system and a copy of its context, to walk without changing the
    original. (A context copies its computed outputs too, and a PlanningResult cannot be
    copied: the original's outputs are never evaluated.)"""
    system, context = planned[:2]
    return system, context.Clone()


def test_plans_at_initialization(planned, scenario):
    system, context = _copy(planned)
    plan = system.GetOutputPort("plan").Eval(context)
    assert plan is not None and plan.method == "V-GROP*"
    assert {a.dish for a in plan.pickups} == {d.name for d in scenario.dishes}
    progress = system.GetOutputPort("progress").Eval(context)
    assert progress.total == len(plan.actions) and not progress.finished
    assert system.GetOutputPort("base_command").Eval(context).id == NO_COMMAND
    assert system.GetOutputPort("planning_time").Eval(context)[0] > 0
    result = system.GetOutputPort("planning_result").Eval(context)
    assert result.plan is plan and result.navigation is not None and result.heatmaps


def test_plans_with_the_plan_from_it_is_given(planned, scenario):
    """Another planner plugs in as `plan_from`: it is asked once, at initialization, with
    what the robot knows (a KnownWorld: the perceived chairs, not the true ones)."""
    from s3o_drake.belief.known_world import KnownWorld

    system, context = _copy(planned)
    (known,) = planned[2]
    assert isinstance(known, KnownWorld)
    assert {d.name for d in known.dishes} == {d.name for d in scenario.dishes}
    assert system.GetOutputPort("plan").Eval(context).method == "V-GROP*"


@pytest.mark.parametrize("motion", ["stop_and_go", "smooth"])
def test_in_a_short_simulation_it_plans_then_sends_the_first_drive(scenario, motion):
    """Inside a diagram whose controllers never report: the plan is made at initialization,
    the first goto's drive goes out at the first control period, and nothing more; with
    smooth motion, with it the arm's command to the first dish's pre-grasp, timed by that
    drive."""
    scenario = dataclasses.replace(scenario, execution=dataclasses.replace(
        scenario.execution, motion=motion))
    builder = DiagramBuilder()
    system = builder.AddSystem(_executive(
        scenario, method="V-GROP*", seed=0, perceive=scenario_unmapped_chairs(scenario)))
    state = UR5E.desired_state(UR5E.positions(*scenario.robot.start))
    inputs = {"overhead_color_image": ImageRgba8U(8, 8),
              "overhead_depth_image": ImageDepth32F(8, 8),
              "overhead_label_image": ImageLabel16I(8, 8),
              "base_status": Status(), "arm_status": Status()}
    for name, value in inputs.items():
        source = builder.AddSystem(ConstantValueSource(AbstractValue.Make(value)))
        builder.Connect(source.get_output_port(), system.GetInputPort(name))
    robot = builder.AddSystem(ConstantVectorSource(state))
    builder.Connect(robot.get_output_port(), system.GetInputPort("robot_state"))
    simulator = Simulator(builder.Build())
    simulator.AdvanceTo(0.3)
    context = system.GetMyContextFromRoot(simulator.get_context())
    plan = system.GetOutputPort("plan").Eval(context)
    command = system.GetOutputPort("base_command").Eval(context)
    assert isinstance(plan.actions[0], Goto) and command.id == 1
    assert command.pose == pytest.approx(plan.actions[0].pose)
    progress = system.GetOutputPort("progress").Eval(context)
    assert progress.step == 1 and not progress.finished and not progress.outcomes
    pick = system.GetOutputPort("pick_command").Eval(context)
    if motion == "stop_and_go":
        assert pick.id == NO_COMMAND
    else:
        assert pick.id == 2 and pick.base_id == 1 and pick.prepare == pytest.approx(
            plan.actions[0].pose) and pick.dish == plan.actions[1].dish


def test_walks_the_plan_on_the_controllers_reports(planned):
    system, context = _copy(planned)
    plan = system.GetOutputPort("plan").Eval(context)
    base_status = system.GetInputPort("base_status")
    arm_status = system.GetInputPort("arm_status")
    sent = []
    for i, action in enumerate(plan.actions):
        _step(system, context)  # sends the command of this action
        if isinstance(action, Goto):
            command = system.GetOutputPort("base_command").Eval(context)
            assert command.pose == pytest.approx(action.pose)
            # The path starts where the base is and ends at the goal, clear of the map.
            assert np.allclose(command.path[-1], action.pose[:2])
            _step(system, context)  # a running controller: nothing changes
            assert system.GetOutputPort("progress").Eval(context).step == i + 1
            base_status.FixValue(context, Status(id=command.id, state="done"))
            # The base arrives: the first pickup there needs no turn (the stop faces it).
            system.GetInputPort("robot_state").FixValue(
                context, UR5E.desired_state(UR5E.positions(*action.pose)))
        else:
            assert isinstance(action, Pickup)
            command = system.GetOutputPort("pick_command").Eval(context)
            assert command.dish == action.dish
            # The first pickup fails: the plan goes on with the next action.
            failed = not any(isinstance(a, Pickup) for a in plan.actions[:i])
            arm_status.FixValue(context, Status(id=command.id, state="failed" if failed
                                                else "done", reason="missed"))
        sent.append(command.id)
        _step(system, context)  # reads the report, advances
    assert sent == sorted(set(sent))  # a fresh id per command
    progress = system.GetOutputPort("progress").Eval(context)
    assert progress.finished and progress.reason == "plan ended"
    outcomes = [o for _, _, o in progress.outcomes]
    assert outcomes.count("failed: missed") == 1 and len(outcomes) == len(plan.actions)


def test_a_failed_goto_ends_the_execution(planned):
    system, context = _copy(planned)
    _step(system, context)
    command = system.GetOutputPort("base_command").Eval(context)
    system.GetInputPort("base_status").FixValue(
        context, Status(id=command.id, state="failed", reason="blocked"))
    _step(system, context)
    progress = system.GetOutputPort("progress").Eval(context)
    assert progress.finished and "failed: blocked" in progress.reason
    _step(system, context)  # nothing more is sent
    assert system.GetOutputPort("base_command").Eval(context).id == command.id


def test_perception_decides_the_obstacles(scenario):
    """The planner plans around what perception reports, not the scenario's chairs."""
    # One bowl: the perceived chair makes a world of its own, whose Fea^m the planner
    # computes for each dish.
    scenario = dataclasses.replace(scenario, dishes=scenario.dishes[:1])
    seen = []

    def perceive(color, depth, label):
        seen.append((color.shape, depth.shape, label.shape))
        return [[1.0, 1.0, 0.0]]

    system = _executive(scenario, method="V-GROP*", seed=0, perceive=perceive)
    context = _context(system, scenario)
    system.ExecuteInitializationEvents(context)
    assert seen == [((8, 8, 4), (8, 8), (8, 8))]
    known = system.GetOutputPort("planning_result").Eval(context).known
    assert known.perceived_chairs == ((1.0, 1.0, 0.0),)
    assert known.map.chairs == tuple(c for c in scenario.chairs if c.mapped)
    # The controllers check their motions in the same belief: the perceived chair is in
    # it, and no unmapped chair of the scenario's.
    scene = system.GetOutputPort("known_scene").Eval(context).scene
    assert scene.contents == known.contents
    chairs = {c.name: tuple(c.pose) for c in scene.contents.chairs if not c.mapped}
    assert chairs == {"perceived_0": (1.0, 1.0, 0.0)}


def test_no_scene_before_the_first_plan(scenario):
    system = _executive(scenario, method="V-GROP*", seed=0)
    assert system.GetOutputPort("known_scene").Eval(system.CreateDefaultContext()).scene is None


@pytest.fixture(scope="module")
def one_stop():
    """two_dishes (`_one_stop_for_both`) planned with S3O-GROP*: the scenario, the system
    and its context, which each test walks a copy of."""
    scenario = _one_stop_for_both(_with_oracle(load_scenario("scenarios/small/two_dishes.yaml")))
    system = _executive(scenario, method="S3O-GROP*", seed=0,
                        perceive=scenario_unmapped_chairs(scenario))
    context = _context(system, scenario)
    system.ExecuteInitializationEvents(context)
    return scenario, system, context


def test_turns_to_face_each_further_dish_before_picking_it(one_stop):
    """Fea^m assumed the base faces the dish it picks: at a stop that serves two dishes,
    the second pickup is preceded by a turn in place (no navigation noise), then picked."""
    scenario = one_stop[0]
    system, context = _copy(one_stop[1:])
    plan = system.GetOutputPort("plan").Eval(context)
    assert len(plan.gotos) == 1 and len(plan.pickups) == 2
    goto, first, second = plan.actions
    _step(system, context)
    command = system.GetOutputPort("base_command").Eval(context)
    system.GetInputPort("base_status").FixValue(context, Status(id=command.id, state="done"))
    system.GetInputPort("robot_state").FixValue(
        context, UR5E.desired_state(UR5E.positions(*goto.pose)))
    _step(system, context)  # goto done
    _step(system, context)  # first pickup: faced already
    pick = system.GetOutputPort("pick_command").Eval(context)
    assert pick.dish == first.dish
    system.GetInputPort("arm_status").FixValue(context, Status(id=pick.id, state="done"))
    _step(system, context)
    _step(system, context)  # second pickup: a turn first
    turn = system.GetOutputPort("base_command").Eval(context)
    assert turn.turn and turn.id > pick.id
    x, y, yaw = turn.pose
    dish = next(d for d in scenario.dishes if d.name == second.dish)
    assert (x, y) == pytest.approx(goto.pose[:2])
    assert yaw == pytest.approx(np.arctan2(dish.position[1] - y, dish.position[0] - x))
    assert system.GetOutputPort("pick_command").Eval(context).id == pick.id  # not yet
    system.GetInputPort("base_status").FixValue(context, Status(id=turn.id, state="done"))
    _step(system, context)
    _step(system, context)
    pick2 = system.GetOutputPort("pick_command").Eval(context)
    assert pick2.dish == second.dish and pick2.id > turn.id


def test_records_every_finished_pickup_with_its_prediction_and_real_stop(planned, scenario):
    """Each finished pickup leaves a PickupRecord on `progress`: the plan's Fea^m and the
    stop it was predicted for, where the base really stood when the pick was sent, the
    arm's outcome, and the arm command that aimed with a sighting (whose error the referee
    joins to it)."""
    system, context = _copy(planned)
    plan = system.GetOutputPort("plan").Eval(context)
    kinds = {d.name: d.kind for d in scenario.dishes}
    positions = {d.name: d.position for d in scenario.dishes}
    expected, sightings, stop, landing = [], [], None, None
    for i, action in enumerate(plan.actions):
        _step(system, context)
        if isinstance(action, Goto):
            command = system.GetOutputPort("base_command").Eval(context)
            system.GetInputPort("base_status").FixValue(context, Status(command.id, "done"))
            # A landing off the planned stop, facing the dish it picks next (no turn).
            dish = positions[plan.actions[i + 1].dish]
            x, y = action.pose[0] + 0.03 * (i + 1), action.pose[1] - 0.02
            landing = (x, y, float(np.arctan2(dish[1] - y, dish[0] - x)))
            system.GetInputPort("robot_state").FixValue(
                context, UR5E.desired_state(UR5E.positions(*landing)))
            stop = action.pose
        else:
            command = system.GetOutputPort("pick_command").Eval(context)
            failed = len(expected) == 0
            system.GetInputPort("arm_status").FixValue(context, Status(
                command.id, "failed" if failed else "done", "no_ik" if failed else "",
                sighted=True))
            expected.append(PickupRecord(
                dish=action.dish, kind=kinds[action.dish], method="V-GROP*",
                predicted=action.feasibility, source="oracle", planned_pose=stop,
                actual_pose=landing, outcome="no_ik" if failed else "done",
                planned=action.feasibility))
            sightings.append(command.id)
        _step(system, context)
    records = system.GetOutputPort("progress").Eval(context).pickups
    assert len(records) == len(plan.pickups) >= 2
    for got, want in zip(records, expected, strict=True):
        assert got.actual_pose == pytest.approx(want.actual_pose)
        assert got == dataclasses.replace(want, actual_pose=got.actual_pose)
    assert [r.sighting for r in records] == sightings
    assert [r.succeeded for r in records] == [False] + [True] * (len(records) - 1)


def test_a_pickup_whose_turn_fails_is_recorded_where_the_base_stopped(one_stop):
    system, context = _copy(one_stop[1:])
    goto, first, second = system.GetOutputPort("plan").Eval(context).actions
    _step(system, context)
    command = system.GetOutputPort("base_command").Eval(context)
    system.GetInputPort("base_status").FixValue(context, Status(id=command.id, state="done"))
    system.GetInputPort("robot_state").FixValue(
        context, UR5E.desired_state(UR5E.positions(*goto.pose)))
    _step(system, context)
    _step(system, context)
    pick = system.GetOutputPort("pick_command").Eval(context)
    system.GetInputPort("arm_status").FixValue(context, Status(id=pick.id, state="done"))
    _step(system, context)
    _step(system, context)  # the turn towards the second dish
    turn = system.GetOutputPort("base_command").Eval(context)
    assert turn.turn
    stopped = (goto.pose[0], goto.pose[1], goto.pose[2] + 0.2)
    system.GetInputPort("robot_state").FixValue(
        context, UR5E.desired_state(UR5E.positions(*stopped)))
    system.GetInputPort("base_status").FixValue(
        context, Status(id=turn.id, state="failed", reason="blocked"))
    _step(system, context)
    progress = system.GetOutputPort("progress").Eval(context)
    assert tuple(progress.outcomes[-1]) == ("pickup", second.dish, "failed: turn blocked")
    done, blocked = progress.pickups
    assert (done.dish, done.outcome, blocked.dish) == (first.dish, "done", second.dish)
    assert done.actual_pose == pytest.approx(goto.pose)
    assert blocked.outcome == "turn blocked" and blocked.reach_noise is None
    assert blocked.actual_pose == pytest.approx(stopped)
    assert blocked.planned_pose == done.planned_pose == pytest.approx(goto.pose)
    assert blocked.predicted == second.feasibility


@pytest.fixture(scope="module")
def tidy():
    """An ExecutiveSystem of tidy_home (V-GROP*, open loop) that has planned, and its
    context. One can on the coffee table beside the apple, not the paper's two: each
    object costs the plan its Fea^m map, and one can picked before the apple shows what
    two do."""
    tidy = _with_oracle(load_scenario("scenarios/tidy_home.yaml"))
    tidy = dataclasses.replace(tidy, dishes=[d for d in tidy.dishes if d.name != "can_2"])
    system = _executive(tidy, method="V-GROP*", seed=0,
                        perceive=scenario_unmapped_chairs(tidy))
    context = _context(system, tidy)
    system.GetInputPort("replan_request").FixValue(context, [0.0])
    system.ExecuteInitializationEvents(context)
    return system, context


def _tidy_planner(tidy):
    """The planned tidy_home system, a copy of its context to walk, and its plan."""
    system, context = _copy(tidy)
    return system, context, system.GetOutputPort("plan").Eval(context)


def test_a_replan_while_an_object_to_place_is_held_puts_it_down_first(tidy):
    """tidy_home: the apple is picked (held, not on the tray); a replan then plans the
    apple's place without picking it again, before the can that remains (the gripper is
    busy until then). The place is sent to the arm as a PickCommand with `place`."""
    system, context, plan = _tidy_planner(tidy)
    apple = plan.actions.index(next(a for a in plan.pickups if a.dish == "apple"))
    put = next(k for k, a in enumerate(plan.actions) if isinstance(a, Place))
    place_stop = next(a.pose for a in reversed(plan.actions[:put]) if isinstance(a, Goto))
    for action in plan.actions[:apple + 1]:
        _step(system, context)
        if isinstance(action, Goto):
            _land(system, context, action)
        else:
            command = system.GetOutputPort("pick_command").Eval(context)
            assert command.dish == action.dish and not command.place
            # The apple's pickup is told where the plan puts it down from (its grasp must
            # work there); the cans' are not.
            assert command.place_from == (place_stop if action.dish == "apple" else None)
            system.GetInputPort("arm_status").FixValue(context, Status(command.id, "done"))
        _step(system, context)
    picked = {d for action, d, outcome in system.GetOutputPort("progress").Eval(context).outcomes
              if action == "pickup" and outcome == "done"}
    assert "apple" in picked and "can_3" not in picked
    system.GetInputPort("replan_request").FixValue(context, [1.0])
    _step(system, context)
    replanned = system.GetOutputPort("plan").Eval(context)
    kinds = [(type(a).__name__, getattr(a, "dish", "")) for a in replanned.actions]
    assert ("Pickup", "apple") not in kinds and ("Pickup", "can_3") in kinds
    assert kinds.index(("Place", "apple")) < kinds.index(("Pickup", "can_3"))
    assert {a.dish for a in replanned.pickups} == {"can_3"} - picked
    # Walk to the place: the arm is told to put the apple down.
    for action in replanned.actions[:kinds.index(("Place", "apple")) + 1]:
        _step(system, context)
        if isinstance(action, Goto):
            _land(system, context, action)
            _step(system, context)
    command = system.GetOutputPort("pick_command").Eval(context)
    assert command.dish == "apple" and command.place


def test_an_object_whose_place_fails_is_let_go_over_the_tray_then_the_plan_goes_on(tidy):
    """tidy_home, open loop: the apple's place fails (no_ik), so the gripper would hold it
    for good and every later pickup fail hand_full. The planner has the arm let it go over
    the tray (a PickCommand naming the held apple, without `place`), then goes on."""
    system, context, plan = _tidy_planner(tidy)
    put = next(k for k, a in enumerate(plan.actions) if isinstance(a, Place))
    for action in plan.actions[:put + 1]:
        _step(system, context)
        if isinstance(action, Goto):
            _land(system, context, action)
        else:
            command = system.GetOutputPort("pick_command").Eval(context)
            assert command.place == isinstance(action, Place)
            failed = isinstance(action, Place)
            system.GetInputPort("arm_status").FixValue(
                context, Status(command.id, "failed", "no_ik") if failed else
                Status(command.id, "done"))
        _step(system, context)
    _step(system, context)  # the failed place is taken up: the tray's command goes out
    command = system.GetOutputPort("pick_command").Eval(context)
    assert command.dish == "apple" and not command.place
    system.GetInputPort("arm_status").FixValue(context, Status(command.id, "done"))
    _step(system, context)
    progress = system.GetOutputPort("progress").Eval(context)
    assert ("place", "apple", "failed: no_ik") in [
        (a, d, o) for a, d, o in progress.outcomes]
    assert len(progress.outcomes) == put + 1 and not progress.finished
    # On with the plan: its next action is commanded.
    _step(system, context)
    nxt = plan.actions[put + 1]
    out = system.GetOutputPort("base_command" if isinstance(nxt, Goto) else "pick_command")
    assert out.Eval(context).id > command.id
