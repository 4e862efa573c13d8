"""`s3o bench limit`: a row per plan and one for the bound, kept as they are made and
resumed; the summary names each configuration's gap to the reference."""

import json
import math

import pytest

from s3o_drake.commands.limit_benchmark import main
from s3o_drake.experiments.limit_study import (
    closed_share,
    gaps,
    judged_utility,
    same_plan,
    summary_lines,
)
from tests.conftest import CUP, one_dish, refused


def test_rows_for_the_bound_and_each_plan_then_a_rerun_makes_none(tmp_path, capsys):
    tasks = tmp_path / "tasks"
    tasks.mkdir()
    (tasks / "one_plate.yaml").write_text(one_dish("two_dishes", CUP))
    rows = tmp_path / "limit.jsonl"
    argv = ["--tasks", str(tasks), "--configurations", "default", "all_candidates",
            "--execute-seeds", "1", "--json", str(rows)]
    assert main(argv) == 0
    made = [json.loads(line) for line in rows.read_text().splitlines()]
    assert [r["configuration"] for r in made] == ["bound", "default", "all_candidates",
                                                  "executed:default:0"]
    bound, default, _, executed = made
    assert all(r["planned"] for r in made[1:3])
    assert 0.0 < bound["bound_s"] < default["predicted_time"]
    assert 0.5 < default["judged_completion"] <= 1.0 and default["stops"] >= 1
    # The default plan itself was executed (open loop, noise on): its prediction is the
    # plan's, and a complete run is no faster than the bound.
    assert executed["predicted_time"] == default["predicted_time"]
    assert executed["dishes"] == 1 and executed["execution_time"] > 0.0
    assert not executed["complete"] or executed["execution_time"] >= bound["bound_s"]
    written = rows.read_text()
    capsys.readouterr()
    assert main(argv) == 0  # resumed: every row read back, none made again
    assert rows.read_text() == written
    assert "predicted" in capsys.readouterr().out


def test_the_summary_gives_each_lift_its_gap_and_the_share_it_closes():
    def row(task, configuration, time, judged, utility):
        return {"task": task, "configuration": configuration, "planned": True,
                "predicted_time": time, "judged_completion": judged, "utility": utility}

    rows = [row("a", "reference", 100.0, 0.9, 50.0), row("a", "default", 110.0, 0.8, 40.0),
            row("a", "oracle", 105.0, 0.9, 48.0),
            {"task": "a", "configuration": "bound", "bound_s": 20.0}]
    rows += [{"task": "a", "configuration": f"executed:{name}:{k}", "complete": True,
              "execution_time": time + k, "predicted_time": predicted}
             for name, time, predicted in (("default", 120.0, 110.0),
                                           ("reference", 100.0, 100.0)) for k in (0, 2)]
    lines = summary_lines(rows)
    assert any("+19.8% executed, +10.0% predicted" in s for s in lines)
    assert any("complete runs below their task's bound: 0" in s for s in lines)
    assert any("default" in s and "+10.0%" in s and "-0.100" in s for s in lines)
    # Each share as a reader takes it from the medians: time (10 - 5) / 10, utility
    # (-10 - -2) / -10.
    assert any("oracle" in s and "of the time gap 50%, of the utility gap 80%" in s
               for s in lines)
    assert any("median 5.00 (1 tasks, 0 below the bound)" in s for s in lines)


def test_each_share_is_of_the_medians_of_its_own_gap():
    def row(task, configuration, time, utility):
        return {"task": task, "configuration": configuration, "planned": True,
                "predicted_time": time, "judged_completion": 0.9, "utility": utility}

    # Per task (default, long_search): time gaps +10 %, +2 % / +20 %, +2 % / +30 %, +2 %;
    # utility gaps -40, -36 / -20, -19 / -4, -3. Medians: time +20 % and +2 %, utility
    # -20 and -19: the search closes 90 % of the time gap and 5 % of the utility gap.
    rows = []
    for task, slower, lost, lost_searching in (("a", 1.1, 40.0, 36.0),
                                               ("b", 1.2, 20.0, 19.0),
                                               ("c", 1.3, 4.0, 3.0)):
        rows += [row(task, "reference", 100.0, 800.0),
                 row(task, "default", 100.0 * slower, 800.0 - lost),
                 row(task, "long_search", 102.0, 800.0 - lost_searching)]
    lines = summary_lines(rows)
    assert any("long_search" in s and "of the time gap 90%, of the utility gap 5%" in s
               for s in lines)
    assert closed_share(0.2, 0.02) == pytest.approx(0.9)
    assert closed_share(-20.0, -19.0) == pytest.approx(0.05)
    assert math.isnan(closed_share(0.0, 0.1))
    assert f"{closed_share(-20.0, -20.0):.0%}" == "0%"


