"""BaseNavigator: drives a command's path at v, lands with the seeded noise, stops short of
collisions; alone (forced updates, Eval at chosen times) and driving the world's plant."""

import dataclasses
import math
import time

import numpy as np
import pytest
from pydrake.common.value import AbstractValue
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import (
    ConstantValueSource,
    ConstantVectorSource,
    MatrixGain,
    Multiplexer,
)
from pydrake.trajectories import PiecewisePolynomial

from s3o_drake.execution.base_navigator import BaseNavigator
from s3o_drake.execution.controllers import navigator_params
from s3o_drake.execution.messages import (
    ArmMotion,
    BaseCommand,
    CommandState,
    KnownScene,
    Status,
)
from s3o_drake.world.angles import wrap as wrap_angle
from s3o_drake.world.builder import build_world_diagram
from s3o_drake.world.robot import load_robot

UR5E = load_robot("ur5e")

V = 0.4  # the scenario's planner speed (default)
STOWED = np.concatenate([UR5E.arm_stow, UR5E.gripper_open])


def _robot_state(x: float, y: float, yaw: float) -> np.ndarray:
    state = np.zeros(2 * UR5E.num_positions)
    state[:3] = [x, y, yaw]
    return state


class _Alone:
    """A navigator with fixed inputs; `send` forces its update at `t`, `at` Evals."""

    def __init__(self, navigator: BaseNavigator, base=(0.6, 0.6, 0.0), scene=None):
        self.navigator = navigator
        self.context = navigator.CreateDefaultContext()
        navigator.GetInputPort("robot_state").FixValue(self.context, _robot_state(*base))
        if scene is not None:  # what the robot knows; else its motions are not checked
            navigator.GetInputPort("known_scene").FixValue(
                self.context, AbstractValue.Make(KnownScene(scene)))
        self.send(BaseCommand(), t=0.0)

    def send(self, command: BaseCommand, t: float = 0.0) -> None:
        self.context.SetTime(t)
        self.navigator.GetInputPort("base_command").FixValue(
            self.context, AbstractValue.Make(command))
        self.navigator.CalcForcedUnrestrictedUpdate(self.context,
                                                    self.context.get_mutable_state())

    def at(self, t: float) -> tuple[np.ndarray, Status]:
        self.context.SetTime(t)
        desired = self.navigator.GetOutputPort("base_desired_state").Eval(self.context)
        return desired.copy(), self.navigator.GetOutputPort("status").Eval(self.context)

    def final(self) -> tuple[np.ndarray, Status]:
        return self.at(1e3)


def _navigator(scenario, *, seed=None, noise=False, motion=None,
               **changes) -> BaseNavigator:
    """A navigator of `scenario` (without noise unless asked; with its motion unless
    `motion` says), `changes` made to its params."""
    params = navigator_params(scenario, seed=seed, noise=noise)
    if motion is not None:
        changes["profile"] = dataclasses.replace(params.profile, motion=motion)
    return BaseNavigator(robot=scenario.robot_value,
                         params=dataclasses.replace(params, **changes))


def test_ports_and_no_feedthrough(scenario):
    navigator = _navigator(scenario)
    assert navigator.GetInputPort("robot_state").size() == 22
    assert navigator.GetOutputPort("base_desired_state").size() == 6
    # The plant's state feeds back into robot_state: no algebraic loop.
    assert not navigator.HasAnyDirectFeedthrough()


def test_without_command_holds_the_initial_base_pose(scenario):
    alone = _Alone(_navigator(scenario), base=(1.0, 2.0, 0.3))
    desired, status = alone.at(5.0)
    np.testing.assert_allclose(desired, [1.0, 2.0, 0.3, 0, 0, 0])
    assert status == Status()


def test_drives_the_path_at_v_and_lands_on_the_pose(scenario):
    assert scenario.planner.speed == V
    alone = _Alone(_navigator(scenario, motion="stop_and_go"))
    # An L: east 1 m, then north 1 m, then face west.
    command = BaseCommand(id=1, path=((0.6, 0.6), (1.6, 0.6), (1.6, 1.6)),
                          pose=(1.6, 1.6, math.pi))
    alone.send(command)
    # Mid first leg (already facing east): cruising at v along +x.
    a, status = alone.at(1.5)
    b, _ = alone.at(2.0)
    assert status.id == 1 and status.state is CommandState.RUNNING
    np.testing.assert_allclose(a[3:], [V, 0, 0], atol=1e-12)
    assert b[0] - a[0] == pytest.approx(0.5 * V)
    assert a[1] == pytest.approx(0.6) and a[2] == pytest.approx(0.0)
    final, status = alone.final()
    np.testing.assert_allclose(final[:2], command.pose[:2], atol=1e-3)
    assert wrap_angle(final[2] - math.pi) == pytest.approx(0.0, abs=1e-9)
    np.testing.assert_allclose(final[3:], 0.0)
    assert status == Status(id=1, state=CommandState.DONE)

    # The pose stays on the path (x = 0.6 -> 1.6 at y = 0.6, then y up at x = 1.6) and
    # yaw only turns (0 -> pi/2 -> pi) while xy stands still.
    poses = np.array([alone.at(t)[0] for t in np.arange(0.0, 12.0, 0.05)])
    on_first = np.isclose(poses[:, 1], 0.6)
    on_second = np.isclose(poses[:, 0], 1.6)
    assert np.all(on_first | on_second)
    moving_xy = np.hypot(poses[:, 3], poses[:, 4]) > 0
    assert not np.any(moving_xy & (np.abs(poses[:, 5]) > 0))
    assert np.all(np.abs(poses[:, 5]) <= 0.8 + 1e-12)
    assert np.all(np.hypot(poses[:, 3], poses[:, 4]) <= V + 1e-12)


