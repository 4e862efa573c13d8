"""ArmController: pickups planned from the real robot and dish, played, gripped and reported.

The scene (tests/conftest.py) is scenarios/small/two_dishes.yaml: a table (x 1.4..2.6, y
2.1..2.9, top at 0.75 m) with a plate at (1.85, 2.3) and a cup at (2.15, 2.3); the robot
faces them from y = 1.45.
"""

import dataclasses
import functools
import math
import time
from pathlib import Path

import numpy as np
import pytest
from pydrake.common.value import AbstractValue
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder, PortDataType
from pydrake.systems.primitives import (
    ConstantValueSource,
    ConstantVectorSource,
    MatrixGain,
    Multiplexer,
    VectorLogSink,
)

from s3o_drake.execution.arm.place import place_grasps
from s3o_drake.execution.arm_controller import GRIP_REPORT_TIMEOUT, ArmController
from s3o_drake.execution.controllers import arm_params
from s3o_drake.execution.messages import CommandState, KnownScene, PickCommand, Status
from s3o_drake.feasibility.check import FeasibilityChecker
from s3o_drake.feasibility.scene import FeasibilityScene
from s3o_drake.world.builder import build_world_diagram
from s3o_drake.world.dish_messages import DishPoses, DishState, DishStates
from s3o_drake.world.furniture import DISH_SHAPES
from s3o_drake.world.goals import with_place_targets
from s3o_drake.world.gripper import RIM_INSET, grasp_tolerance
from s3o_drake.world.objects import PlaceSpot
from s3o_drake.world.robot import load_robot
from s3o_drake.world.robot_messages import (
    GripEvent,
    GripperStatus,
    TargetRequest,
    TargetSighting,
)
from s3o_drake.world.scenario import load_scenario

UR5E = load_robot("ur5e")

REPO = Path(__file__).resolve().parents[2]
FRONT_OF_PLATE = np.array([1.85, 1.45, math.pi / 2])
STOWED = np.concatenate([UR5E.arm_stow, UR5E.gripper_open])
PLANNING_REASONS = ("no_ik", "no_path", "base_collision")


def _controller(scenario, scene, *, seed=None, noise=True, motion="stop_and_go"):
    """The scenario's controller, knowing the world as `scene` holds it; stopping and going
    unless `motion` says (the pickup then is done at its end)."""
    params = dataclasses.replace(arm_params(scenario, seed=seed, noise=noise), motion=motion)
    arm = ArmController(robot=scene.robot, params=params)
    context = arm.CreateDefaultContext()
    arm.GetInputPort("known_scene").FixValue(context, AbstractValue.Make(KnownScene(scene)))
    return arm, context


def _fix_robot(arm, context, base=FRONT_OF_PLATE, arm_q=STOWED):
    q = np.concatenate([base, arm_q])
    arm.GetInputPort("robot_state").FixValue(context,
                                             np.concatenate([q, np.zeros(UR5E.num_positions)]))


def _step(arm, context, t):
    """Runs the controller's update at time t, as the simulator's periodic event would."""
    context.SetTime(t)
    arm.CalcForcedUnrestrictedUpdate(context, context.get_mutable_state())


def _outputs(arm, context):
    return (arm.GetOutputPort("arm_desired_state").Eval(context),
            arm.GetOutputPort("grip").Eval(context),
            arm.GetOutputPort("status").Eval(context))


def _play(arm, context, t0, *, dt=0.05, limit=60.0):
    """Steps from t0 until the status is finished; records (t, desired, grip, status)."""
    record, t = [], t0
    while t < t0 + limit:
        _step(arm, context, t)
        desired, grip, status = _outputs(arm, context)
        record.append((t, desired.copy(), grip, status))
        if status.finished:
            return record
        t += dt
    raise AssertionError(f"not finished after {limit} s: {record[-1][3]}")


# ----------------------------------------------------------------------------- alone

def test_the_controller_takes_no_truth_of_the_dishes(scenario, scene):
    """What the arm knows of a dish is the robot's sighting of it: no input carries the
    simulation's dish poses or states."""
    arm, _ = _controller(scenario, scene)
    names = [arm.get_input_port(i).get_name() for i in range(arm.num_input_ports())]
    assert names == ["pick_command", "robot_state", "target_sighting", "gripper_status",
                     "base_motion", "known_scene"]
    for i in range(arm.num_input_ports()):
        port = arm.get_input_port(i)
        if port.get_data_type() == PortDataType.kAbstractValued:
            value = port.Allocate().get_value()
            assert not isinstance(value, DishPoses | DishStates), port.get_name()


