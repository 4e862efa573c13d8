"""The controllers and the simulated robot talking over an LCM bus in one process (memq://):
the run does what the run with the world's ports wired directly does, its messages a
control period late. The scene has two unmapped chairs that close an aisle: the executive
sees them only in the overhead images that come over the bus."""

import dataclasses

import pytest

from s3o_drake.execution.execute import execute
from s3o_drake.world.scenario import load_scenario
from tests.conftest import ORACLE_MAPS_ONCE


def _run(bus):
    scenario = load_scenario("scenarios/small/blocked_aisle.yaml")
    scenario = dataclasses.replace(
        scenario, planner=dataclasses.replace(scenario.planner, feasibility="oracle"),
        simulation=dataclasses.replace(scenario.simulation, publish_period=1.0))
    return execute(scenario, meshcat=None, progress=False, plan_from=ORACLE_MAPS_ONCE,
                   bus=bus).report


def test_over_memq_the_run_does_what_the_direct_run_does():
    direct, bus = _run(None), _run("memq://")
    assert bus["collected_dishes"] == direct["collected_dishes"]
    assert bus["reason"] == direct["reason"]
    assert [o[0] for o in bus["outcomes"]] == [o[0] for o in direct["outcomes"]]
    # 28.35 s against 27.5 s: each request and its answer, each command and the state that
    # follows, a control period late.
    assert bus["execution_time"] == pytest.approx(direct["execution_time"], rel=0.05)