def test_drives_through_a_corner_turning_as_it_goes(scenario):
    """Smooth motion: the same L without stopping at its corner, the base turning while it
    drives (within v and the yaw rate), lands on the pose, facing west, at rest."""
    alone = _Alone(_navigator(scenario, motion="smooth"))
    command = BaseCommand(id=1, path=((0.6, 0.6), (1.6, 0.6), (1.6, 1.6)),
                          pose=(1.6, 1.6, math.pi))
    alone.send(command)
    poses = np.array([alone.at(t)[0] for t in np.arange(0.0, 12.0, 0.02)])
    speed = np.hypot(poses[:, 3], poses[:, 4])
    assert np.any((speed > 0.1) & (np.abs(poses[:, 5]) > 0.1))  # turning on the move
    assert np.all(speed <= V + 1e-9) and np.all(np.abs(poses[:, 5]) <= 0.8 + 1e-9)
    final, status = alone.final()
    np.testing.assert_allclose(final[:2], command.pose[:2], atol=1e-3)
    assert wrap_angle(final[2] - math.pi) == pytest.approx(0.0, abs=1e-9)
    np.testing.assert_allclose(final[3:], 0.0)
    assert status == Status(id=1, state=CommandState.DONE)
    stop_and_go = _Alone(_navigator(scenario, motion="stop_and_go"))
    stop_and_go.send(command)
    assert alone.context.get_abstract_state(0).get_value().duration < \
        stop_and_go.context.get_abstract_state(0).get_value().duration - 1.0


def test_status_waits_for_the_settle_time(scenario):
    alone = _Alone(_navigator(scenario, settle_time=0.3))
    alone.send(BaseCommand(id=4, path=((0.6, 0.6), (1.0, 0.6)), pose=(1.0, 0.6, 0.0)))
    # 0.4 m with v = 0.4 m/s and 1 m/s^2 ramps: 1.4 s of motion.
    assert alone.at(1.35)[1].state is CommandState.RUNNING
    assert alone.at(1.6)[1].state is CommandState.RUNNING
    assert alone.at(1.75)[1] == Status(id=4, state=CommandState.DONE)


def test_command_id_0_stops_where_the_motion_is(scenario):
    alone = _Alone(_navigator(scenario))
    alone.send(BaseCommand(id=1, path=((0.6, 0.6), (2.6, 0.6)), pose=(2.6, 0.6, 0.0)))
    here, _ = alone.at(2.0)
    alone.send(BaseCommand(), t=2.0)
    final, status = alone.final()
    np.testing.assert_allclose(final, [*here[:3], 0, 0, 0])
    assert status == Status()
    # The same id again is no new command: nothing restarts.
    alone.send(BaseCommand(), t=3.0)
    np.testing.assert_allclose(alone.final()[0], final)


def test_turns_the_short_way_and_keeps_yaw_continuous(scenario):
    alone = _Alone(_navigator(scenario), base=(1.0, 1.0, 3.0))
    # Heading of the leg is -3.0 rad: the short way is +0.28 rad through pi.
    command = BaseCommand(id=1, path=((1.0, 1.0), (1.0 + math.cos(-3.0), 1.0 + math.sin(-3.0))),
                          pose=(1.0 + math.cos(-3.0), 1.0 + math.sin(-3.0), -3.0))
    alone.send(command)
    yaws = np.array([alone.at(t)[0][2] for t in np.arange(0.0, 8.0, 0.05)])
    assert np.all(np.diff(yaws) >= -1e-12)  # only counter-clockwise
    assert yaws[-1] == pytest.approx(2 * math.pi - 3.0)
    assert np.max(np.abs(np.diff(yaws))) < 0.8 * 0.05 + 1e-9