def test_ports_and_idle_hold(scenario, scene):
    arm, context = _controller(scenario, scene)
    assert arm.GetInputPort("robot_state").size() == 2 * UR5E.num_positions
    assert arm.GetOutputPort("arm_desired_state").size() == 16
    # Before any update: the scenario's start (stowed, open); no command: idle.
    desired, grip, status = _outputs(arm, context)
    np.testing.assert_array_equal(desired, np.concatenate([STOWED, np.zeros(8)]))
    assert grip == GripEvent() and status == Status()
    # The first update takes the arm's configuration from the robot's state and holds it.
    bent = STOWED + np.array([0.1, -0.05, 0.05, 0.0, 0.0, 0.2, -0.01, -0.01])
    _fix_robot(arm, context, arm_q=bent)
    arm.GetInputPort("pick_command").FixValue(context, PickCommand())
    for t in (0.0, 0.01, 1.0):
        _step(arm, context, t)
        desired, _, status = _outputs(arm, context)
        np.testing.assert_allclose(desired, np.concatenate([bent, np.zeros(8)]))
        assert status.state is CommandState.IDLE


def test_pickup_plays_grips_places_and_ends_done(scenario, scene):
    arm, context = _controller(scenario, scene, noise=False)
    _fix_robot(arm, context)
    arm.GetInputPort("pick_command").FixValue(context, PickCommand(id=1, dish="plate_a"))
    t0 = 0.5
    record = _play(arm, context, t0)
    _, first, _, status = record[0]
    assert status == Status(1, CommandState.RUNNING)
    np.testing.assert_allclose(first[:8], STOWED, atol=1e-9)  # starts where the arm is
    held = [r[0] for r in record if r[2].dish == "plate_a"]
    assert held, "the gripper never held the plate"
    # Held over one contiguous stretch in the middle of the motion, not at the ends.
    assert held == [r[0] for r in record if held[0] <= r[0] <= held[-1]]
    assert t0 < held[0] and held[-1] < record[-1][0]
    assert all(r[2].placed == () for r in record if r[0] <= held[-1])
    t_end, last, grip, status = record[-1]
    assert status == Status(1, CommandState.DONE)
    assert grip == GripEvent("", ("plate_a",))
    np.testing.assert_allclose(last, np.concatenate([STOWED, np.zeros(8)]), atol=1e-9)
    assert 3.0 < t_end - t0 < 40.0
    # The fingers close while the plate is held: where the grip starts, they are shut.
    closed = next(r[1] for r in record if r[0] == held[0])
    np.testing.assert_allclose(closed[6:8], 0.0, atol=1e-6)
    # Afterwards the arm holds still, and the same command is not run again.
    _step(arm, context, t_end + 1.0)
    desired, grip, status = _outputs(arm, context)
    np.testing.assert_allclose(desired, last)
    assert status == Status(1, CommandState.DONE) and grip.placed == ("plate_a",)


def _grasp_point(arm, context, scene, base, dish):
    """World position of the grasp frame when the gripper first holds `dish`."""
    for _, desired, grip, _ in _play(arm, context, 0.0):
        if grip.dish == dish:
            return scene.grasp_pose(np.concatenate([base, desired[:8]])).translation()
    raise AssertionError("never held")


def test_grasp_aims_where_the_sensor_sees_the_dish(scenario, scene):
    p_rim = np.array([1.85, 2.3 - DISH_SHAPES["plate"].radius + RIM_INSET])
    points = {}
    for shift in (0.0, 0.03):
        arm, context = _controller(scenario, scene, noise=False)
        _fix_robot(arm, context)
        arm.GetInputPort("pick_command").FixValue(context, PickCommand(id=1, dish="plate_a"))
        # It asks the robot's sensor where the plate is, and aims at the answer.
        assert arm.GetOutputPort("target_request").Eval(context) == TargetRequest(1, "plate_a")
        arm.GetInputPort("target_sighting").FixValue(
            context, TargetSighting(1, "plate_a", (1.85 + shift, 2.3)))
        points[shift] = _grasp_point(arm, context, scene, FRONT_OF_PLATE, "plate_a")
    # The near rim, pinched: the checker's IK is within 1 cm of its target.
    np.testing.assert_allclose(points[0.0][:2], p_rim, atol=0.01)
    np.testing.assert_allclose(points[0.03][:2] - points[0.0][:2], [0.03, 0.0], atol=0.01)


