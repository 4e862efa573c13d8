"""Calibration of Fea^m against executed pickups: the arithmetic on constructed data, the
reliability diagram, reading results and report files, and bad input."""

import json
import math
import subprocess
import sys
from pathlib import Path

import cv2
import pytest

from s3o_drake.commands.calibration import main
from s3o_drake.execution.messages import PickupRecord
from s3o_drake.experiments.calibration import (
    RecordsError,
    binomial_interval,
    calibrate,
    calibrate_records,
    distance_group,
    facing_error,
    grouped,
    read_records,
)

REPO = Path(__file__).resolve().parents[2]

# Six pickups, worked by hand with 10 bins:
#   bin 0.5-0.6: 0.55 (fail)                       mean 0.55, observed 0   -> |0.55|
#   bin 0.8-0.9: 0.85 (done), 0.85 (fail)          mean 0.85, observed 0.5 -> |0.35|
#   bin 0.9-1.0: 0.95, 0.95, 0.99 (all done)       mean 0.9633.., observed 1 -> |0.03666..|
# ECE = (1 * 0.55 + 2 * 0.35 + 3 * 0.036666..) / 6 = 1.36 / 6
# Brier = (0.55² + 0.15² + 0.85² + 0.05² + 0.05² + 0.01²) / 6 = 1.0526 / 6
PREDICTED = [0.55, 0.85, 0.85, 0.95, 0.95, 0.99]
SUCCEEDED = [False, True, False, True, True, True]


def _record(predicted: float, outcome: str, *, method: str = "S3O-GROP*",
            source: str = "fcn", dish: str = "plate_1") -> PickupRecord:
    return PickupRecord(dish=dish, kind="plate", method=method, predicted=predicted,
                        source=source, planned_pose=(1.0, 2.0, 0.0),
                        actual_pose=(1.02, 1.97, 0.01), outcome=outcome,
                        reach_noise=(0.004, -0.002))


def test_ece_and_brier_match_the_hand_computation():
    f = calibrate(PREDICTED, SUCCEEDED, bins=10)
    assert f.count == 6 and f.successes == 4
    assert f.ece == pytest.approx(1.36 / 6)
    assert f.brier == pytest.approx(1.0526 / 6)
    assert f.mean_predicted == pytest.approx(sum(PREDICTED) / 6)
    assert [b.count for b in f.bins] == [0, 0, 0, 0, 0, 1, 0, 0, 2, 3]
    assert f.bins[8].mean_predicted == pytest.approx(0.85) and f.bins[8].observed == 0.5
    assert math.isnan(f.bins[0].observed) and f.bins[0].interval is None
    # Predicted >= 0.9: three, all done.
    assert (f.high_count, f.high_successes, f.high_success) == (3, 3, 1.0)
    assert f.high_interval == pytest.approx((0.292402, 1.0), abs=1e-6)


def test_one_bin_is_the_gap_between_mean_prediction_and_success():
    f = calibrate(PREDICTED, SUCCEEDED, bins=1)
    assert f.ece == pytest.approx(abs(sum(PREDICTED) / 6 - 4 / 6))


def test_a_prediction_of_one_falls_in_the_last_bin_and_a_perfect_model_scores_zero():
    f = calibrate([1.0, 1.0, 0.0], [True, True, False], bins=10)
    assert f.bins[-1].count == 2 and f.bins[0].count == 1
    assert f.ece == 0.0 and f.brier == 0.0


def test_clopper_pearson_interval_matches_known_values():
    # 9 of 10: the exact interval is [0.5550, 0.9975] (Clopper & Pearson 1934 tables).
    assert binomial_interval(9, 10) == pytest.approx((0.554984, 0.997471), abs=1e-5)
    assert binomial_interval(0, 5)[0] == 0.0 and binomial_interval(5, 5)[1] == 1.0
    with pytest.raises(ValueError):
        binomial_interval(3, 2)


def test_bad_predictions_are_refused():
    with pytest.raises(ValueError, match="0, 1"):
        calibrate([1.2], [True])
    with pytest.raises(ValueError, match="bins"):
        calibrate([0.5], [True], bins=0)


def test_records_group_by_method_and_source():
    records = [_record(0.9, "done", method="V-PETLON", source="oracle"),
               _record(0.8, "no_ik"), _record(0.95, "done", source="oracle")]
    by_method = grouped(records, "method")
    assert list(by_method) == ["S3O-GROP*", "V-PETLON"]
    assert [len(v) for v in by_method.values()] == [2, 1]
    assert {k: len(v) for k, v in grouped(records, "source").items()} == {"fcn": 1,
                                                                         "oracle": 2}
    f = calibrate_records(records)
    assert f.successes == 2 and f.brier == pytest.approx((0.01 + 0.64 + 0.0025) / 3)