def test_landing_noise_is_seeded_per_command(scenario):
    command = BaseCommand(id=2, path=((0.6, 0.6), (1.5, 1.5)), pose=(1.5, 1.5, 0.5))
    rng = np.random.default_rng([7, 1, 2])
    std = scenario.uncertainty
    expected = np.array(command.pose) + rng.normal(0.0, 1.0, 3) * [
        std.nav_xy_std, std.nav_xy_std, std.nav_yaw_std]

    landings = []
    for earlier in (None, BaseCommand(id=1, path=((0.6, 0.6), (0.8, 0.6)), pose=(0.8, 0.6, 0))):
        alone = _Alone(_navigator(scenario, seed=7, noise=True))
        if earlier is not None:  # whatever happened before, command 2 lands the same
            alone.send(earlier)
        alone.send(command, t=5.0)
        final, status = alone.final()
        assert status == Status(id=2, state=CommandState.DONE)
        landings.append(final[:3])
    np.testing.assert_allclose(landings[0][:2], expected[:2], atol=1e-9)
    assert wrap_angle(landings[0][2] - expected[2]) == pytest.approx(0.0, abs=1e-9)
    np.testing.assert_allclose(landings[0], landings[1], atol=1e-9)
    assert np.linalg.norm(landings[0][:2] - command.pose[:2]) > 1e-3

    other = _Alone(_navigator(scenario, seed=8, noise=True))
    other.send(command)
    assert np.linalg.norm(other.final()[0][:2] - landings[0][:2]) > 1e-3


def test_a_landing_that_faces_a_point_keeps_only_the_heading_error(scenario):
    """With `face`, the same noisy landing's x, y, and its yaw that facing the point from
    there plus the yaw's noise: off the facing by the heading error alone, not by the drift
    in x, y as well."""
    dish = (2.4, 1.5)
    pose = (1.5, 1.5, 0.0)  # faces the dish from the commanded stop
    rng = np.random.default_rng([7, 1, 2])
    std = scenario.uncertainty
    noise = rng.normal(0.0, 1.0, 3) * [std.nav_xy_std, std.nav_xy_std, std.nav_yaw_std]
    alone = _Alone(_navigator(scenario, seed=7, noise=True))
    alone.send(BaseCommand(id=2, path=((0.6, 0.6), (1.5, 1.5)), pose=pose, face=dish))
    final, _ = alone.final()
    np.testing.assert_allclose(final[:2], np.array(pose[:2]) + noise[:2], atol=1e-9)
    facing = math.atan2(dish[1] - final[1], dish[0] - final[0])
    assert wrap_angle(final[2] - facing) == pytest.approx(noise[2], abs=1e-9)


def test_a_path_through_the_table_fails_blocked_before_it(scenario, scene):
    # The table spans x 1.4..2.6, y 2.1..2.9; drive straight across it along y = 2.5.
    alone = _Alone(_navigator(scenario), scene=scene, base=(0.6, 2.5, 0.0))
    alone.send(BaseCommand(id=3, path=((0.6, 2.5), (3.4, 2.5)), pose=(3.4, 2.5, 0.0)))
    final, status = alone.final()
    assert (status.id, status.state, status.reason) == (3, CommandState.FAILED, "blocked")
    # The bumper's reading: where the base touched the table, at its west edge (x = 1.4;
    # the deck fits under the top, so the plan views overlap a little), ahead of the base.
    x, y = status.contact
    assert 1.4 <= x < 1.5 and y == pytest.approx(2.5, abs=0.35)
    assert 0.9 < final[0] < 1.4  # stopped in front of the table (the deck fits under its top)
    assert final[1] == pytest.approx(2.5)
    q = scene.q(final[:3])
    assert scene.checker.CheckConfigCollisionFree(q)
    # Within one check step of the first colliding pose.
    assert not scene.checker.CheckConfigCollisionFree(scene.q(final[:3] + np.array([0.021, 0, 0])))
    # Running until the cut, then failed.
    assert alone.at(1.0)[1].state is CommandState.RUNNING


def test_a_colliding_landing_ends_done_at_the_last_free_pose(scenario, scene):
    # Facing the table's south edge (y = 2.1) from 1.9 m: the base's front overlaps it.
    alone = _Alone(_navigator(scenario), scene=scene, base=(2.0, 0.8, math.pi / 2))
    alone.send(BaseCommand(id=5, path=((2.0, 0.8), (2.0, 1.9)), pose=(2.0, 1.9, math.pi / 2)))
    final, status = alone.final()
    assert status == Status(id=5, state=CommandState.DONE)
    assert 1.4 < final[1] < 1.9 and final[0] == pytest.approx(2.0)
    assert scene.checker.CheckConfigCollisionFree(scene.q(final[:3]))