def test_equal_judged_completion_is_counted_with_the_tolerance_and_strictly():
    def row(configuration, judged):
        return {"task": "a", "configuration": configuration, "planned": True,
                "predicted_time": 100.0, "judged_completion": judged, "utility": 0.0}

    found = gaps([row("reference", 0.900), row("default", 0.903)], "default")
    assert found[0]["level"] and not found[0]["strict"]
    found = gaps([row("reference", 0.900), row("default", 0.900)], "default")
    assert found[0]["level"] and found[0]["strict"]


def test_a_plan_on_the_judging_model_is_rated_pickup_by_pickup():
    plan = {"task": "a", "configuration": "default", "planned": True, "utility": 700.0,
            "predicted_time": 150.0, "judged_completion": 0.72,
            "planned_completion": 0.81}
    again = {"task": "a", "configuration": "pickups:default", "planned": True,
             "reward": 150.0, "utility": 700.004, "predicted_time": 150.0,
             "pickups": [{"dish": "cup_1", "own": 0.9, "judged": 0.8},
                         {"dish": "plate_1", "own": 0.9, "judged": 0.9}]}
    # The plan made again, each pickup at the judged Fea^m: λ (0.8 - 0.9) below its own.
    assert judged_utility(plan, again) == pytest.approx(685.004)
    assert same_plan(plan, again)  # within SAME_UTILITY, every stop judged as the row's
    assert not same_plan(plan, {**again, "utility": 701.0})
    assert not same_plan({**plan, "judged_completion": 0.75}, again)
    assert judged_utility(plan, None) is None  # made on the network, not made again
    # Made on the oracle: its own utility.
    assert judged_utility({**plan, "configuration": "oracle"}, None) == 700.0
    reference = {**plan, "configuration": "reference", "utility": 720.0,
                 "judged_completion": 0.81}
    oracle = {**plan, "configuration": "oracle", "utility": 710.0}
    lines = summary_lines([plan, again, reference, oracle])
    assert any("own completion minus judged" in s for s in lines)
    assert any("default" in s and "+0.090" in s and "1 above" in s for s in lines)
    # Gaps on the judging model: default 685 - 720, oracle 710 - 720: it closes 5 / 7.
    assert any("default" in s and "-35.00 (1 tasks; by their own Fea^m -20.00" in s
               and "1 of the 1 plans made again are the study's" in s for s in lines)
    assert any("oracle" in s and "-10.00 (1 tasks; its own" in s
               and "closes 71% of the default's" in s for s in lines)
    assert any("2 pickups" in s and "median +0.050" in s for s in lines)
    assert any("per plan, λ x their sum" in s and "median +15.00" in s for s in lines)
    assert any("the oracle's plan's utility less the default's" in s and "median +25.00" in s
               and "mean +25.00 on the 1 where the network rates a pickup" in s
               for s in lines)


def test_bad_input_is_one_line(capsys, tmp_path):
    assert "--tasks" in refused(main, ["--tasks", str(tmp_path / "none")], capsys)
    assert "--configurations" in refused(main, ["--configurations", "best"], capsys)


def test_rows_of_two_rooms_are_summarized_per_room_and_drawn(tmp_path, capsys):
    import matplotlib.image

    files = []
    for room, slower in (("generated", 1.05), ("generated_dense", 1.10)):
        lines = []
        for k in range(4):
            task = f"scenarios/{room}/task_{k:03d}.yaml"
            for name, factor, judged in (("reference", 1.0, 0.9), ("default", slower, 0.8),
                                         ("oracle", 1.02, 0.9)):
                lines.append({"key": f"{task}|{name}|0", "task": task, "configuration": name,
                              "seed": 0, "planned": True, "predicted_time": 100.0 * factor,
                              "judged_completion": judged, "utility": 50.0 / factor})
        path = tmp_path / f"{room}.jsonl"
        path.write_text("".join(json.dumps(line) + "\n" for line in lines))
        files.append(str(path))
    picture = tmp_path / "pictures" / "gap.png"
    assert main(["--rows", *files, "--picture", str(picture)]) == 0
    printed = capsys.readouterr().out
    assert "generated:" in printed and "generated_dense:" in printed
    assert "+5.0%" in printed and "+10.0%" in printed
    image = matplotlib.image.imread(picture)
    assert image.shape[1] > 1000 and image.std() > 0.01
    assert "--rows" in refused(main, ["--rows", str(tmp_path / "none.jsonl")], capsys)