def test_puttings_down_group_apart_from_pickups():
    """A record whose dish is a place target is the putting down of its object."""
    records = [_record(0.9, "done", dish="cup_1"), _record(0.95, "off_place", dish="cup_1__place"),
               _record(0.9, "done", dish="cup_1__place")]
    by_action = grouped(records, "action")
    assert {k: [r.outcome for r in v] for k, v in by_action.items()} == {
        "pickup": ["done"], "place": ["off_place", "done"]}
    assert calibrate_records(by_action["place"]).successes == 1


# ------------------------------------------------------------------------------ files

def _row(key: str, records: list[PickupRecord], **extra) -> dict:
    return {"key": key, "kind": "run", "task": key, "method": records[0].method if records
            else "S3O-GROP*", "seed": 0, "outcomes": [], "pickups": [r.to_dict()
                                                                     for r in records],
            **extra}


def _write_results(path: Path, rows: list[dict]) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("".join(json.dumps(r) + "\n" for r in rows))
    return path


def _study(tmp_path: Path) -> Path:
    """A results.jsonl of two runs (two methods) and a run that ended in an error."""
    s3o = [_record(p, "done" if y else "no_ik", dish=f"d{i}")
           for i, (p, y) in enumerate(zip(PREDICTED, SUCCEEDED, strict=True))]
    petlon = [_record(0.3, "done", method="V-PETLON"), _record(0.6, "missed",
                                                               method="V-PETLON")]
    return _write_results(tmp_path / "study" / "results.jsonl", [
        _row("run/a/S3O-GROP*/0", s3o), _row("run/a/V-PETLON/0", petlon),
        {"key": "run/b/S3O-GROP*/0", "kind": "run", "error": "RuntimeError: boom"},
        {"key": "difficulty/a", "kind": "difficulty", "area": 3.0}])


def test_reads_a_results_file_a_folder_and_reports(tmp_path):
    results = _study(tmp_path)
    read = read_records([results])
    assert read.runs == 2 and len(read.pickups) == 8
    assert read_records([results.parent]).pickups == read.pickups
    assert read_records([results.parent, results]).runs == 2  # one file named twice
    # Run folders with report.json files, found below the folder given.
    for i, record in enumerate(read.pickups[:3]):
        folder = tmp_path / "runs" / f"run{i}"
        folder.mkdir(parents=True)
        (folder / "report.json").write_text(json.dumps(
            {"outcomes": [], "collected": 1, "pickups": [record.to_dict()]}))
    from_reports = read_records([tmp_path / "runs"])
    assert from_reports.runs == 3 and from_reports.pickups == read.pickups[:3]


def test_command_prints_the_figures_and_writes_the_diagram(tmp_path, capsys):
    results = _study(tmp_path)
    out = tmp_path / "out"
    assert main([str(results), "--out", str(out), "--by", "method"]) == 0
    printed = capsys.readouterr().out
    assert "8 executed pickups from 2 runs" in printed
    lines = {line.split("  ")[0].strip(): line for line in printed.splitlines()}
    # S3O-GROP*'s six are the hand-worked set.
    assert f"{1.36 / 6:5.3f}  {1.0526 / 6:6.3f}" in lines["method S3O-GROP*"]
    assert "1.000 (3) [0.292, 1.000]" in lines["method S3O-GROP*"]
    assert lines["method V-PETLON"].split()[2:4] == ["2", "0.500"]
    assert "none" in lines["method V-PETLON"]  # nothing predicted >= 0.9
    assert "no_ik 2, missed 1" in printed
    image = cv2.imread(str(out / "reliability.png"))
    assert image is not None and image.shape[0] > 400 and image.std() > 10
    summary = json.loads((out / "calibration.json").read_text())
    assert summary["figures"]["method S3O-GROP*"]["ece"] == pytest.approx(1.36 / 6)
    assert summary["figures"]["all"]["pickups"] == 8
    assert sum(b["pickups"] for b in summary["figures"]["all"]["bins"]) == 8
    # --methods keeps only those pickups.
    assert main([str(results), "--out", str(out), "--methods", "V-PETLON"]) == 0
    assert "2 executed pickups" in capsys.readouterr().out


def test_rows_without_records_are_refused_not_guessed(tmp_path):
    old = _write_results(tmp_path / "old" / "results.jsonl", [
        {"key": "run/a/S3O-GROP*/0", "kind": "run", "outcomes": ["pickup d: done"]}])
    with pytest.raises(RecordsError, match="1 of 1 runs have no per-pickup records"):
        read_records([old])