def test_a_chair_the_robot_knows_of_stops_the_base_and_one_it_does_not_know_of_does_not(
        scenario, scene):
    """The navigator checks in the world as the robot knows it (`known_scene`), not in the
    true one: a chair on the way that the robot perceived stops the drive; without it, the
    same drive is driven through."""
    from s3o_drake.feasibility.scene import FeasibilityScene
    from s3o_drake.world.map import Chair

    drive = BaseCommand(id=1, path=((0.6, 1.0), (3.0, 1.0)), pose=(3.0, 1.0, 0.0))
    chair = Chair(name="perceived_0", pose=[1.8, 1.0, 0.0], mapped=False)
    believed = FeasibilityScene(dataclasses.replace(
        scene.contents, chairs=(*scene.contents.chairs, chair)))
    finals = {}
    for name, known in (("with the chair", believed), ("without", scene)):
        alone = _Alone(_navigator(scenario, motion="stop_and_go"), scene=known,
                       base=(0.6, 1.0, 0.0))
        alone.send(drive)
        finals[name] = alone.final()
    (stopped, blocked), (driven, done) = finals["with the chair"], finals["without"]
    assert blocked.state is CommandState.FAILED and blocked.reason == "blocked"
    assert stopped[0] < 1.8 - 0.2
    assert done == Status(id=1, state=CommandState.DONE)
    np.testing.assert_allclose(driven[:3], [3.0, 1.0, 0.0], atol=1e-9)


def test_a_protective_stop_ends_the_motion_where_the_robot_stands(scenario):
    """The robot's protective stop holds the base: far from the end the command fails
    "blocked", with where the robot stopped short of as the contact; within FINAL_APPROACH
    of it, it is done (landed short). The base is held where the robot believes it
    stands."""
    drive = BaseCommand(id=1, path=((0.6, 1.0), (3.0, 1.0)), pose=(3.0, 1.0, 0.0))
    for t_stop, base, outcome in ((2.0, (1.3, 1.0, 0.0), CommandState.FAILED),
                                  (6.0, (2.7, 1.0, 0.0), CommandState.DONE)):
        alone = _Alone(_navigator(scenario, motion="stop_and_go"), base=(0.6, 1.0, 0.0))
        alone.navigator.GetInputPort("bumper").FixValue(alone.context, [0.0, np.nan, np.nan])
        alone.send(drive)
        alone.navigator.GetInputPort("bumper").FixValue(alone.context, [1.0, 1.6, 1.05])
        alone.navigator.GetInputPort("robot_state").FixValue(alone.context, _robot_state(*base))
        alone.context.SetTime(t_stop)
        alone.navigator.CalcForcedUnrestrictedUpdate(alone.context,
                                                     alone.context.get_mutable_state())
        final, status = alone.final()
        np.testing.assert_allclose(final[:3], base)
        assert status.id == 1 and status.state is outcome
        if outcome is CommandState.FAILED:
            assert status.reason == "blocked" and status.contact == (1.6, 1.05)
        else:
            assert status.reason == "" and status.contact is None


def test_free_path_with_scene_is_untouched(scenario, scene):
    alone = _Alone(_navigator(scenario), scene=scene)
    alone.send(BaseCommand(id=1, path=((0.6, 0.6), (3.0, 0.6)), pose=(3.0, 0.6, 0.0)))
    final, status = alone.final()
    np.testing.assert_allclose(final[:3], [3.0, 0.6, 0.0], atol=1e-9)
    assert status == Status(id=1, state=CommandState.DONE)


def test_backs_out_of_a_stop_too_tight_to_turn_in(scenario, scene):
    # Facing the table's south-west leg, 2 cm from touching: turning east, either way
    # round, swings a corner into the leg; backing straight out first leaves room.
    base = np.array([1.4, 1.78, math.pi / 2])
    free = lambda p: scene.checker.CheckConfigCollisionFree(scene.q(np.asarray(p, float)))  # noqa: E731
    assert free(base)
    turned = lambda a: base + np.array([0.0, 0.0, a])  # noqa: E731
    assert not all(free(turned(-a)) for a in np.arange(0.05, math.pi / 2, 0.05))
    assert not all(free(turned(a)) for a in np.arange(0.05, 1.5 * math.pi, 0.05))
    alone = _Alone(_navigator(scenario), scene=scene, base=tuple(base))
    alone.send(BaseCommand(id=4, path=((1.4, 1.78), (3.2, 1.2)), pose=(3.2, 1.2, 0.0)))
    final, status = alone.final()
    assert status == Status(id=4, state=CommandState.DONE)
    np.testing.assert_allclose(final[:3], [3.2, 1.2, 0.0], atol=1e-9)
    # It first drove straight back (yaw unchanged, y decreasing), then turned.
    early, _ = alone.at(0.5)
    assert early[2] == pytest.approx(math.pi / 2) and early[1] < 1.78 and early[4] < 0


