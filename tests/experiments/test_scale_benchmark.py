"""The scale benchmark: its figures against the exact optimum, its summary and targets,
and the command (bad input, a run, a resumed run)."""

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from s3o_drake.commands import scale_benchmark
from s3o_drake.experiments.scale import state_space_row, summarize, target_lines
from s3o_drake.planning.task.exact_order import exact_order
from s3o_drake.planning.task.planner import TaskProblem, plan_tasks
from s3o_drake.planning.task.visit_order import visit_matrix

TWO_DISHES = Path(__file__).resolve().parents[2] / "scenarios" / "small" / "two_dishes.yaml"


def random_problem(m: int, seed: int) -> TaskProblem:
    rng = np.random.default_rng(seed)
    points = rng.uniform(0, 10, (m + 1, 2))
    locations = tuple(f"l{i}" for i in range(m))
    return TaskProblem(locations=locations, dishes={f"d{i}": locations[i] for i in range(m)},
                       costs=np.round(np.linalg.norm(points[:, None] - points[None],
                                                     axis=-1) * 10))


def test_a_state_space_is_measured_against_the_exact_optimum():
    problem = random_problem(20, seed=3)
    # clingo's search ends when it stalls (what it reaches is not the point here): a limit
    # far from that, so that an order exists whatever the machine's speed.
    task = plan_tasks(problem, n_plans=2, time_limit=60.0)
    groups = [(f"d{i}",) for i in range(20)]
    row = state_space_row(groups, task, reference_limit=60)
    _, optimum = exact_order(visit_matrix(problem)[1])
    assert row["locations"] == 20 and row["reference"] == optimum
    assert row["above"] == pytest.approx(task.best.cost / optimum - 1) and row["above"] >= 0
    assert row["bound"] <= optimum and row["asked"] == 2


def _row(dishes, plan_s, task_s, above, collected=None):
    row = {"task": f"t{dishes}_{plan_s}", "dishes": dishes, "planning_s": plan_s,
           "timing": dict.fromkeys(("feasibility", "navigation", "abstraction",
                                    "task_planning", "motion_search"), 0.1),
           "state_spaces": [{"locations": dishes, "task_s": t, "proven": a == 0,
                             "above": a, "reference_s": 0.1}
                            for t, a in zip(task_s, above, strict=True)]}
    if collected is not None:
        row["collected"] = collected
    return row


def test_the_summary_says_which_targets_hold_from_thirty_dishes_on():
    rows = [_row(10, 3.0, [4.0], [0.1]),  # below 30 dishes: no targets
            _row(30, 4.0, [1.5, 1.9], [0.0, 0.015], collected=29),
            _row(30, 6.0, [1.0], [0.0], collected=30),
            _row(30, 4.5, [1.2], [0.0]),
            _row(40, 4.0, [2.5], [0.03])]
    summary = summarize(rows)
    assert "targets" not in summary[10]
    assert summary[30]["plan_s"] == 4.5 and summary[30]["task_s_max"] == 1.9
    assert summary[30]["above_max"] == 0.015 and summary[30]["completion"] == 59 / 60
    assert summary[30]["targets"] == {"task_s": True, "order": True, "plan_s": True}
    assert summary[40]["targets"] == {"task_s": False, "order": False, "plan_s": True}
    lines = target_lines(summary)
    assert len(lines) == 2 and "MISSED" not in lines[0] and lines[1].count("MISSED") == 2


@pytest.mark.parametrize("args", [["--count", "0"], ["--method", "Greedy"],
                                  ["--dishes", "7"], ["--seed", "-2"],
                                  ["--reference-limit", "0"]])
def test_bad_arguments_exit_2_with_one_line(args, tmp_path, capsys):
    out = tmp_path / "rows.jsonl"
    with pytest.raises(SystemExit) as info:
        scale_benchmark.main([*args, "--json", str(out)])
    assert info.value.code == 2
    assert capsys.readouterr().err.count("\n") == 1
    assert not out.exists()


def test_a_run_plans_and_executes_each_task_and_a_second_run_reads_it_back(
        tmp_path, capsys, monkeypatch):
    """--execute: the task is planned as `run` plans it, then run; the row holds the
    plan's figures against the optimum and what the run collected. Run again on the same
    file, nothing is planned again. The task is the small two-dish scene in a --tasks-dir of
    its own: the command's row is what is checked, not the task's size, and a shipped
    5-dish task, planned and then planned again and executed, costs four times as long."""
    tasks = tmp_path / "tasks"
    (tasks / "dishes_02").mkdir(parents=True)
    shutil.copy(TWO_DISHES, tasks / "dishes_02" / "task_000.yaml")
    out = tmp_path / "rows.jsonl"
    argv = ["--tasks-dir", str(tasks), "--dishes", "2", "--count", "1", "--execute",
            "--json", str(out)]
    assert scale_benchmark.main(argv) == 0
    (row,) = [json.loads(line) for line in out.read_text().splitlines()]
    assert row["dishes"] == 2 and "error" not in row
    assert row["state_spaces"] and all(s["above"] is not None and s["above"] >= 0
                                       for s in row["state_spaces"])
    assert row["planning_s"] >= sum(row["timing"].values()) - 1e-6
    assert row["execute"] and 0 <= row["collected"] <= 2
    assert row["execution_time"] > 0 and row["replans"] >= 0
    printed = capsys.readouterr().out
    assert "dishes_02/task_000" in printed and "2 dishes: plan" in printed
    assert "collected" in printed

    def replan(*args, **kwargs):
        raise AssertionError("planned again")

    monkeypatch.setattr(scale_benchmark, "plan_task_row", replan)
    assert scale_benchmark.main(argv) == 0
    assert len(out.read_text().splitlines()) == 1
