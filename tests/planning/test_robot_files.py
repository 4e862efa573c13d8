"""A robot without a built file that the settings need is told which setting needs it and
how to make it, before anything runs."""

import dataclasses

from s3o_drake.planning import robot_files
from s3o_drake.world.resources import RESTAURANT
from s3o_drake.world.robot import RobotFiles, load_robot
from s3o_drake.world.scenario import load_scenario

UR5E = load_robot("ur5e")


def _settings(feasibility: str, price: str, recovery: str, shared_stop: str = "execution"):
    scenario = load_scenario(RESTAURANT)
    return dataclasses.replace(
        scenario, planner=dataclasses.replace(scenario.planner, feasibility=feasibility,
                                              failure_price=price, shared_stop=shared_stop),
        execution=dataclasses.replace(scenario.execution, recovery=recovery)).settings


def test_the_shipped_robot_has_everything_its_defaults_need():
    assert robot_files.missing_robot_files(_settings("fcn", "execution", "replan"), UR5E) == []


def test_each_missing_file_is_named_with_its_setting_and_its_command(tmp_path):
    # The UR5e with a folder that holds only its map and its time model.
    for name in ("reachability_map.npz", "time_model.yaml"):
        (tmp_path / name).symlink_to(UR5E.files.folder / name)
    robot = dataclasses.replace(UR5E, files=RobotFiles(tmp_path))
    missing = robot_files.missing_robot_files(_settings("fcn", "execution", "replan"), robot)
    assert [line.split(":")[0] for line in missing] == ["planner.feasibility",
                                                        "planner.failure_price"]
    assert "s3o build robot ur5e --steps fcn-data fcn" in missing[0]
    assert "planner.failure_price: paper" in missing[1]
    # Open loop needs the shared-stop shares instead of the recovery's price.
    missing = robot_files.missing_robot_files(_settings("oracle", "execution", "none"), robot)
    assert [line.split(":")[0] for line in missing] == ["planner.shared_stop"]
    assert "`s3o shared-stop`" in missing[0] and "planner.shared_stop: paper" in missing[0]
    # Settings that do without them need none: the oracle, the paper's price and rating.
    assert robot_files.missing_robot_files(_settings("oracle", "paper", "replan"), robot) == []
    assert robot_files.missing_robot_files(_settings("oracle", "execution", "none", "paper"),
                                           robot) == []


def test_a_robot_still_being_built_is_told_what_it_lacks_in_one_line():
    # Its description says what it lacks (`missing`) until its build is done: the commands
    # that plan and execute refuse it with that, whatever files its folder holds so far.
    description = dataclasses.replace(UR5E.description, missing="its network and\n  its price")
    robot = dataclasses.replace(UR5E, description=description)
    assert robot_files.missing_robot_files(_settings("fcn", "execution", "replan"), robot) == [
        "robot.name: 'ur5e' is not ready to plan and execute; it lacks its network and its "
        "price"]