def test_drives_straight_on_out_of_a_stop_it_can_neither_turn_in_nor_back_out_of(
        scenario, scene):
    """Facing south with its back under the table's edge (task_089: backed against the
    bar): every turn towards the path swings a corner into a leg, and backing out hits the
    table; it drives straight on, then turns."""
    base = np.array([1.3, 1.8, -math.pi / 2])
    free = lambda p: scene.checker.CheckConfigCollisionFree(scene.q(np.asarray(p, float)))  # noqa: E731
    assert free(base) and not free(base + np.array([0.0, 0.02, 0.0]))
    assert not all(free(base + np.array([0, 0, a])) for a in np.arange(0.05, math.pi / 2, 0.05))
    assert not all(free(base - [0, 0, a]) for a in np.arange(0.05, 1.5 * math.pi, 0.05))
    alone = _Alone(_navigator(scenario), scene=scene, base=tuple(base))
    alone.send(BaseCommand(id=7, path=((1.3, 1.8), (3.2, 1.2)), pose=(3.2, 1.2, 0.0)))
    final, status = alone.final()
    assert status == Status(id=7, state=CommandState.DONE)
    np.testing.assert_allclose(final[:3], [3.2, 1.2, 0.0], atol=1e-9)
    first = alone.navigator._motion(alone.context).segments[0]
    assert not first.turn and first.end[1] < 1.8 and first.end[2] == pytest.approx(-math.pi / 2)


def test_a_stop_it_cannot_turn_in_is_driven_into_along_its_heading(scenario, scene):
    """Arriving from the west at a stop facing north beside the table's south-west leg: the
    final turn there swings a corner into the leg. The base turns north 10 cm before and
    drives straight in, landing on the stop facing the dish (as Fea^m's landing model has
    it), not short and facing east."""
    stop = np.array([1.4, 1.78, math.pi / 2])
    free = lambda p: scene.checker.CheckConfigCollisionFree(scene.q(np.asarray(p, float)))  # noqa: E731
    assert free(stop) and not all(free(stop - [0, 0, a])
                                  for a in np.arange(0.05, math.pi / 2, 0.05))
    alone = _Alone(_navigator(scenario), scene=scene, base=(0.4, 1.78, 0.0))
    alone.send(BaseCommand(id=6, path=((0.4, 1.78), (1.4, 1.78)), pose=tuple(stop)))
    final, status = alone.final()
    assert status == Status(id=6, state=CommandState.DONE)
    np.testing.assert_allclose(final[:3], stop, atol=1e-9)
    segments = alone.navigator._motion(alone.context).segments
    last = segments[-1]
    assert not last.turn and last.start[2] == pytest.approx(math.pi / 2)
    assert last.start[1] == pytest.approx(1.68) and last.start[0] == pytest.approx(1.4)


def test_a_noisy_landing_is_reached_along_the_planned_leg(scenario, scene):
    """The stop (3.4, 1.72), east of the table, is planned along y = 1.72, clear of its
    south-east corner (2.6, 2.1); the noise puts the landing 0.28 m north. The straight
    drive to the landing swings the leg and clips the corner 1 m before the stop (blocked,
    as dense task_033 was); the base keeps to the planned leg and turns off it to the
    landing just before the stop (stopping and going; a smooth motion tries the same way,
    driving through its corners)."""

    class Landing(BaseNavigator):
        def _landing(self, command):
            return np.array([3.4, 2.0, 0.0])

    free = lambda p: scene.checker.CheckConfigCollisionFree(scene.q(np.asarray(p, float)))  # noqa: E731
    heading = math.atan2(2.0 - 1.72, 3.4 - 1.6)
    swung = [(x, 1.72 + (x - 1.6) * math.tan(heading), heading)
             for x in np.arange(1.6, 3.4, 0.02)]
    assert free((3.4, 2.0, 0.0)) and not all(free(p) for p in swung)
    assert not all(free(p) for p in swung if p[0] < 3.4 - 0.6)  # far from the stop
    # The path's last leg starts at a waypoint, where backing out or driving on first
    # (the escapes from a tight start) changes nothing.
    params = navigator_params(scenario, noise=False)
    stop_and_go = dataclasses.replace(params, profile=dataclasses.replace(
        params.profile, motion="stop_and_go"))
    alone = _Alone(Landing(robot=scene.robot, params=stop_and_go), scene=scene,
                   base=(0.8, 1.72, 0.0))
    alone.send(BaseCommand(id=3, path=((0.8, 1.72), (1.6, 1.72), (3.4, 1.72)),
                           pose=(3.4, 1.72, 0.0)))
    final, status = alone.final()
    assert status == Status(id=3, state=CommandState.DONE)
    np.testing.assert_allclose(final[:3], [3.4, 2.0, 0.0], atol=1e-9)
    drives = [s for s in alone.navigator._motion(alone.context).segments if not s.turn]
    off = drives[-1].start  # where it turns off the planned leg, to the landing
    assert off[1] == pytest.approx(1.72) and 3.4 - 0.8 < off[0] < 3.4
    assert all(d.end[1] == pytest.approx(1.72) for d in drives[:-1])
    times = np.linspace(0.0, alone.navigator._motion(alone.context).duration, 200)
    assert all(free(alone.at(t)[0][:3]) for t in times)