def _bad_inputs(tmp_path: Path) -> list[tuple[list[str], str]]:
    results = _study(tmp_path)
    bad_record = _row("run/c/S3O-GROP*/0", [_record(0.5, "done")])
    bad_record["pickups"][0]["predicted"] = 1.5
    text = tmp_path / "notes.json"
    text.write_text("hello")
    empty = tmp_path / "empty"
    empty.mkdir()
    return [
        ([str(tmp_path / "missing.jsonl")], "no such file"),
        ([str(empty)], "no results.jsonl"),
        ([str(text)], "not a JSON report"),
        ([str(_write_results(tmp_path / "bad" / "results.jsonl", [bad_record]))],
         "pickups[0]: predicted"),
        ([str(_write_results(tmp_path / "old" / "results.jsonl", [
            {"key": "run/a/S3O-GROP*/0", "kind": "run", "outcomes": ["pickup d: done"]}]))],
         "no per-pickup records"),
        ([str(results), "--bins", "0"], "--bins"),
        ([str(results), "--methods", "S3O"], "--methods"),
        ([str(results), "--methods", "V-GROP"], "no executed pickup of 'V-GROP'"),
        ([str(results), "--by", "dish"], "--by"),
    ]


def test_bad_input_is_one_line_exit_2_and_writes_nothing(tmp_path, capsys):
    for argv, message in _bad_inputs(tmp_path):
        out = tmp_path / "out"
        with pytest.raises(SystemExit) as exit_:
            main([*argv, "--out", str(out)])
        printed = capsys.readouterr()
        assert exit_.value.code == 2, (argv, printed.err)
        assert printed.err.count("\n") == 1 and message in printed.err, printed.err
        assert not out.exists() and printed.out == ""


def test_pickups_are_grouped_by_whether_the_base_faced_its_dish(tmp_path, capsys):
    """Fea^m assumes the base faces the dish; a turn cut short leaves it turned away. The
    dishes' positions come from the row's task file."""
    def at(dish, yaw, outcome="done"):
        r = _record(0.9, outcome, dish=dish)
        return PickupRecord(**{**r.to_dict(), "planned_pose": (2.0, 1.6, math.pi / 2),
                               "actual_pose": (2.0, 1.6, yaw)})

    # plate_a at (1.85, 2.3), cup_b at (2.15, 2.3): from (2.0, 1.6) bearings of about
    # π/2 + 0.21 and π/2 - 0.21.
    bearing = math.atan2(0.7, -0.15)
    run = [at("plate_a", bearing), at("cup_b", bearing, "no_ik"), at("ghost", 0.0),
           at("cup_b", bearing + math.pi, "no_ik")]
    task = "scenarios/small/two_dishes.yaml"
    results = _write_results(tmp_path / "s" / "results.jsonl",
                             [_row("run/t/S3O-GROP*/0", run, path=task)])
    read = read_records([results])
    assert read.facing[0] == pytest.approx(0.0, abs=1e-9)
    assert read.facing[1] == pytest.approx(2 * math.atan2(0.15, 0.7))
    assert read.facing[2] is None  # no such dish in the task
    assert read.facing[3] == pytest.approx(math.pi - read.facing[1])  # the dish behind it
    by = grouped(read.pickups, "facing", stops=read.stops, facing=read.facing)
    assert {k: [r.dish for r in v] for k, v in by.items()} == {
        "3+ dishes, facing": ["plate_a"], "3+ dishes, position unknown": ["ghost"],
        "3+ dishes, turned away": ["cup_b", "cup_b"]}
    with pytest.raises(ValueError, match="facing"):
        grouped(read.pickups, "facing", stops=read.stops)
    # How far: a little (0.42 rad), or with the dish behind the base.
    by = grouped(read.pickups, "turn", facing=read.facing)
    assert {k: len(v) for k, v in by.items()} == {
        "0.00-0.15 rad": 1, "0.15-1.00 rad": 1, "1.00 rad or more": 1, "position unknown": 1}
    with pytest.raises(ValueError, match="turn"):
        grouped(read.pickups, "turn")
    for by in ("facing", "turn"):
        assert main([str(results), "--out", str(tmp_path / by), "--by", by]) == 0
    printed = capsys.readouterr().out
    assert "facing 3+ dishes, turned away" in printed
    assert "turn 1.00 rad or more" in printed
    assert facing_error((0.0, 0.0, math.pi), (-1.0, 0.0)) == pytest.approx(0.0)
    assert facing_error((0.0, 0.0, -math.pi / 2), (1.0, 0.0)) == pytest.approx(math.pi / 2)


def test_help_is_the_module_docstring():
    result = subprocess.run([sys.executable, "-m", "s3o_drake.commands.calibration", "--help"],
                            capture_output=True, text=True, check=True, cwd=REPO)
    for text in ("RESULTS", "--out", "--methods", "--by", "--bins", "ECE", "Brier",
                 "reliability.png", "calibration.json", "Exit status"):
        assert text in result.stdout


