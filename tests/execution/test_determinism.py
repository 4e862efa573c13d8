"""Whole runs are deterministic: the same scenario and seed give the same plan.json and
report.json, wall-clock timings aside, whether the planner searches in one process or two.
Users compare runs and methods on that promise (randomness flows from one seed). That a run
on a Dask worker does what the same run does in the local pool is
tests/experiments/test_evaluate.py's (`evaluate --scheduler`)."""

import contextlib
import io
import json
from pathlib import Path

import yaml

from s3o_drake.commands import run_scenario
from s3o_drake.commands.run_scenario import main as run_main

REPO = Path(__file__).resolve().parents[2]
TWO_DISHES = REPO / "scenarios" / "small" / "two_dishes.yaml"
TIMINGS = {"planning_time", "feasibility_time", "wall_time", "realtime_rate", "timing",
           "job_seconds"}
"""Wall-clock figures: how long things took on this machine, not what was planned or done."""


def without_timings(value):
    """`value` (JSON data) without the wall-clock fields, at any depth."""
    if isinstance(value, dict):
        return {k: without_timings(v) for k, v in value.items() if k not in TIMINGS}
    if isinstance(value, list):
        return [without_timings(v) for v in value]
    return value


def scenario(folder: Path, workers: int) -> Path:
    """two_dishes.yaml with `workers` search processes, the network's Fea^m (the quicker
    source) and no pictures or playback (they are drawn from the same data)."""
    data = yaml.safe_load(TWO_DISHES.read_text())
    data["planner"] = {"feasibility": "fcn", "workers": workers}
    data["outputs"] = {"playback": False, "overhead": False, "feasibility": False,
                       "state_space": False}
    folder.mkdir(parents=True)
    path = folder / "two_dishes.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def run(path: Path, out: Path) -> int:
    """The run command, quietly (in whatever process calls it)."""
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        return run_main([str(path), "--out", str(out), "--seed", "7"])


def outputs(out: Path) -> dict:
    report = json.loads((out / "report.json").read_text())
    report.pop("scenario")  # the file's path: each run has its own copy
    return {"report": without_timings(report),
            "plan": without_timings(json.loads((out / "plan.json").read_text()))}


def test_runs_with_one_or_two_search_processes_are_identical(tmp_path, monkeypatch):
    # The pictures the run draws whatever its outputs say (the plan's, the search's, the
    # timeline) come after plan.json and report.json, from the same data.
    monkeypatch.setattr(run_scenario, "_write_pictures", lambda *args: [])
    one, two = scenario(tmp_path / "one", 1), scenario(tmp_path / "two", 2)
    status = run(one, tmp_path / "out_one")
    assert run(two, tmp_path / "out_two") == status
    reference = outputs(tmp_path / "out_one")
    # The run did something worth comparing: a plan, executed, with noise drawn.
    assert reference["plan"]["actions"] and reference["report"]["outcomes"]
    assert all(p["reach_noise"] is not None for p in reference["report"]["pickups"])
    assert outputs(tmp_path / "out_two") == reference