def _drive_in_world(scenario, command: BaseCommand, **kwargs):
    builder = DiagramBuilder()
    world = builder.AddSystem(build_world_diagram(scenario))
    navigator = builder.AddSystem(_navigator(scenario, **kwargs))
    commands = builder.AddSystem(ConstantValueSource(AbstractValue.Make(command)))
    arm = builder.AddSystem(ConstantVectorSource(np.concatenate([UR5E.arm_stow, UR5E.gripper_open,
                                                                 np.zeros(8)])))
    mux = builder.AddSystem(Multiplexer([6, 16]))
    # [base q, base v, arm q, arm v] -> [base q, arm q, base v, arm v]
    order = [*range(0, 3), *range(6, 14), *range(3, 6), *range(14, 22)]
    permute = builder.AddSystem(MatrixGain(np.eye(22)[order]))
    builder.Connect(commands.get_output_port(), navigator.GetInputPort("base_command"))
    builder.Connect(world.GetOutputPort("robot_state"), navigator.GetInputPort("robot_state"))
    builder.Connect(navigator.GetOutputPort("base_desired_state"), mux.get_input_port(0))
    builder.Connect(arm.get_output_port(), mux.get_input_port(1))
    builder.Connect(mux.get_output_port(), permute.get_input_port())
    builder.Connect(permute.get_output_port(), world.GetInputPort("robot_desired_state"))
    diagram = builder.Build()

    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    simulator.Initialize()
    status_port = navigator.GetOutputPort("status")
    nav_context = navigator.GetMyContextFromRoot(context)
    start = time.perf_counter()
    while not status_port.Eval(nav_context).finished and context.get_time() < 20.0:
        simulator.AdvanceTo(context.get_time() + 0.1)
    wall = time.perf_counter() - start
    state = world.GetOutputPort("robot_state").Eval(world.GetMyContextFromRoot(context))
    return state, status_port.Eval(nav_context), context.get_time(), wall


def test_drives_the_plant_to_the_goal_in_simulation(scenario):
    x0, y0, _ = scenario.robot.start
    command = BaseCommand(id=1, path=((x0, y0), (1.2, 1.4)), pose=(1.2, 1.4, 0.5))
    state, status, sim_time, wall = _drive_in_world(scenario, command)
    print(f"\nbase navigator in the world: {sim_time:.1f} s simulated in {wall:.2f} s "
          f"({sim_time / wall:.0f}x real time)")
    assert status == Status(id=1, state=CommandState.DONE)
    np.testing.assert_allclose(state[:2], command.pose[:2], atol=0.02)
    assert wrap_angle(state[2] - command.pose[2]) == pytest.approx(0.0, abs=0.02)
    np.testing.assert_allclose(state[3:9], UR5E.arm_stow, atol=0.01)  # the arm held still


def test_a_turn_command_turns_where_the_base_stands(scenario):
    # The planner's turn command names where it saw the base a control period earlier; the
    # base has drifted 40 µm since (the arm pushes it against its PD). It only turns.
    alone = _Alone(_navigator(scenario), base=(1.0, 1.0, 0.0))
    alone.send(BaseCommand(id=1, path=((1.0, 1.00004),), pose=(1.0, 1.00004, 1.0), turn=True))
    poses = np.array([alone.at(t)[0] for t in np.arange(0.0, 3.0, 0.01)])
    np.testing.assert_array_equal(poses[:, :2], np.broadcast_to([1.0, 1.0], (len(poses), 2)))
    assert np.all(np.diff(poses[:, 2]) >= 0)  # straight to yaw 1.0, no detour
    final, status = alone.final()
    np.testing.assert_allclose(final[:3], [1.0, 1.0, 1.0])
    assert status == Status(id=1, state=CommandState.DONE)
    # 1 rad: 0.4 s ramps to 0.8 rad/s and back, 0.68 rad at 0.8 rad/s; then the settle time.
    assert alone.at(0.4 + 0.85 + 0.4 + 0.3 - 1e-6)[1].state is CommandState.RUNNING
    assert alone.at(0.4 + 0.85 + 0.4 + 0.3 + 1e-6)[1].state is CommandState.DONE


def test_a_turn_cut_a_hair_short_of_a_collision_stops_a_step_earlier(scenario, scene):
    """From this stop near the chair, turning to yaw 0.573 collides from yaw 0.81852 on;
    the turn's samples (every 0.049 rad) have a free one at 0.81855, a hair short of it.
    The plant settles within a hair of its set point, and there the base stood in the
    collision (a pickup failed "base_collision"): the turn ends a sample earlier instead,
    here where it started."""
    x, y = 1.3452592452380063, 1.7807096953917887
    assert scene.checker.CheckConfigCollisionFree(scene.q([x, y, 0.81855]))
    assert not scene.checker.CheckConfigCollisionFree(scene.q([x, y, 0.81847]))
    alone = _Alone(_navigator(scenario), scene=scene, base=(x, y, 0.86765))
    alone.send(BaseCommand(id=2, path=((x, y),), pose=(x, y, 0.573), turn=True))
    final, status = alone.final()
    assert status == Status(id=2, state=CommandState.DONE)
    assert final[2] == pytest.approx(0.86765, abs=1e-9)
    # Turned from further away, its samples fall elsewhere: the last free one counts.
    alone.navigator.GetInputPort("robot_state").FixValue(alone.context, _robot_state(x, y, 1.2))
    alone.send(BaseCommand(id=4, path=((x, y),), pose=(x, y, 0.573), turn=True), t=2e3)
    final, status = alone.at(3e3)
    assert status == Status(id=4, state=CommandState.DONE)
    assert 0.8 < final[2] < 0.86765


