"""A pickup at a stop that serves several dishes is rated at the share of its Fea^m that
executed pickups at such stops achieved: derived from open-loop runs, recorded, and applied
by the motion search's utility and the ranking alike."""

import dataclasses
import json

import numpy as np
import pytest
import yaml

from s3o_drake.abstraction.shared_stop import (
    NONE,
    StopPickup,
    StopShares,
    derive_shares,
    stop_shares,
    uses_recorded_shares,
)
from s3o_drake.commands.shared_stop import main as shared_stop
from s3o_drake.planning.failure_price import priced_planner
from s3o_drake.world.robot import load_robot
from s3o_drake.world.scenario import Scenario
from s3o_drake.world.settings import PlanningSettings

UR5E = load_robot("ur5e")


def test_a_share_is_successes_over_summed_fea_m_per_stop_size():
    records = ([StopPickup(0.9, True, 1)] * 9 + [StopPickup(0.9, False, 1)]
               + [StopPickup(0.8, True, 2)] * 3 + [StopPickup(0.8, False, 2)]
               + [StopPickup(0.5, True, 3), StopPickup(0.5, False, 4)])
    found = derive_shares(records)
    assert found["1"]["share"] == pytest.approx(9 / 9.0)
    assert found["2"]["share"] == pytest.approx(3 / 3.2)
    assert found["3+"]["share"] == pytest.approx(1 / 1.0)  # three and four dishes together
    assert found["2"]["low"] <= found["2"]["share"] <= found["2"]["high"]
    assert found["3+"]["pickups"] == 2
    with pytest.raises(ValueError, match=r"serving 3\+ dishes"):
        derive_shares(records[:-2])


def test_one_dish_stops_keep_fea_m_and_the_paper_rates_every_pickup_at_it():
    shares = StopShares({"2": 0.97, "3+": 0.9})
    assert [shares.of(k) for k in (1, 2, 3, 7)] == [1.0, 0.97, 0.9, 0.9]
    paper = dataclasses.replace(PlanningSettings(), shared_stop="paper")
    assert stop_shares(paper, robot=None) is NONE
    # The recorded shares are what the default planner reads.
    recorded = stop_shares(PlanningSettings(), robot=UR5E)
    assert recorded is StopShares.load(UR5E.files.shared_stop) and 0.5 < recorded.of(2) < 1.0
    with pytest.raises(ValueError, match=r"shares.3\+"):
        StopShares({"2": 0.97})


def test_open_loop_reads_the_shares_and_recovery_its_own_price():
    """In open loop a failed pickup loses its dish, at the shares' rate; with recovery it
    costs the recovery's time, whose recorded price already holds shared stops."""
    scenario = Scenario()
    assert scenario.planner.shared_stop == "execution"  # the default
    open_loop = dataclasses.replace(scenario, execution=dataclasses.replace(
        scenario.execution, recovery="none"))
    assert priced_planner(open_loop.settings, robot=UR5E) is open_loop.planner
    for recovery, rated in (("none", "execution"), ("retry", "paper"), ("replan", "paper")):
        s = dataclasses.replace(scenario, execution=dataclasses.replace(
            scenario.execution, recovery=recovery))
        assert uses_recorded_shares(s.settings) == (rated == "execution")
        assert priced_planner(s.settings, robot=UR5E).shared_stop == rated
    paper = dataclasses.replace(open_loop, planner=dataclasses.replace(
        scenario.planner, shared_stop="paper"))
    assert not uses_recorded_shares(paper.settings)
    assert priced_planner(paper.settings, robot=UR5E) is paper.planner


def _pickup(dish, pose, outcome, predicted=0.9):
    return {"dish": dish, "kind": "plate", "method": "S3O-GROP*", "predicted": predicted,
            "source": "fcn", "planned_pose": pose, "actual_pose": pose, "outcome": outcome}


def _row(key, pickups, recovery="none"):
    return {"kind": "run", "key": key, "task": "t", "method": "S3O-GROP*", "seed": 0,
            "recovery": recovery, "pickups": pickups, "code": "abc"}