def test_a_pickup_waits_for_the_answer_to_its_own_request(scenario, scene):
    arm, context = _controller(scenario, scene, noise=False)
    _fix_robot(arm, context)
    arm.GetInputPort("pick_command").FixValue(context, PickCommand(id=2, dish="plate_a"))
    # An answer to an earlier request is no answer: nothing starts.
    arm.GetInputPort("target_sighting").FixValue(context,
                                                  TargetSighting(1, "plate_a", (1.85, 2.3)))
    _step(arm, context, 0.0)
    assert _outputs(arm, context)[2] == Status()
    arm.GetInputPort("target_sighting").FixValue(context,
                                                  TargetSighting(2, "plate_a", (1.85, 2.3)))
    _step(arm, context, 0.01)
    assert _outputs(arm, context)[2] == Status(2, CommandState.RUNNING, sighted=True)
    # A target the sensor does not see fails by name.
    arm2, context2 = _controller(scenario, scene, noise=False)
    _fix_robot(arm2, context2)
    arm2.GetInputPort("pick_command").FixValue(context2, PickCommand(id=3, dish="plate_a"))
    arm2.GetInputPort("target_sighting").FixValue(context2, TargetSighting(3, "plate_a", None))
    _step(arm2, context2, 0.0)
    assert _outputs(arm2, context2)[2] == Status(3, CommandState.FAILED, "unknown_dish")


def test_base_too_far_fails_with_a_reason(scenario, scene):
    arm, context = _controller(scenario, scene, noise=False)
    _fix_robot(arm, context, base=FRONT_OF_PLATE - np.array([0.0, 1.3, 0.0]))  # 2.15 m away
    arm.GetInputPort("pick_command").FixValue(context, PickCommand(id=4, dish="plate_a"))
    _step(arm, context, 0.0)
    desired, grip, status = _outputs(arm, context)
    assert status.id == 4 and status.state is CommandState.FAILED
    assert status.reason in PLANNING_REASONS
    np.testing.assert_allclose(desired, np.concatenate([STOWED, np.zeros(8)]))
    assert grip == GripEvent()
    # Unknown dishes fail by name, too.
    arm.GetInputPort("pick_command").FixValue(context, PickCommand(id=5, dish="teapot"))
    _step(arm, context, 0.01)
    assert _outputs(arm, context)[2] == Status(5, CommandState.FAILED, "unknown_dish")


def test_a_dish_the_robot_does_not_know_of_is_not_picked(scenario, scene):
    """The arm plans in the world as the robot knows it: without a scene (no plan yet) a
    command fails "no_scene"; a dish that is not in the scene fails "unknown_dish", though
    the sensor would see it."""
    params = dataclasses.replace(arm_params(scenario, noise=False), motion="stop_and_go")
    arm = ArmController(robot=scene.robot, params=params)
    context = arm.CreateDefaultContext()
    _fix_robot(arm, context)
    arm.GetInputPort("pick_command").FixValue(context, PickCommand(id=1, dish="plate_a"))
    arm.GetInputPort("target_sighting").FixValue(context,
                                                 TargetSighting(1, "plate_a", (1.85, 2.3)))
    _step(arm, context, 0.0)
    assert _outputs(arm, context)[2] == Status(1, CommandState.FAILED, "no_scene")
    without = FeasibilityScene(dataclasses.replace(scene.contents, dishes=tuple(
        d for d in scene.contents.dishes if d.name != "plate_a")))
    arm.GetInputPort("known_scene").FixValue(context, AbstractValue.Make(KnownScene(without)))
    arm.GetInputPort("pick_command").FixValue(context, PickCommand(id=2, dish="plate_a"))
    _step(arm, context, 0.01)
    assert _outputs(arm, context)[2] == Status(2, CommandState.FAILED, "unknown_dish")


def test_grasp_tolerances_follow_the_gripper_geometry():
    tolerance = functools.partial(grasp_tolerance, robot=load_robot("ur5e"))
    assert tolerance("cup") == pytest.approx(0.07 - 0.045)
    for kind in ("plate", "bowl"):
        assert 0.02 < tolerance(kind) <= 0.07 - RIM_INSET
    assert tolerance("bowl") < tolerance("plate")


