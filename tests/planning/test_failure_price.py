"""What a pickup's chance of failing costs the utility with recovery: derived from recorded
runs, recorded, and applied only where the execution recovers."""

import dataclasses
import json

import pytest
import yaml

from s3o_drake.commands.failure_price import main as failure_price
from s3o_drake.planning.failure_price import (
    FailurePrice,
    PricedPickup,
    derive_price,
    failure_reward,
    priced_planner,
)
from s3o_drake.world.robot import load_robot
from s3o_drake.world.scenario import Scenario

UR5E = load_robot("ur5e")


def test_the_price_is_recovery_time_per_expected_failure():
    records = [PricedPickup(0.9, 0.0)] * 8 + [PricedPickup(0.6, 10.0), PricedPickup(0.6, 2.0)]
    price = derive_price(records)
    # 12 s of recoveries against 8 x 0.1 + 2 x 0.4 = 1.6 expected failures.
    assert price["seconds"] == pytest.approx(12.0 / 1.6)
    assert price["low"] <= price["seconds"] <= price["high"]
    assert price["pickups"] == 10
    with pytest.raises(ValueError, match="no pickups"):
        derive_price([])


def test_recovery_prices_a_failure_by_its_time_and_open_loop_by_the_dish():
    price = FailurePrice(20.0)
    scenario = Scenario()
    assert scenario.planner.failure_price == "execution"  # the default
    for recovery, priced in (("none", 150.0), ("retry", 20.0), ("replan", 20.0)):
        s = dataclasses.replace(scenario, execution=dataclasses.replace(
            scenario.execution, recovery=recovery))
        assert failure_reward(s.settings, price, robot=UR5E) == priced
    # The paper's price whatever the execution does; and the planner is the same object.
    paper = dataclasses.replace(scenario, planner=dataclasses.replace(
        scenario.planner, failure_price="paper", shared_stop="paper"))
    assert failure_reward(paper.settings, price, robot=UR5E) == 150.0
    assert priced_planner(paper.settings, price, robot=UR5E) is paper.planner
    # The recorded price is the one the planner reads.
    assert FailurePrice.load(UR5E.files.failure_price).seconds > 0


def _row(recovery, pickups, recoveries):
    return {"key": json.dumps(pickups), "task": "t", "method": "S3O-GROP*", "seed": 0,
            "recovery": recovery, "pickups": pickups, "recoveries": recoveries,
            "code": "abc"}


def test_the_command_derives_and_records_the_price(tmp_path, capsys):
    study = tmp_path / "study"
    study.mkdir()
    rows = [_row("replan", [{"dish": "a", "predicted": 0.95, "planned": 0.5},
                            {"dish": "a", "predicted": 0.95, "planned": 0.5, "attempt": 2},
                            {"dish": "b", "predicted": 0.5, "planned": 0.5}],
                 [{"kind": "correction", "dish": "a", "cost": 6.0},
                  {"kind": "retry", "dish": "a", "cost": 4.0},
                  {"kind": "replan", "dish": "a", "cost": 0.0}]),
            _row("none", [{"dish": "c", "predicted": 0.0, "planned": 0.0}], [])]
    (study / "results.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))
    out = tmp_path / "price.yaml"
    assert failure_price([str(study), "--out", str(out)]) == 0
    recorded = FailurePrice.from_dict(yaml.safe_load(out.read_text()))
    # 10 s for dish a, 0 for b, against 0.5 + 0.5 expected failures (the open-loop run and
    # the retry's record do not count).
    assert recorded.seconds == pytest.approx(10.0)
    assert recorded.provenance["pickups"] == 2
    assert "10.00 s per expected failure" in capsys.readouterr().out


def test_studies_without_the_plans_feasibility_are_refused_in_one_line(tmp_path, capsys):
    study = tmp_path / "old"
    study.mkdir()
    row = _row("replan", [{"dish": "a", "predicted": 0.9}], [])
    (study / "results.jsonl").write_text(json.dumps(row) + "\n")
    with pytest.raises(SystemExit) as e:
        failure_price([str(study), "--out", str(tmp_path / "p.yaml")])
    assert e.value.code == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "planned" in err
    assert not (tmp_path / "p.yaml").exists()
