"""The scenario's robot.name selects the robot: an unknown one is refused in one line, and a
command given a scenario for a robot other than its process's runs again for that robot."""

import subprocess
import sys

import pytest

from s3o_drake.commands import cli, common
from s3o_drake.world import scenario_checks
from s3o_drake.world.resources import RESTAURANT, ROBOT_NAME, ROBOT_VARIABLE
from s3o_drake.world.scenario import parse_scenario
from s3o_drake.world.scenario_checks import OtherRobotError, ScenarioError


def test_a_scenario_names_its_robot_and_an_unknown_one_is_refused():
    assert parse_scenario(RESTAURANT.read_text()).robot.name == ROBOT_NAME == "ur5e"
    with pytest.raises(ScenarioError, match=r"^robot.name: no robot named 'r2d2' \(known: "
                                            r".*ur5e"):
        parse_scenario("robot: {name: r2d2}")


def test_a_command_runs_again_for_the_robot_its_scenario_names(monkeypatch, capsys, tmp_path):
    # This process plans for a robot named "other"; the scenario names the UR5e.
    monkeypatch.setattr(scenario_checks, "ROBOT_NAME", "other")
    monkeypatch.delenv(ROBOT_VARIABLE, raising=False)
    with pytest.raises(OtherRobotError) as error:
        parse_scenario(RESTAURANT.read_text())
    assert error.value.path == "robot.name" and error.value.robot == "ur5e"
    calls = []

    def call(argv, env):
        calls.append((argv, env[ROBOT_VARIABLE]))
        return 3

    monkeypatch.setattr(subprocess, "call", call)
    argv = ["run", str(RESTAURANT), "--out", str(tmp_path), "--set", "planner.top_k=4"]
    with pytest.raises(SystemExit) as info:
        cli.main(argv)
    assert info.value.code == 3  # the new process's status
    assert calls == [([sys.executable, "-m", "s3o_drake.commands", *argv], "ur5e")]
    assert not any(tmp_path.iterdir())  # this process wrote nothing


def test_without_a_command_to_run_again_the_robot_is_one_line_and_status_2(monkeypatch,
                                                                          capsys):
    monkeypatch.setattr(common, "_invocation", None)
    with pytest.raises(SystemExit) as info:
        common.use_robot("ur5e")
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"set {ROBOT_VARIABLE}=ur5e" in err
