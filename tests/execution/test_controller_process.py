"""The controllers in a process of their own: they wait for the robot, follow its clock,
are judged by the simulation's referee channel, and stop the robot when it falls silent.
The robot is `s3o sim` in another process, on a bus of this machine."""

import random
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from pydrake.lcm import DrakeLcm

from s3o_drake.execution.controller_process import (
    ROBOT_SILENT,
    NoRobotError,
    execute_on_bus,
    robot_labels,
)
from s3o_drake.world import robot_channels as ch
from s3o_drake.world.builder import build_world_diagram, robot_render_labels
from s3o_drake.world.lcmtypes.s3o_lcm import robot_command_t
from s3o_drake.world.scenario import load_scenario
from tests.conftest import ORACLE_MAPS_ONCE

SCENE = "scenarios/small/two_dishes.yaml"


def _bus() -> str:
    """A port of its own, so that no other run on this machine is heard."""
    return ch.local_bus(random.randint(20000, 60000))


def test_the_robot_knows_its_own_pixels_as_the_simulation_labels_them():
    scenario = load_scenario(SCENE)
    world = build_world_diagram(scenario, track_dishes=True)
    seen = robot_render_labels(world, scenario.robot_value)
    mine = robot_labels(scenario.robot_value)
    assert seen and seen <= mine
    # They are the robot's bodies in the world's plant: no other body carries one.
    plant = world.GetSubsystemByName("plant")
    assert mine == {int(b) for b in scenario.robot_value.instances_in(plant).body_indices()}


def _ended(robot: subprocess.Popen, *, timeout: float) -> str:
    """The robot's stderr once it ended; a robot that does not end is aborted, and the
    failure shows each of its threads' stacks."""
    try:
        return robot.communicate(timeout=timeout)[1]
    except subprocess.TimeoutExpired:
        robot.send_signal(signal.SIGABRT)
        _, err = robot.communicate(timeout=30)
        pytest.fail(f"the robot did not end within {timeout:g} s of its signal:\n{err}")


def test_without_a_robot_the_controllers_say_so_after_the_wait():
    start = time.monotonic()
    with pytest.raises(NoRobotError, match=ch.ROBOT_STATE):
        execute_on_bus(load_scenario(SCENE), lcm=DrakeLcm(_bus()), wait=0.5, progress=False)
    assert time.monotonic() - start < 5.0


def test_a_robot_that_falls_silent_is_stopped_and_the_run_ends_with_its_report():
    """The robot's process ends once the controllers have planned and kept the robot
    moving for a second: they command it to stand where it was last heard of, and
    report."""
    url = _bus()
    lcm = DrakeLcm(url)
    robot = subprocess.Popen(
        # faulthandler: should it hang, SIGABRT shows where (below).
        [sys.executable, "-X", "faulthandler", "-m", "s3o_drake.commands", "sim", SCENE,
         "--lcm", url],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    commands, ended = [], []

    def heard(data: bytes) -> None:
        command = robot_command_t.decode(data)
        commands.append(command)
        moving = sum(np.abs(c.velocity).max() > 0.0 for c in commands)
        if moving == 20 and not ended:
            robot.send_signal(signal.SIGINT)  # the robot goes away mid-motion
            ended.append(True)

    lcm.Subscribe(ch.ROBOT_COMMAND, heard)
    try:
        # A robot process starved of the CPU (beside a study) can be silent for a while
        # before it is ended: only its end is to stop these controllers.
        run = execute_on_bus(load_scenario(SCENE), lcm=lcm, wait=60.0, progress=False,
                             plan_from=ORACLE_MAPS_ONCE, state_timeout=2.0)
        moving = len(commands)
        for _ in range(5):  # what the controllers published last, as the robot would hear it
            lcm.HandleSubscriptions(20)
    finally:
        if not ended:  # the run ended otherwise: end the robot all the same
            robot.send_signal(signal.SIGINT)
        err = _ended(robot, timeout=120)
    assert robot.returncode == 130, err
    report = run.report
    assert report["reason"].startswith(ROBOT_SILENT) and not report["finished"]
    # The referee's channel came: the dishes are the simulation's.
    assert report["referee"] and report["dishes"] == 2
    assert run.plan is not None
    # The last commands hold the robot still: where its last state put it.
    assert len(commands) > moving and np.allclose(commands[-1].velocity, 0.0)


def test_the_command_without_a_robot_says_so_and_writes_nothing(tmp_path, capsys):
    from s3o_drake.commands.run_scenario import main

    out = tmp_path / "run"
    assert main([SCENE, "--robot", "lcm", "--lcm", _bus(), "--wait", "0.5", "--out",
                 str(out)]) == 1
    err = capsys.readouterr().err
    assert f"no robot state on {ch.ROBOT_STATE} within 0.5 s" in err and "s3o sim" in err
    assert not out.exists()