def test_a_gripper_that_reports_no_object_is_a_miss(scenario, scene):
    """Whether the fingers hold the dish is the robot's to say, after they close: nothing
    detected, the pickup fails "missed", the grip lets go, and nothing lands on the tray."""
    outcomes = {}
    for detected in (True, False):
        arm, context = _controller(scenario, scene, noise=False)
        _fix_robot(arm, context)
        arm.GetInputPort("pick_command").FixValue(context, PickCommand(1, "plate_a"))
        arm.GetInputPort("gripper_status").FixValue(context, GripperStatus(detected))
        record = _play(arm, context, 0.0, dt=0.02)
        held = [r[2].dish for r in record]
        outcomes[detected] = record[-1][3], record[-1][2], held
    status, grip, held = outcomes[True]
    assert status == Status(1, CommandState.DONE) and grip.placed == ("plate_a",)
    status, grip, held = outcomes[False]
    assert status == Status(1, CommandState.FAILED, "missed") and grip == GripEvent()
    # It closed on the plate, and let go once the report came.
    closed = [i for i, dish in enumerate(held) if dish == "plate_a"]
    assert closed and held[closed[-1] + 1:] and not any(held[closed[-1] + 1:])
    assert len(closed) * 0.02 <= GRIP_REPORT_TIMEOUT + 0.02


def test_same_seed_and_id_give_the_same_pickup(scenario, scene):
    """The planner's seed comes from the seed and the command id alone."""
    runs = []
    for _ in range(2):
        arm, context = _controller(scenario, scene, seed=3)
        _fix_robot(arm, context)
        arm.GetInputPort("pick_command").FixValue(context, PickCommand(7, "plate_a"))
        _step(arm, context, 0.0)
        context.SetTime(2.0)
        desired, _, status = _outputs(arm, context)
        runs.append((status, desired.copy()))
    assert runs[0][0] == runs[1][0]
    np.testing.assert_array_equal(runs[0][1], runs[1][1])


# ------------------------------------------------------------------------ placing

@pytest.fixture(scope="module")
def tidy(scenario):
    """two_dishes with the cup to put onto the plate, which stays; the scene holds the
    cup's place target (a cup standing on the plate)."""
    plate, cup = scenario.dishes
    scenario = dataclasses.replace(scenario, dishes=[
        dataclasses.replace(plate, goal="stay"),
        dataclasses.replace(cup, goal="place", place=PlaceSpot(onto="plate_a"))])
    return scenario, FeasibilityScene(with_place_targets(scenario).contents)


def test_an_object_to_place_is_held_then_put_down_at_its_place(tidy):
    scenario, scene = tidy
    arm, context = _controller(scenario, scene, noise=False)
    _fix_robot(arm, context)
    arm.GetInputPort("pick_command").FixValue(context, PickCommand(id=1, dish="cup_b"))
    record = _play(arm, context, 0.0)
    t_end, last, grip, status = record[-1]
    # Picked and kept: still in the gripper, not on the tray.
    assert status == Status(1, CommandState.DONE)
    assert grip == GripEvent("cup_b") and all(r[2].placed == () for r in record)
    np.testing.assert_allclose(last[6:8], 0.0, atol=1e-6)  # the fingers stay closed
    # The gripper is busy: another pickup fails; a place of what it does not hold too.
    q_held = np.concatenate([FRONT_OF_PLATE, last[:8]])
    arm.GetInputPort("robot_state").FixValue(
        context, np.concatenate([q_held, np.zeros(UR5E.num_positions)]))
    arm.GetInputPort("pick_command").FixValue(context, PickCommand(id=2, dish="plate_a"))
    _step(arm, context, t_end + 0.1)
    assert _outputs(arm, context)[2] == Status(2, CommandState.FAILED, "hand_full")
    arm.GetInputPort("pick_command").FixValue(
        context, PickCommand(id=3, dish="plate_a", place=True))
    _step(arm, context, t_end + 0.2)
    assert _outputs(arm, context)[2] == Status(3, CommandState.FAILED, "unknown_dish")
    # Put down onto the plate: the gripper lets go at the cup's place, and ends open.
    arm.GetInputPort("pick_command").FixValue(context, PickCommand(id=4, dish="cup_b",
                                                                   place=True))
    record = _play(arm, context, t_end + 0.3)
    assert record[0][3] == Status(4, CommandState.RUNNING)
    held = [r for r in record if r[2].dish == "cup_b"]
    assert held and held[0] is record[0]  # held from the start until the release
    _, desired, grip, status = record[-1]
    assert status == Status(4, CommandState.DONE)
    assert grip == GripEvent("", (), ("cup_b",))
    np.testing.assert_allclose(desired[6:8], UR5E.gripper_open, atol=1e-6)
    # Where it let go: the grasp frame as at a grasp of the place target, the cup
    # standing on the plate's top.
    release = next(r for r in record if r[2].put)[1]
    X_WG = scene.grasp_pose(np.concatenate([FRONT_OF_PLATE, release[:8]]))
    target = next(d for d in scene.dishes.values() if d.name == "cup_b__place")
    assert target.position == [1.85, 2.3]
    np.testing.assert_allclose(X_WG.translation()[:2], target.position, atol=0.005)
    # A place needs the object in the gripper.
    arm.GetInputPort("pick_command").FixValue(context, PickCommand(id=5, dish="cup_b",
                                                                   place=True))
    _step(arm, context, record[-1][0] + 0.1)
    assert _outputs(arm, context)[2] == Status(5, CommandState.FAILED, "not_held")


