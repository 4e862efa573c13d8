"""`evaluate --again`: a fix measured on the runs it was made for, each beside its old twin."""

import json
import shutil
from pathlib import Path

import pytest

from s3o_drake.commands.evaluate import main as evaluate
from s3o_drake.commands.evaluate import study_jobs
from s3o_drake.experiments.again import chosen, comparison
from tests.conftest import CUP, one_dish

REPO = Path(__file__).resolve().parents[2]


def _row(job, **fields) -> dict:
    return {"key": job.key, "task": job.task, "method": job.method, "seed": job.seed,
            "dishes": 2, **fields}


def test_the_runs_chosen_are_those_that_did_not_complete_or_that_ended_so(tmp_path):
    path = tmp_path / "t.yaml"
    shutil.copy(REPO / "scenarios/small/two_dishes.yaml", path)
    _, jobs = study_jobs([path], ["V-GROP"], 6)
    before = {r["key"]: r for r in [
        _row(jobs[0], complete=True, collected=2, reason="plan ended"),
        _row(jobs[1], complete=False, collected=0, reason="goto l0 failed: blocked"),
        _row(jobs[2], complete=False, collected=0, reason="no plan: V-GROP: no valid plan"),
        _row(jobs[3], complete=False, collected=1, reason="plan ended"),
        _row(jobs[4], error="ValueError: broken")]}  # jobs[5]: never run
    assert chosen(jobs, before) == jobs[1:4]
    assert chosen(jobs, before, ["blocked"]) == [jobs[1]]
    assert chosen(jobs, before, ["blocked", "no plan"]) == jobs[1:3]
    after = [_row(jobs[1], complete=True, collected=2, reason="plan ended"),
             _row(jobs[2], complete=False, collected=1, reason="goto l1 failed: blocked")]
    table = comparison(before, after, ["V-GROP", "S3O-GROP*"])
    assert "| V-GROP | 2 | 0 -> 1 | 0 -> 3 of 4 | 1 / 0 / 1 / 0 |" in table
    assert "S3O-GROP*" not in table  # no runs of it


def test_again_runs_only_the_chosen_runs_and_sets_them_beside_their_twins(tmp_path, capsys):
    tasks = tmp_path / "tasks"
    tasks.mkdir()
    (tasks / "one_plate.yaml").write_text(one_dish("two_dishes", CUP))
    difficulty, jobs = study_jobs(sorted(tasks.glob("*.yaml")), ["V-GROP"], 2)
    earlier = tmp_path / "earlier"
    earlier.mkdir()
    measured = {"key": difficulty[0].key, "task": "one_plate", "area": 3.0,
                "areas": {"plate_a": 3.0}, "dishes": 1}
    (earlier / "difficulty.jsonl").write_text(json.dumps(measured) + "\n")
    (earlier / "results.jsonl").write_text("".join(json.dumps(r) + "\n" for r in [
        _row(jobs[0], dishes=1, complete=True, collected=1, reason="plan ended"),
        _row(jobs[1], dishes=1, complete=False, collected=0, reason="goto l0 failed: blocked")]))
    out = tmp_path / "again"
    assert evaluate(["--tasks", str(tasks), "--methods", "V-GROP", "--seeds", "2",
                     "--out", str(out), "--again", str(earlier), "--ended", "blocked",
                     "--workers", "1", "--quiet"]) == 0
    rows = [json.loads(line) for line in (out / "results.jsonl").read_text().splitlines()]
    assert [r["key"] for r in rows] == [jobs[1].key]  # only the blocked run, same seed
    assert rows[0]["run_seed"] != 0 and rows[0]["finished"]
    # The task's difficulty is read from the earlier study, not measured again.
    assert json.loads((out / "difficulty.jsonl").read_text())["area"] == 3.0
    again = (out / "again.md").read_text()
    line = f"| V-GROP | 1 | 0 -> {int(rows[0]['complete'])} | 0 -> {rows[0]['collected']} of 1 |"
    assert line in again and line in capsys.readouterr().out


@pytest.mark.parametrize("args, field", [
    (["--ended", "blocked"], "--ended"),
    (["--again", "nowhere"], "--again"),
])
def test_bad_again_input_is_one_line_exit_2_and_writes_nothing(tmp_path, capsys, args, field):
    out = tmp_path / "results"
    with pytest.raises(SystemExit) as exit_info:
        evaluate(["--tasks", str(REPO / "scenarios/small"), "--out", str(out), *args])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and field in err[0]
    assert not out.exists()


def test_again_into_its_own_study_is_refused(tmp_path, capsys):
    (tmp_path / "results.jsonl").write_text("")
    with pytest.raises(SystemExit) as exit_info:
        evaluate(["--tasks", str(REPO / "scenarios/small"), "--out", str(tmp_path),
                  "--again", str(tmp_path)])
    assert exit_info.value.code == 2 and "--again" in capsys.readouterr().err