@pytest.fixture(scope="module")
def dense():
    """The dense restaurant without chairs, and its scene: a 0.85 m aisle between the wall
    (y = 0) and the 2 x 2 block of small tables (y >= 0.85)."""
    from s3o_drake.feasibility.scene import FeasibilityScene
    from s3o_drake.world.scenario import load_scenario

    scenario = dataclasses.replace(load_scenario("scenarios/restaurant_dense.yaml"), chairs=[])
    return scenario, FeasibilityScene(scenario.contents)


def test_a_base_that_cannot_leave_a_tight_spot_goes_back_the_way_it_came(dense):
    """In the aisle, the way to (3.3, 1.3) cuts the table's corner whichever way the base
    turns or however far it first backs out (ESCAPE_STEPS); it drove in along the aisle, so
    it backs out along its trail and goes on from there. A base that did not come that way
    is blocked."""
    scenario, scene = dense
    leave = BaseCommand(id=2, path=((1.7, 0.45), (3.3, 1.3)), pose=(3.3, 1.3, 0.0))
    alone = _Alone(_navigator(scenario), scene=scene, base=(3.4, 0.45, math.pi))
    alone.send(BaseCommand(id=1, path=((3.4, 0.45), (1.7, 0.45)), pose=(1.7, 0.45, math.pi)))
    stopped, status = alone.final()
    assert status.state is CommandState.DONE
    alone.navigator.GetInputPort("robot_state").FixValue(alone.context,
                                                         _robot_state(*stopped[:3]))
    alone.send(leave, t=100.0)
    final, status = alone.final()
    assert status.state is CommandState.DONE and final[:2] == pytest.approx([3.3, 1.3])
    # Backwards along the aisle first: the way in, undone.
    assert alone.at(100.0 + 1.6 / V)[0][0] > 2.5
    assert wrap_angle(alone.at(100.5)[0][2] - math.pi) == pytest.approx(0.0, abs=1e-9)

    stranger = _Alone(_navigator(scenario), scene=scene, base=(1.7, 0.45, math.pi))
    stranger.send(leave, t=1.0)
    _, status = stranger.final()
    assert (status.state, status.reason) == (CommandState.FAILED, "blocked")


# --------------------------------------------------------- smooth: the arm moves as well
def _arm_out_of_the_table(base) -> ArmMotion:
    """An arm motion that starts with the hand inside the table in front of `base` and
    reaches the stow, in a straight joint line over 2 s: clear of the table about halfway."""
    reaching = np.array(UR5E.arm_stow, dtype=float)
    reaching[:3] = [math.pi, -0.3, 1.0]
    q0 = UR5E.positions(*base, arm=reaching, gripper=UR5E.gripper_open)
    q1 = UR5E.positions(*base, arm=UR5E.arm_stow, gripper=UR5E.gripper_open)
    trajectory = PiecewisePolynomial.FirstOrderHold([0.0, 2.0], np.column_stack([q0, q1]))
    return ArmMotion(trajectory, 0.0, tuple(q0[3:]))


def _played(navigator: BaseNavigator, base, arm: ArmMotion, command: BaseCommand, scene):
    """The motion `navigator` plays for `command` from `base`, the arm doing `arm`, in
    `scene`."""
    context = navigator.CreateDefaultContext()
    navigator.GetInputPort("known_scene").FixValue(context, AbstractValue.Make(KnownScene(scene)))
    navigator.GetInputPort("robot_state").FixValue(context, _robot_state(*base))
    navigator.GetInputPort("arm_motion").FixValue(context, AbstractValue.Make(arm))
    navigator.GetInputPort("base_command").FixValue(context, AbstractValue.Make(command))
    navigator.CalcForcedUnrestrictedUpdate(context, context.get_mutable_state())
    return navigator.GetOutputPort("base_motion").Eval(context)