def test_an_object_to_place_whose_place_failed_is_let_go_over_the_tray(tidy):
    """Named again without `place` while held, the object is let go where the arm holds it,
    above the tray: it lands there, the fingers open and the gripper is free."""
    scenario, scene = tidy
    arm, context = _controller(scenario, scene, noise=False)
    _fix_robot(arm, context)
    arm.GetInputPort("pick_command").FixValue(context, PickCommand(id=1, dish="cup_b"))
    t_end, last, grip, _ = _play(arm, context, 0.0)[-1]
    assert grip == GripEvent("cup_b")
    _fix_robot(arm, context, arm_q=last[:8])
    arm.GetInputPort("pick_command").FixValue(context, PickCommand(id=2, dish="cup_b"))
    record = _play(arm, context, t_end + 0.1)
    assert record[0][2].dish == "cup_b"  # held until the fingers have opened
    _, desired, grip, status = record[-1]
    assert status == Status(2, CommandState.DONE)
    assert grip == GripEvent("", ("cup_b",))  # on the tray
    np.testing.assert_allclose(desired[:6], UR5E.arm_stow, atol=1e-6)
    np.testing.assert_allclose(desired[6:8], UR5E.gripper_open, atol=1e-6)
    # The gripper is free: a pickup may follow.
    _fix_robot(arm, context, arm_q=desired[:8])
    arm.GetInputPort("pick_command").FixValue(context, PickCommand(id=3, dish="plate_a"))
    _step(arm, context, record[-1][0] + 0.1)
    assert _outputs(arm, context)[2].reason != "hand_full"


# ------------------------------------------------------------------------- simulated

def _permutation() -> np.ndarray:
    """[base q 3, base v 3, arm q 8, arm v 8] -> [q 11, v 11] (the plant's desired state)."""
    order = np.concatenate([np.arange(0, 3), np.arange(6, 14), np.arange(3, 6),
                            np.arange(14, 22)])
    P = np.zeros((22, 22))
    P[np.arange(22), order] = 1.0
    return P


