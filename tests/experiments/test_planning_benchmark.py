"""The planning benchmark's command line: bad arguments are one line and exit status 2;
the helpers that need no planning. (The benchmark itself takes minutes and is not run here.)"""

from __future__ import annotations

import math

import pytest

from s3o_drake.commands.planning_benchmark import long_run, main, summarize
from s3o_drake.world.resources import shipped_tasks
from s3o_drake.world.scenario import load_scenario
from tests.conftest import refused


@pytest.mark.parametrize("argv", [
    ["--tasks", "0"],
    ["--tasks", "100000"],
    ["--tasks", "three"],
    ["--method", "NOPE"],
    ["--workers", "0"],
    ["--factor", "1"],
    ["--scenarios", "no/such/file.yaml"],
    ["--json", "/no/such/folder/out.jsonl"],
    ["--bogus"],
])
def test_bad_arguments_are_one_line_exit_2(argv: list[str],
                                           capsys: pytest.CaptureFixture[str]) -> None:
    assert "error" in refused(main, argv, capsys)


def test_shipped_tasks_have_5_to_7_dishes() -> None:
    tasks = shipped_tasks()
    assert len(tasks) >= 10
    for path in tasks[:10]:
        assert 5 <= len(load_scenario(path).dishes) <= 7


def test_long_run_multiplies_generations_only() -> None:
    scenario = load_scenario(shipped_tasks()[0])
    longer = long_run(scenario, 10)
    assert longer.planner.cma_generations == 10 * scenario.planner.cma_generations
    assert longer.planner.cma_population == scenario.planner.cma_population
    assert longer.dishes == scenario.dishes
    assert scenario.planner.cma_generations == 20  # the original is untouched


def _row(task: str, plan_s: float, ratio: float) -> dict:
    timing = {k: 0.1 for k in ("feasibility", "navigation", "abstraction", "task_planning",
                               "motion_search")}
    return {"task": task, "planning_s": plan_s, "planning_with_feasibility_s": plan_s + 3.0,
            "timing": timing, "utility_ratio": ratio}


def test_summary_medians_and_failures() -> None:
    rows = [_row("a", 1.0, 1.0), _row("b", 2.0, 0.9), _row("c", 9.0, math.nan),
            {"task": "d", "error": "PlanningError: x"}]
    s = summarize(rows)
    assert s["planned"] == 3 and s["failed"] == ["d"]
    assert s["median_planning_s"] == 2.0
    assert s["median_planning_with_feasibility_s"] == 5.0
    assert s["median_utility_ratio"] == pytest.approx(0.95)
    assert s["worst_utility_ratio"] == 0.9
    assert s["time_target_met"] and s["time_target_met_with_feasibility"]
    assert not s["utility_target_met"]


def test_resumes_from_the_tasks_in_its_json_file(tmp_path, monkeypatch, capsys) -> None:
    """A task already in the --json file (same settings) is read back, not planned again;
    one with other settings is planned."""
    import json

    from s3o_drake.commands import planning_benchmark as benchmark

    path = tmp_path / "bench.jsonl"
    settings = {"method": "S3O-GROP*", "seed": 0, "workers": 2, "factor": 10}
    done = {**_row("task_000", 1.5, 0.99), **settings, "dishes": 7, "utility": 800.0,
            "long_utility": 808.0, "complete": True, "long_complete": True}
    other = {**done, "task": "task_001", "seed": 5}
    # Lines of a file from before the benchmark used the result store: no key, no schema.
    path.write_text(json.dumps(done) + "\n" + json.dumps(other) + "\n" + '{"task": "cut sh')
    planned = []

    def fake(name, scenario, **kwargs):
        planned.append(name)
        return {**_row(name, 2.5, 1.0), **settings, "dishes": len(scenario.dishes),
                "utility": 1.0, "long_utility": 1.0, "complete": True, "long_complete": True}

    monkeypatch.setattr(benchmark, "benchmark_task", fake)
    assert main(["--count", "2", "--json", str(path)]) == 0
    assert planned == ["task_001"]
    assert "resuming: 1 tasks" in capsys.readouterr().out
    lines = path.read_text().splitlines()
    assert len(lines) == 4  # the line cut short is cut off, the two rows appended
    records = [json.loads(line) for line in lines[2:]]
    assert all(r["schema"] == 1 and "code" in r for r in records)
    assert records[0]["task"] == "task_001" and records[-1]["summary"]["tasks"] == 2
    assert records[-1]["summary"]["median_planning_s"] == 2.0
