"""What a study's rows say: a run's time, its predicted completion, and whether two versions
of the code made the same runs (the behaviour check of a restructuring)."""

import json

import pytest

from s3o_drake.commands.same_runs import main as same_runs
from s3o_drake.experiments.run_rows import has_time, predicted_completion, run_differences


def _run(task="t", method="S3O-GROP*", **fields):
    row = {"task": task, "method": method, "run_seed": 7, "recovery": "none",
           "outcomes": ["goto l0: done", "pickup cup: done"], "execution_time": 40.0,
           "planning_time": 3.2, "job_seconds": 9.0, "code": "abc", "schema": 1,
           "pickups": [{"dish": "cup", "predicted": 0.9, "planned": 0.9}], "dishes": 1}
    return {**row, **fields}


def test_runs_that_differ_only_in_timings_and_bookkeeping_are_the_same():
    before = [_run(), _run(task="u")]
    after = [_run(planning_time=9.9, job_seconds=1.0, code="def", schema=2,
                  timing={"wall": 1.0}), _run(task="u")]
    assert run_differences(before, after) == (2, [])


def test_a_run_that_did_something_else_is_named_with_its_field():
    pairs, lines = run_differences([_run()], [_run(execution_time=41.0)])
    assert pairs == 1 and lines == ["t/S3O-GROP*/7/none: execution_time: 40.0 -> 41.0"]


def test_the_command_exits_1_on_a_difference_and_2_without_runs(tmp_path, capsys):
    for name, rows in (("a", [_run()]), ("b", [_run(outcomes=["goto l0: failed"])]),
                       ("c", [_run(task="other")])):
        (tmp_path / name).mkdir()
        (tmp_path / name / "results.jsonl").write_text(
            "".join(json.dumps({"key": r["task"], **r}) + "\n" for r in rows))
    assert same_runs([str(tmp_path / "a"), str(tmp_path / "a")]) == 0
    assert same_runs([str(tmp_path / "a"), str(tmp_path / "b")]) == 1
    printed = capsys.readouterr().out
    assert "outcomes" in printed and "other packages" not in printed
    (tmp_path / "d").mkdir()  # the same run made with another numpy: named
    (tmp_path / "d" / "results.jsonl").write_text(json.dumps(
        {"key": "t", **_run(outcomes=["goto l0: failed"]), "packages": "numpy 9"}) + "\n")
    assert same_runs([str(tmp_path / "a"), str(tmp_path / "d")]) == 1
    assert ("made with other packages: BEFORE not recorded; AFTER numpy 9"
            in capsys.readouterr().out)
    # The same run on another processor: identical is identical, a difference names both.
    for name, machine, changes in (("e", "x86_64, one, avx2", {}),
                                   ("f", "x86_64, another, avx512f",
                                    {"outcomes": ["goto l0: failed"]})):
        (tmp_path / name).mkdir()
        (tmp_path / name / "results.jsonl").write_text(json.dumps(
            {"key": "t", **_run(**changes), "machine": machine}) + "\n")
    assert same_runs([str(tmp_path / "a"), str(tmp_path / "e")]) == 0
    capsys.readouterr()
    assert same_runs([str(tmp_path / "e"), str(tmp_path / "f")]) == 1
    assert ("made with other machines: BEFORE x86_64, one, avx2; AFTER x86_64, another, "
            "avx512f" in capsys.readouterr().out)
    with pytest.raises(SystemExit) as e:
        same_runs([str(tmp_path / "a"), str(tmp_path / "c")])
    assert e.value.code == 2


def test_a_run_without_a_plan_has_no_time_and_predicts_nothing():
    assert not has_time({"planned": False}) and has_time({})
    assert predicted_completion({"planned": False, "pickups": []}) == 0.0
    assert predicted_completion(_run(dishes=2)) == 0.0  # a dish without a pickup
    assert predicted_completion(_run()) == pytest.approx(0.9)
    assert predicted_completion({"predicted_completion": 0.5}) == 0.5


def test_a_field_only_one_version_records_is_no_difference():
    assert run_differences([_run()], [_run(predicted_time=41.0)]) == (1, [])


def test_with_a_tolerance_last_digits_are_the_same_and_anything_more_is_not():
    pose = {"dish": "cup", "predicted": 0.9, "planned": 0.9, "actual_pose": [1.2, 2.5, 0.3]}
    nudged = {**pose, "actual_pose": [1.2 + 4e-16, 2.5, 0.3 - 5e-17]}
    before = [_run(pickups=[pose], closest_approach=0.0134)]
    after = [_run(pickups=[nudged], closest_approach=0.0134 + 1e-14)]
    assert run_differences(before, after)[1] != []  # exact by default
    assert run_differences(before, after, tolerance=1e-12) == (1, [])
    moved = [_run(pickups=[{**pose, "actual_pose": [1.21, 2.5, 0.3]}],
                  closest_approach=0.0134)]
    assert run_differences(before, moved, tolerance=1e-12)[1] != []
    # Not numbers: a tolerance changes nothing.
    assert run_differences([_run()], [_run(outcomes=["goto l0: failed"])],
                           tolerance=1e-12)[1] != []
    assert run_differences([_run(execution_time=40)], [_run(execution_time=40.0)]) == (1, [])