@pytest.mark.parametrize("motion", ["smooth", "stop_and_go"])
def test_smooth_the_base_waits_where_the_arm_s_motion_and_its_own_collide(scenario, scene,
                                                                          motion):
    """A turn commanded while the arm is still in the table waits until the two motions
    are collision-free together, and no longer than the arm's motion; with the arm stowed
    it starts at once. Stopping and going, the arm is stowed whenever the base moves: the
    navigator does not look at it."""
    base = (1.85, 1.55, math.pi / 2)
    turn = BaseCommand(id=1, path=(base[:2],), pose=(*base[:2], base[2] - 1.0), turn=True)
    starts = []
    for arm in (_arm_out_of_the_table(base), ArmMotion(hold=tuple(STOWED))):
        played = _played(_navigator(scenario, motion=motion), base, arm, turn, scene)
        assert played.id == 1 and played.end_time == pytest.approx(played.t0 + played.duration)
        starts.append(played.t0)
    if motion == "smooth":
        assert 0.5 <= starts[0] <= 2.0 and starts[1] == 0.0
    else:
        assert starts == [0.0, 0.0]


def test_smooth_a_turn_that_ends_before_the_arm_s_motion_is_checked_until_that_ends(
        scenario, scene):
    """A turn at a stop ends in 2 s; the arm, planned for the base where it stood, reaches
    out after that and back to its stow. At the turned yaw the reach is in the table: the
    turn may not start where the base would stand turned while the arm is out."""
    from s3o_drake.execution.together import free_together

    base = (1.85, 1.55, math.pi / 2)
    out = np.array(UR5E.arm_stow, dtype=float)
    out[:3] = [4.2, -0.3, 1.0]  # clear of the table at yaw π/2, in it at π/2 - 1
    q = [UR5E.positions(*base, arm=arm, gripper=UR5E.gripper_open)
         for arm in (UR5E.arm_stow, UR5E.arm_stow, out, UR5E.arm_stow)]
    arm = ArmMotion(PiecewisePolynomial.FirstOrderHold([0.0, 2.5, 4.0, 5.5], np.column_stack(q)),
                    0.0, tuple(q[0][3:]))
    turn = BaseCommand(id=1, path=(base[:2],), pose=(*base[:2], base[2] - 1.0), turn=True)
    played = _played(_navigator(scenario, motion="smooth"), base, arm, turn, scene)
    assert played.id == 1 and played.duration < arm.end_time
    assert not free_together(lambda t: scene.checker, dataclasses.replace(played, t0=0.0).desired,
                             arm.arm_at, 0.0, arm.end_time,
                             robot=scene.robot)  # at once, the reach hits the table
    assert played.t0 > 0.0
    assert free_together(lambda t: scene.checker, played.desired, arm.arm_at, played.t0,
                         arm.end_time, robot=scene.robot)


def test_a_motion_that_writes_its_heading_a_turn_round_is_played_from_the_joint_s_yaw():
    """The yaw joint counts whole turns (4.98 rad after a few stops); a smooth drive starts at
    its leg's heading in (-π, π] (4.98 - 2π). Played as written, the set point jumps a turn
    and the PD spins the robot round at its stop, into the table beside it."""
    from s3o_drake.execution.base_navigator import _Motion, yaw_turns
    from s3o_drake.execution.escape import MotionProfile

    profile = MotionProfile(speed=0.4)
    yaw = 4.98
    written = yaw - 2 * math.pi
    drive = profile.segment((2.0, 3.0, written), (2.0, 2.5, written), turn=False, length=0.5)
    turn = profile.segment((2.0, 2.5, written), (2.0, 2.5, written + 0.3), turn=True,
                           length=0.3)
    turns = yaw_turns(yaw, [drive, turn])
    assert turns == pytest.approx((2 * math.pi, 2 * math.pi))
    motion = _Motion(id=1, t0=0.0, hold=(2.0, 3.0, yaw), segments=(drive, turn), turns=turns,
                     initialized=True)
    times = np.linspace(0.0, motion.duration + 1.0, 200)
    yaws = np.array([motion.desired(t)[2] for t in times])
    assert yaws[0] == pytest.approx(yaw) and np.abs(np.diff(yaws)).max() < 0.05
    assert motion.end[2] == pytest.approx(yaw + 0.3)
    # A motion written from the joint's own yaw, as a stop-and-go one is, is played as is.
    assert yaw_turns(yaw, [profile.segment((0, 0, yaw), (1, 0, yaw), turn=False,
                                           length=1.0)]) == (0.0,)


def test_an_arm_still_carrying_a_dish_a_replan_left_out_is_checked_without_it(scene):
    """After a replan the scene holds only the dishes that remain; the arm may still be
    carrying the one it picked to the tray. The navigator's check of the two motions
    together lets the gripper touch a dish the scene has, and checks without one it has
    not (it raised KeyError on it: five smooth dense runs with recovery at 6d93e51)."""
    from s3o_drake.execution.base_navigator import _checker
    from s3o_drake.feasibility import ik

    present = next(iter(scene.dishes))
    holding = ArmMotion(dish=present, release_time=math.inf)
    assert _checker(scene, holding, 1.0) is ik.grasp_checker(scene, present)
    carried = ArmMotion(dish="cup_gone", release_time=math.inf)
    assert _checker(scene, carried, 1.0) is scene.checker
    assert _checker(scene, ArmMotion(dish=present, release_time=0.5), 1.0) is scene.checker
