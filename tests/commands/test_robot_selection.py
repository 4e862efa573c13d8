"""The scenario's robot.name selects the robot, in whatever process: an unknown one is
refused in one line, and one process plans and executes for two robots what two processes,
one for each, do (the robot it runs second runs as in a process of its own)."""

import json
import subprocess
import sys

import pytest

from s3o_drake.world.resources import DEFAULT_ROBOT, REPO_DIR, RESTAURANT, SCENARIOS_DIR
from s3o_drake.world.scenario import load_scenario, parse_scenario, with_overrides
from s3o_drake.world.scenario_checks import ScenarioError

SHORT = ("planner.cma_generations=4", "planner.cma_population=6", "execution.recovery=none")
"""A short run: a small search, open loop."""
SAME = ("dishes", "collected", "completed", "execution_time", "finished", "reason",
        "outcomes", "outcome_times", "pickups", "unreachable", "closest_approach",
        "simulated_time")
"""What a run's report says of the plan and the execution (not its wall-clock timings)."""


def test_a_scenario_names_its_robot_and_an_unknown_one_is_refused():
    assert parse_scenario(RESTAURANT.read_text()).robot.name == DEFAULT_ROBOT == "ur5e"
    assert parse_scenario("robot: {name: panda}").robot_value.name == "panda"
    with pytest.raises(ScenarioError, match=r"^robot.name: no robot named 'r2d2' \(known: "
                                            r".*ur5e"):
        parse_scenario("robot: {name: r2d2}")


def test_a_description_being_written_is_refused_in_one_line_naming_its_file(monkeypatch):
    """A user bringing a robot edits its robot.yaml: a scenario that names it gets the
    description's problem as the robot.name field's, not a traceback."""
    from s3o_drake.world import scenario_checks
    from s3o_drake.world.robot_description import RobotDescriptionError

    def broken(name):
        raise RobotDescriptionError("missing_of", "unknown field 'missing_of'")

    monkeypatch.setattr(scenario_checks, "load_robot", broken)
    with pytest.raises(ScenarioError) as info:
        parse_scenario("robot: {name: panda}")
    assert str(info.value) == ("robot.name: 'panda': models/panda/robot.yaml: missing_of: "
                               "unknown field 'missing_of'")


def short_run(robot: str) -> dict:
    """The report of a short run of one dish of two_dishes.yaml for `robot`, seed 0."""
    import dataclasses

    from s3o_drake.execution.execute import execute

    scenario = with_overrides(load_scenario(SCENARIOS_DIR / "small" / "two_dishes.yaml"),
                              (f"robot.name={robot}", *SHORT))
    scenario = dataclasses.replace(scenario, dishes=scenario.dishes[:1])
    report = execute(scenario, seed=0, meshcat=None, progress=False).report
    return json.loads(json.dumps({key: report[key] for key in SAME}))


def test_one_process_plans_and_executes_for_two_robots_what_two_processes_do():
    """The robot run second in this process, after the default one, runs as it does in a
    process of its own: the first robot leaves nothing that the second one's plan or
    execution reads."""
    child = ("import json, sys; from tests.commands.test_robot_selection import short_run; "
             "print(json.dumps(short_run(sys.argv[1])))")
    # Started first, so that it runs while this process does.
    apart = subprocess.Popen([sys.executable, "-c", child, "panda"], cwd=REPO_DIR,
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    together = {robot: short_run(robot) for robot in ("ur5e", "panda")}
    out, err = apart.communicate(timeout=600)
    assert apart.returncode == 0, err[-1000:]
    assert json.loads(out.splitlines()[-1]) == together["panda"]
    assert together["ur5e"]["collected"] == together["panda"]["collected"] == 1
    assert together["ur5e"]["pickups"] != together["panda"]["pickups"]  # two robots, two runs


def test_a_build_is_told_its_robot_and_an_unknown_one_is_one_line_and_status_2(capsys):
    from s3o_drake.commands import build_reachability

    with pytest.raises(SystemExit) as info:
        build_reachability.main(["--robot", "r2d2"])
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--robot" in err and "no robot named 'r2d2'" in err