def test_pickups_are_grouped_by_how_many_dishes_their_stop_served(tmp_path, capsys):
    def at(pose, dish, outcome="done", attempt=1):
        r = _record(0.9, outcome, dish=dish)
        return PickupRecord(**{**r.to_dict(), "planned_pose": tuple(pose),
                               "attempt": attempt})

    shared, alone = (1.0, 2.0, 0.0), (3.0, 1.0, 0.5)
    run = [at(shared, "a"), at(shared, "b", "no_ik"), at(alone, "c", "missed"),
           at(alone, "c", attempt=2), at(shared, "d")]
    results = _write_results(tmp_path / "s" / "results.jsonl", [_row("run/t/S3O-GROP*/0", run)])
    read = read_records([results])
    assert read.stops == (3, 3, 1, 1, 3)  # a retry counts with its stop, not again
    by_stop = grouped(read.pickups, "stop", stops=read.stops)
    assert {k: [r.dish for r in v] for k, v in by_stop.items()} == {
        "1 dish": ["c", "c"], "3+ dishes": ["a", "b", "d"]}
    with pytest.raises(ValueError, match="stop"):
        grouped(read.pickups, "stop")
    assert main([str(results), "--out", str(tmp_path / "out"), "--by", "stop"]) == 0
    assert "stop 3+ dishes" in capsys.readouterr().out


def test_pickups_are_grouped_by_their_place_at_the_stop(tmp_path, capsys):
    """The first pickup at a stop is made as the base arrives; the others after a turn in
    place, which a chair can cut short."""
    def at(pose, dish, outcome="done", attempt=1):
        r = _record(0.9, outcome, dish=dish)
        return PickupRecord(**{**r.to_dict(), "planned_pose": tuple(pose),
                               "attempt": attempt})

    shared, alone = (1.0, 2.0, 0.0), (3.0, 1.0, 0.5)
    run = [at(shared, "a"), at(shared, "b", "no_ik"), at(shared, "b", attempt=2),
           at(alone, "c"), at(shared, "d")]
    results = _write_results(tmp_path / "s" / "results.jsonl", [_row("run/t/S3O-GROP*/0", run)])
    read = read_records([results])
    assert read.orders == (1, 2, 2, 1, 3)  # a retry keeps its pickup's place
    by_order = grouped(read.pickups, "order", orders=read.orders)
    assert {k: [r.dish for r in v] for k, v in by_order.items()} == {
        "1st at its stop": ["a", "c"], "2nd at its stop": ["b", "b"],
        "3rd+ at its stop": ["d"]}
    with pytest.raises(ValueError, match="order"):
        grouped(read.pickups, "order", stops=read.stops)
    assert main([str(results), "--out", str(tmp_path / "out"), "--by", "order"]) == 0
    assert "order 2nd at its stop" in capsys.readouterr().out


def test_pickups_are_grouped_by_their_stops_distance_to_the_dish(tmp_path, capsys):
    """Fea^m's errors grow towards the edge of reach, where an optimiser tends to stop: the
    planned stop's distance to its dish, from the row's task file, groups the pickups."""
    def at(x, dish, outcome="done"):
        r = _record(0.9, outcome, dish=dish)
        return PickupRecord(**{**r.to_dict(), "planned_pose": (x, 2.3, 0.0),
                               "actual_pose": (x + 0.05, 2.3, 0.0)})

    # plate_a at (1.85, 2.3): stops 0.5, 0.85 and 1.2 m to its left, and a ghost dish.
    run = [at(1.35, "plate_a"), at(1.0, "plate_a", "no_ik"), at(0.65, "plate_a", "no_ik"),
           at(0.0, "ghost")]
    task = "scenarios/small/two_dishes.yaml"
    results = _write_results(tmp_path / "s" / "results.jsonl",
                             [_row("run/t/S3O-GROP*/0", run, path=task)])
    read = read_records([results])
    assert read.distances[:3] == pytest.approx((0.5, 0.85, 1.2))
    assert read.distances[3] is None
    by = grouped(read.pickups, "distance", distances=read.distances)
    assert {k: [r.outcome for r in v] for k, v in by.items()} == {
        "0.00-0.80 m": ["done"], "0.80-0.90 m": ["no_ik"], "1.00 m or more": ["no_ik"],
        "position unknown": ["done"]}
    assert distance_group(0.9) == "0.90-0.95 m"  # an edge opens the group above it
    with pytest.raises(ValueError, match="distance"):
        grouped(read.pickups, "distance", stops=read.stops)
    assert main([str(results), "--out", str(tmp_path / "out"), "--by", "distance"]) == 0
    assert "distance 0.80-0.90 m" in capsys.readouterr().out
