"""The study's table of how the robot moved, pinned on a small table of rows."""

import numpy as np
import pytest

from s3o_drake.experiments.motion_summary import (
    closest_approaches,
    expected_errors,
    landing_offsets,
    motion_table,
    time_by_motion_table,
    time_errors,
)


def _pickup(planned, actual, attempt=1):
    return {"planned_pose": list(planned), "actual_pose": list(actual), "attempt": attempt}


def _run(motion, closest, predicted, executed, complete=True, pickups=(), method="S3O-GROP*",
         expected=None):
    row = {"method": method, "closest_approach": closest, "predicted_time": predicted,
           "expected_time": expected, "execution_time": executed, "complete": complete,
           "planned": True, "pickups": list(pickups)}
    if motion is not None:
        row["motion"] = motion
    return row


RUNS = [
    _run("smooth", 0.02, 90.0, 100.0, pickups=[
        _pickup((1, 1, 0), (1.3, 1.4, 0.1)),
        _pickup((1, 1, 0), (1.3, 1.4, 0.1)),  # the same stop's second dish: not a landing
        _pickup((1, 1, 0), (1.0, 1.1, 0.0), attempt=2),  # a retry: not a landing
        _pickup((3, 1, 0), (3.0, 1.1, 0.0))], expected=95.0),
    _run("smooth", -0.01, 100.0, 80.0),
    _run("smooth", 0.05, 50.0, 60.0, complete=False),  # did less than the plan
    _run(None, 0.04, 100.0, 100.0),  # a row from before the motion was recorded
    _run("smooth", None, 100.0, 100.0, method="V-GROP*"),  # nothing measured it
]


def test_each_measure_is_taken_from_the_rows_it_names():
    smooth = RUNS[:3]
    assert closest_approaches(smooth).tolist() == [0.02, -0.01, 0.05]
    assert closest_approaches(RUNS[4:]).size == 0
    # Only the runs that collected every dish: (90 - 100) / 100 and (100 - 80) / 80.
    assert time_errors(smooth) == pytest.approx([-0.1, 0.25])
    # The expected time where the plan had one: (95 - 100) / 100.
    assert expected_errors(smooth) == pytest.approx([-0.05])
    # A landing per stop, the plan's own attempt: 0.5 m and 0.1 m off the planned stop.
    assert landing_offsets(smooth) == pytest.approx([0.5, 0.1])


def test_the_table_has_a_row_per_method_and_motion():
    lines = motion_table(RUNS, ["S3O-GROP*", "V-GROP*"]).splitlines()
    assert len(lines) == 2 + 3
    smooth, stop_and_go, other = (line.split(" | ") for line in lines[2:])
    assert smooth[:3] == ["| S3O-GROP*", "smooth", "3"]
    assert smooth[3:6] == ["-0.010", f"{np.percentile([0.02, -0.01, 0.05], 5):.3f}", "0.020"]
    assert smooth[6:9] == ["2", "17.5%", "+7.5%"]
    assert smooth[9:12] == ["1", "5.0%", "-5.0%"]
    assert smooth[12:] == ["2", "0.300", f"{np.percentile([0.5, 0.1], 90):.3f} |"]
    # Rows from before the motion was recorded ran stop-and-go.
    assert stop_and_go[:3] == ["| S3O-GROP*", "stop_and_go", "1"]
    assert other[:6] == ["| V-GROP*", "smooth", "1", "–", "–", "–"]


def test_where_the_time_went_is_the_mean_of_the_complete_runs_that_record_it():
    split = {"drive": 10.0, "turn": 4.0, "together": 6.0, "arm": 20.0, "still": 2.0}
    runs = [{"method": "S3O-GROP*", "motion": "smooth", "complete": True,
             "time_by_motion": {k: v * scale for k, v in split.items()}}
            for scale in (1.0, 2.0)]
    runs += [{"method": "S3O-GROP*", "motion": "smooth", "complete": False,
              "time_by_motion": split},  # did less than its plan: left out
             {"method": "S3O-GROP*", "motion": "stop_and_go", "complete": True}]  # older
    table = time_by_motion_table(runs, ["S3O-GROP*"])
    assert "| S3O-GROP* | smooth | 2 | 15.0 | 6.0 | 9.0 | 30.0 | 3.0 | 63.0 |" in table
    assert "stop_and_go" not in table
    assert time_by_motion_table(runs[3:], ["S3O-GROP*"]) == ""
