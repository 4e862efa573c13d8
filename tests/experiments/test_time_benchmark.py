"""The time benchmark: predicted against simulated execution time, one JSON line per run,
resumed from its file."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

from s3o_drake.commands import time_benchmark
from s3o_drake.commands.time_benchmark import main, summarize
from s3o_drake.world.robot import load_robot
from tests.conftest import CUP, one_dish

REPO = Path(__file__).resolve().parents[2]


def test_runs_writes_a_line_per_run_and_resumes(tmp_path, capsys, monkeypatch):
    task = tmp_path / "one_plate.yaml"
    task.write_text(one_dish("two_dishes", CUP))
    out = tmp_path / "times.jsonl"
    assert main(["--tasks", str(task), "--noise", "off", "--json", str(out)]) == 0
    (row,) = [json.loads(line) for line in out.read_text().splitlines()]
    assert row["task"] == "one_plate" and row["noise"] is False
    assert row["cost_profile"] == "robot" and row["method"] == "S3O-GROP*"
    assert row["rel_error"] == pytest.approx(
        (row["predicted_time"] - row["execution_time"]) / row["execution_time"])
    assert row["time_model"] == time_benchmark.model_version(
        load_robot("ur5e").files.time_model)
    printed = capsys.readouterr().out
    assert "one_plate" in printed and "noise off      all:   1 runs" in printed

    # The same command again runs nothing: the row comes from the file.
    class NoRuns:  # the worker pool, asked for no run
        def __enter__(self):
            return self

        def __exit__(self, *exc):
            return False

        def map(self, fn, jobs):
            assert not list(jobs), "a finished run was run again"
            return iter(())

    monkeypatch.setattr(time_benchmark, "local_pool", lambda workers: NoRuns())
    assert main(["--tasks", str(task), "--noise", "off", "--json", str(out)]) == 0
    assert len(out.read_text().splitlines()) == 1
    assert f"{100 * abs(row['rel_error']):.2f} %" in capsys.readouterr().out


def test_summary_splits_runs_with_failures():
    rows = [{"noise": True, "rel_error": e, "all_done": done}
            for e, done in ((-0.05, True), (0.02, True), (0.3, False))]
    s = summarize(rows, "on")
    assert s["all"]["runs"] == 3 and s["all"]["median_abs"] == pytest.approx(0.05)
    assert s["all_done"]["runs"] == 2 and s["all_done"]["median_abs"] == pytest.approx(0.035)
    assert s["all_done"]["mean_signed"] == pytest.approx(-0.015)
    assert summarize(rows, "off") == {"noise": "off", "runs": 0}


@pytest.mark.parametrize("argv, field", [(["--count", "0"], "--count"),
                                         (["--tasks", "nowhere"], "--tasks"),
                                         (["--method", "RRT"], "--method")])
def test_bad_input_is_one_line_and_status_2(tmp_path, argv, field):
    result = subprocess.run([sys.executable, "-m", "s3o_drake.commands.time_benchmark", *argv],
                            capture_output=True, text=True, cwd=REPO)
    assert result.returncode == 2
    assert result.stderr.count("\n") == 1 and field in result.stderr


def test_what_the_noise_adds_is_averaged_per_action_over_plans_done_both_ways():
    from s3o_drake.commands.derive_times import noise_terms

    def row(times, actions=("goto", "pickup", "goto", "pickup"), done=True):
        return {"all_done": done, "outcome_actions": list(actions), "outcome_times": times}

    pairs = [(row([10.0, 12.0, 20.0, 22.0]), row([11.0, 14.0, 23.0, 25.0])),
             # executed otherwise with the noise: not comparable action by action
             (row([10.0, 12.0, 20.0, 22.0]), row([9.0, 30.0], ("goto", "pickup"))),
             (row([10.0, 12.0]), row([50.0, 60.0], done=False))]
    goto, pickup, counts = noise_terms(pairs)
    # gotos 10 -> 11 and 8 -> 9 s, pickups 2 -> 3 and 2 -> 2 s
    assert (goto, pickup) == pytest.approx((1.0, 0.5))
    assert counts == {"pairs": 3, "as_planned": 1, "gotos": 2, "pickups": 2}
    with pytest.raises(RuntimeError, match="unknown"):
        noise_terms(pairs[1:])