def test_simulated_pickup_is_tracked_and_ends_done(scenario, scene):
    start = dataclasses.replace(scenario, robot=dataclasses.replace(
        scenario.robot, start=list(FRONT_OF_PLATE)))
    builder = DiagramBuilder()
    world = builder.AddNamedSystem("world", build_world_diagram(start, track_dishes=True,
                                                                noise=False))
    arm = builder.AddNamedSystem("arm_controller", ArmController(
        robot=scene.robot,
        params=dataclasses.replace(arm_params(start, noise=False), motion="stop_and_go")))
    known = builder.AddSystem(ConstantValueSource(AbstractValue.Make(KnownScene(scene))))
    command = builder.AddSystem(ConstantValueSource(
        AbstractValue.Make(PickCommand(id=1, dish="plate_a"))))
    base = builder.AddSystem(ConstantVectorSource(np.concatenate([FRONT_OF_PLATE, np.zeros(3)])))
    mux = builder.AddSystem(Multiplexer([6, 16]))
    gain = builder.AddSystem(MatrixGain(_permutation()))
    builder.Connect(command.get_output_port(), arm.GetInputPort("pick_command"))
    builder.Connect(known.get_output_port(), arm.GetInputPort("known_scene"))
    builder.Connect(world.GetOutputPort("robot_state"), arm.GetInputPort("robot_state"))
    builder.Connect(world.GetOutputPort("target_sighting"), arm.GetInputPort("target_sighting"))
    builder.Connect(arm.GetOutputPort("target_request"), world.GetInputPort("target_request"))
    builder.Connect(world.GetOutputPort("gripper_status"), arm.GetInputPort("gripper_status"))
    builder.Connect(arm.GetOutputPort("grip"), world.GetInputPort("grip"))
    builder.Connect(base.get_output_port(), mux.get_input_port(0))
    builder.Connect(arm.GetOutputPort("arm_desired_state"), mux.get_input_port(1))
    builder.Connect(mux.get_output_port(), gain.get_input_port())
    builder.Connect(gain.get_output_port(), world.GetInputPort("robot_desired_state"))
    period = 0.02
    desired_log = builder.AddSystem(VectorLogSink(16, period))
    state_log = builder.AddSystem(VectorLogSink(2 * UR5E.num_positions, period))
    builder.Connect(arm.GetOutputPort("arm_desired_state"), desired_log.get_input_port())
    builder.Connect(world.GetOutputPort("robot_state"), state_log.get_input_port())
    diagram = builder.Build()

    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    arm_context = arm.GetMyContextFromRoot(context)
    simulator.Initialize()
    simulator.AdvanceTo(0.05)  # plans at t = 0
    assert arm.GetOutputPort("status").Eval(arm_context) == Status(1, CommandState.RUNNING,
                                                                   sighted=True)
    wall = time.perf_counter()
    t_end = 0.05
    while not arm.GetOutputPort("status").Eval(arm_context).finished and t_end < 40.0:
        t_end += 1.0
        simulator.AdvanceTo(t_end)
    wall = time.perf_counter() - wall
    print(f"\nsimulated {t_end - 0.05:.2f} s in {wall:.2f} s: real-time rate "
          f"{(t_end - 0.05) / wall:.2f}")
    assert arm.GetOutputPort("status").Eval(arm_context) == Status(1, CommandState.DONE,
                                                                   sighted=True)
    assert arm.GetOutputPort("grip").Eval(arm_context).placed == ("plate_a",)

    desired = desired_log.FindLog(context).data()
    actual = state_log.FindLog(context).data()[3:UR5E.num_positions]
    # Arm joints (not the fingers, which the dish stops in the real world).
    error = np.abs(actual[:6] - desired[:6]).max()
    print(f"largest arm tracking error: {error:.4f} rad")
    # The discrete plant follows one step behind: at most the arm's top speed x the step.
    speed = np.abs(desired[8:14]).max(axis=0)
    assert error < speed.max() * start.plant.time_step + 0.005
    # The arm rests while the fingers close and open; the grasp and the release happen at
    # the ends of those rests, by when the arm has settled where the path put it.
    errors = np.abs(actual[:6] - desired[:6]).max(axis=0)
    at_rest = speed == 0.0
    moving = np.flatnonzero(~at_rest)
    during = np.arange(moving[0], moving[-1] + 1)  # first to last moving sample
    runs = np.split(during, np.flatnonzero(np.diff(at_rest[during])) + 1)
    rests = [run for run in runs if at_rest[run[0]]]
    assert len(rests) == 2  # close, release
    for run in rests:
        assert errors[run].max() < 0.002
        assert errors[run[-1]] < 1e-4
    # The base stays put while the arm works.
    base_drift = np.abs(state_log.FindLog(context).data()[:3] - FRONT_OF_PLATE[:, None]).max()
    assert base_drift < 0.01
    states = world.GetOutputPort("dish_states").Eval(world.GetMyContextFromRoot(context))
    assert states["plate_a"] is DishState.TRAY and states["cup_b"] is DishState.TABLE


def test_an_object_to_place_is_picked_with_a_grasp_it_can_be_put_down_with():
    """tidy_home's apple, picked from (2.4, 4.0) facing west where a top and a side grasp
    both work (top is tried first), is to be put down on the plate from (4.95, 2.7), the
    plate's far side, where only a side grasp reaches. The hand never re-grasps: told the
    place's stop, the pickup takes the side grasp and the place succeeds; not told, it
    takes the top grasp and the place fails no_ik."""
    tidy = load_scenario(REPO / "scenarios" / "tidy_home.yaml")
    scene = FeasibilityScene(with_place_targets(tidy).contents)
    checker = FeasibilityChecker(scene)
    pick_at, place_at = np.array([2.4, 4.0, math.pi]), (4.95, 2.7, math.pi / 2)
    assert place_grasps(scene, checker, np.array(place_at), "apple__place") == ["side"]
    for told, outcome in ((True, Status(2, CommandState.DONE)),
                          (False, Status(2, CommandState.FAILED, "no_ik"))):
        arm, context = _controller(tidy, scene, noise=False)
        _fix_robot(arm, context, base=pick_at)
        arm.GetInputPort("pick_command").FixValue(context, PickCommand(
            id=1, dish="apple", place_from=place_at if told else None))
        t_end, last, grip, status = _play(arm, context, 0.0)[-1]
        assert status == Status(1, CommandState.DONE) and grip.dish == "apple"
        _fix_robot(arm, context, base=np.array(place_at), arm_q=last[:8])
        arm.GetInputPort("pick_command").FixValue(context, PickCommand(id=2, dish="apple",
                                                                       place=True))
        assert _play(arm, context, t_end + 0.1)[-1][3] == outcome