def test_the_command_derives_and_records_the_shares(tmp_path, capsys):
    study = tmp_path / "study"
    study.mkdir()
    shared, alone = [1.0, 1.0, 0.0], [3.0, 1.0, 0.0]
    rows = [_row("a", [_pickup("a", shared, "done"), _pickup("b", shared, "no_ik"),
                       _pickup("c", alone, "done")]),
            _row("b", [_pickup("a", shared, "done"), _pickup("b", shared, "done"),
                       _pickup("c", shared, "done"), _pickup("d", alone, "missed")])]
    (study / "results.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))
    out = tmp_path / "shares.yaml"
    assert shared_stop([str(study), "--out", str(out)]) == 0
    recorded = StopShares.from_dict(yaml.safe_load(out.read_text()))
    assert recorded.of(2) == pytest.approx(1 / 1.8)
    assert recorded.of(3) == pytest.approx(3 / 2.7)
    assert recorded.provenance["one_dish_check"] == pytest.approx(round(1 / 1.8, 4))
    assert "stops serving 2 dishes: 0.556" in capsys.readouterr().out


def test_a_study_without_some_stop_size_counts_in_the_total(tmp_path, capsys):
    """A small study may make no stop of three dishes in one room: the shares come from
    the studies together, and only when none has such a stop is that refused."""
    shared, alone = [1.0, 1.0, 0.0], [3.0, 1.0, 0.0]
    pairs = _row("p", [_pickup("a", shared, "done"), _pickup("b", shared, "no_ik"),
                       _pickup("c", alone, "done")])
    threes = _row("t", [_pickup(d, shared, "done") for d in "abc"])
    for name, rows in (("pairs", [pairs]), ("threes", [pairs, threes])):
        (tmp_path / name).mkdir()
        (tmp_path / name / "results.jsonl").write_text(
            "".join(json.dumps(r) + "\n" for r in rows))
    out = tmp_path / "shares.yaml"
    assert shared_stop([str(tmp_path / "pairs"), str(tmp_path / "threes"),
                        "--out", str(out)]) == 0
    recorded = StopShares.from_dict(yaml.safe_load(out.read_text()))
    assert recorded.of(3) == pytest.approx(3 / 2.7)
    assert recorded.of(2) == pytest.approx(2 / 3.6)
    assert "3+" not in recorded.provenance["studies"][str(tmp_path / "pairs")]
    assert "stops serving 3+ dishes: none" in capsys.readouterr().out
    out.unlink()
    with pytest.raises(SystemExit) as e:
        shared_stop([str(tmp_path / "pairs"), "--out", str(out)])
    assert e.value.code == 2 and not out.exists()
    printed = capsys.readouterr()
    err = printed.err.strip()
    assert len(err.splitlines()) == 1 and "DIR" in err and "3+" in err
    # What the studies do hold is still measured: the pooled share of the two-dish stops.
    pooled = printed.out.split("all:")[1]
    assert "stops serving 2 dishes: 0.556" in pooled and "3+ dishes: none" in pooled


def test_runs_with_recovery_are_refused_in_one_line(tmp_path, capsys):
    study = tmp_path / "recovered"
    study.mkdir()
    row = _row("a", [_pickup("a", [1.0, 1.0, 0.0], "done")], recovery="replan")
    (study / "results.jsonl").write_text(json.dumps(row) + "\n")
    with pytest.raises(SystemExit) as e:
        shared_stop([str(study), "--out", str(tmp_path / "s.yaml")])
    assert e.value.code == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "recovery" in err and "DIR" in err
    assert not (tmp_path / "s.yaml").exists()


def test_the_search_rates_a_shared_stops_pickups_at_its_share():
    """Both dishes of two_dishes from one stop: the utility gives up λ (1 - s_2) of each
    pickup's Fea^m against the paper's rating, and nothing else changes."""
    from s3o_drake.abstraction import HeatmapFeasibility, voronoi_partition
    from s3o_drake.belief.known_world import KnownWorld
    from s3o_drake.experiments.plan_checks import ring_heatmaps
    from s3o_drake.planning.motion.grop import SequenceProblem, location_regions
    from s3o_drake.planning.navigation.map import NavigationMap
    from s3o_drake.world.scenario import load_scenario

    scenario = load_scenario("scenarios/small/two_dishes.yaml")
    known = KnownWorld.perfect(scenario)
    partition = voronoi_partition(known)
    regions = location_regions([["plate_a", "cup_b"]],
                               dict(zip(partition.dishes, partition.cells, strict=True)))
    fea = HeatmapFeasibility(ring_heatmaps(known))
    nav = NavigationMap(known.obstacles, robot=known.robot)
    sequence = [("goto", "l0"), ("pickup", "plate_a"), ("pickup", "cup_b")]
    X = np.array([[[2.0, 1.55]], [[1.9, 1.6]]])
    found = {}
    for rating in ("paper", "execution"):
        planner = dataclasses.replace(scenario.planner, shared_stop=rating)
        problem = SequenceProblem(sequence, regions, fea, nav, scenario.robot.start, planner,
                                  None)
        found[rating] = problem.evaluate(X)
    (u_paper, _, F, _), (u_shared, _, F_shared, _) = found["paper"], found["execution"]
    assert np.array_equal(F, F_shared) and F.min() > 0  # Fea^m itself is what it was
    share = stop_shares(PlanningSettings(), robot=UR5E).of(2)
    lam = scenario.planner.reward
    assert u_shared == pytest.approx(u_paper - lam * (1.0 - share) * F.sum(axis=1))