def test_a_place_grasp_is_rated_by_the_landings_at_the_place():
    """From (5.5, 3.75) facing the plate only a top grasp puts the apple down, from
    (4.95, 2.7) only a side grasp: landings that put the base twice at the second and once
    at the first rank the side grasp first; the stop alone ranks only the top grasp."""
    tidy = with_place_targets(load_scenario(REPO / "scenarios" / "tidy_home.yaml"))
    scene = FeasibilityScene(tidy.contents)
    checker = FeasibilityChecker(scene)
    stop = np.array([5.5, 3.75, math.pi])
    assert place_grasps(scene, checker, stop, "apple__place") == ["top"]
    landings = np.array([[0.0, 0.0, 0.0], [-0.55, -1.05, 0.0], [-0.55, -1.05, 0.01]])
    assert place_grasps(scene, checker, stop, "apple__place",
                        landing_noise=landings) == ["side", "top"]
    assert place_grasps(scene, checker, stop, "apple__place",
                        landing_noise=landings[:1]) == ["top"]


# ------------------------------------------------------------------------- smooth motion
@dataclasses.dataclass(frozen=True)
class _BaseMotion:
    """A base motion as the navigator's `base_motion` port gives it: command `id`, standing
    at `pose` until `end_time` (its approach does not matter here)."""

    id: int
    end_time: float
    pose: tuple[float, float, float] = tuple(FRONT_OF_PLATE)

    def desired(self, t):
        return np.array([*self.pose, 0.0, 0.0, 0.0])


def test_smooth_a_pickup_is_done_once_lifted_and_its_motion_plays_on(scenario, scene):
    """The base may leave once the plate is lifted: the status says done then, and when the
    arm's motion (to the tray, letting go, the stow) ends; `arm_motion` says the same."""
    arm, context = _controller(scenario, scene, noise=False, motion="smooth")
    _fix_robot(arm, context)
    arm.GetInputPort("pick_command").FixValue(context, PickCommand(id=1, dish="plate_a"))
    t_done, _, grip, status = _play(arm, context, 0.5)[-1]
    assert status.state is CommandState.DONE and grip.dish == "plate_a"  # held, lifted
    assert status.until > t_done + 1.0
    motion = arm.GetOutputPort("arm_motion").Eval(context)
    assert motion.end_time == pytest.approx(status.until) and motion.dish == "plate_a"
    assert motion.touching(t_done) == "plate_a" and motion.touching(status.until) == ""
    _step(arm, context, status.until + 0.05)
    desired, grip, after = _outputs(arm, context)
    assert grip == GripEvent("", ("plate_a",)) and after == status
    np.testing.assert_allclose(desired[:8], STOWED, atol=1e-9)


def test_smooth_a_pickup_another_follows_leaves_the_arm_over_the_tray(scenario, scene):
    """Without the stow the arm ends over the tray, fingers open, and the next pickup
    starts from there."""
    arm, context = _controller(scenario, scene, noise=False, motion="smooth")
    _fix_robot(arm, context)
    arm.GetInputPort("pick_command").FixValue(
        context, PickCommand(id=1, dish="plate_a", stow=False))
    status = _play(arm, context, 0.0)[-1][3]
    _step(arm, context, status.until + 0.05)
    over_tray = _outputs(arm, context)[0][:8].copy()
    assert np.abs(over_tray[:6] - UR5E.arm_stow).max() > 0.1
    np.testing.assert_allclose(over_tray[6:], UR5E.gripper_open, atol=1e-6)
    _fix_robot(arm, context, arm_q=over_tray)  # where the plant's arm then is
    arm.GetInputPort("pick_command").FixValue(context, PickCommand(id=2, dish="cup_b"))
    _step(arm, context, status.until + 0.1)
    np.testing.assert_allclose(_outputs(arm, context)[0][:8], over_tray, atol=1e-9)
    assert _outputs(arm, context)[2].state is CommandState.RUNNING


def test_smooth_a_prepare_reaches_the_pre_grasp_as_the_base_arrives(scenario, scene):
    """A prepare waits for the navigator to take its base command, then starts so that the
    arm reaches the plate's pre-grasp (the hand above the plate) as the base's motion ends,
    and holds there."""
    arm, context = _controller(scenario, scene, noise=False, motion="smooth")
    _fix_robot(arm, context)
    command = PickCommand(id=3, dish="plate_a", prepare=tuple(FRONT_OF_PLATE), base_id=2)
    arm.GetInputPort("pick_command").FixValue(context, command)
    port = arm.GetInputPort("base_motion")
    port.FixValue(context, AbstractValue.Make(_BaseMotion(id=1, end_time=0.0)))
    _step(arm, context, 0.0)
    assert _outputs(arm, context)[2] == Status()  # not the base motion it is timed by
    port.FixValue(context, AbstractValue.Make(_BaseMotion(id=2, end_time=10.0)))
    _step(arm, context, 0.05)
    motion = arm.GetOutputPort("arm_motion").Eval(context)
    assert motion.end_time == pytest.approx(10.0)
    assert 0.05 < motion.t_start < 9.5
    np.testing.assert_allclose(_outputs(arm, context)[0][:8], STOWED, atol=1e-9)
    _step(arm, context, 10.0)
    desired, _, status = _outputs(arm, context)
    assert status.state is CommandState.DONE and status.id == 3
    hand = scene.grasp_pose(np.concatenate([FRONT_OF_PLATE, desired[:8]])).translation()
    assert np.linalg.norm(hand[:2] - [1.85, 2.3]) < 0.15 and hand[2] > 0.78  # at its rim


@pytest.mark.parametrize("held_at, plays_on", [
    ((1.85, 1.62, math.pi / 2), False),  # 17 cm nearer the table: the reach runs into it
    ((1.85, 1.45, math.pi / 2 - 0.8), True)])  # turned from it: the reach is clear
def test_smooth_a_prepare_whose_base_is_held_short_stops_where_it_would_collide(
        scenario, scene, held_at, plays_on):
    """Halfway through a prepare the navigator's motion changes (the robot's protective stop
    held the base short of its stop). The rest of the prepare is checked with the base
    where it now stands: where the two collide the arm stops where it is and the prepare
    fails ("base_moved"); where they do not, it plays on to its end."""
    arm, context = _controller(scenario, scene, noise=False, motion="smooth")
    _fix_robot(arm, context)
    arm.GetInputPort("pick_command").FixValue(
        context, PickCommand(id=3, dish="plate_a", prepare=tuple(FRONT_OF_PLATE), base_id=2))
    port = arm.GetInputPort("base_motion")
    port.FixValue(context, AbstractValue.Make(_BaseMotion(id=2, end_time=4.0)))
    _step(arm, context, 0.05)
    planned = arm.GetOutputPort("arm_motion").Eval(context)
    halfway = (planned.t_start + planned.end_time) / 2
    _step(arm, context, halfway)
    port.FixValue(context, AbstractValue.Make(_BaseMotion(id=2, end_time=4.0, pose=held_at)))
    _step(arm, context, halfway + 0.05)
    status = _outputs(arm, context)[2]
    if plays_on:
        assert status == Status(3, CommandState.RUNNING)
        _step(arm, context, 4.0)
        assert _outputs(arm, context)[2].state is CommandState.DONE
        return
    assert status == Status(3, CommandState.FAILED, "base_moved")
    stopped = _outputs(arm, context)[0][:8].copy()
    np.testing.assert_allclose(stopped, planned.arm_at(halfway + 0.05), atol=1e-9)
    _step(arm, context, 4.0)
    np.testing.assert_allclose(_outputs(arm, context)[0][:8], stopped, atol=1e-9)  # held


def test_smooth_a_stow_command_stows(scenario, scene):
    arm, context = _controller(scenario, scene, noise=False, motion="smooth")
    bent = STOWED + np.array([0.3, -0.2, 0.1, 0.0, 0.0, 0.0, 0.0, 0.0])
    _fix_robot(arm, context, arm_q=bent)
    arm.GetInputPort("pick_command").FixValue(context, PickCommand(id=4, to_stow=True))
    t_end, desired, _, status = _play(arm, context, 0.0)[-1]
    assert status == Status(4, CommandState.DONE) and status.until == pytest.approx(t_end, abs=0.06)
    np.testing.assert_allclose(desired[:8], STOWED, atol=1e-9)
