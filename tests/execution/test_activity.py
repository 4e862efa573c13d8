"""Where a run's time went, from the robot's sampled motion (`Activity.by_motion`): each
sampled interval counted once, in the kind of motion the robot made during it."""

import numpy as np
import pytest

from s3o_drake.execution.activity import Activity


def test_each_interval_is_counted_once_in_its_kind_of_motion():
    # Ten 0.1 s intervals: drive 2, turn 2, drive with the arm 3, arm alone 2, still 1.
    speed = [0.4, 0.4, 0.0, 0.0, 0.3, 0.3, 0.0, 0.0, 0.0, 0.0, 0.0]
    yaw = [0.0, 0.0, 0.8, 0.8, 0.0, 0.0, 0.6, 0.0, 0.0, 0.0, 0.0]
    arm = [0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 0.5, 0.5, 0.0, 0.0]
    activity = Activity(np.linspace(0.0, 1.0, 11), np.array(speed), np.array(yaw),
                        np.array(arm))
    split = activity.by_motion()
    assert split == pytest.approx({"drive": 0.2, "turn": 0.2, "together": 0.3, "arm": 0.2,
                                   "still": 0.1})
    assert split["together"] == pytest.approx(activity.together())
    assert sum(split.values()) == pytest.approx(1.0)


def test_a_run_too_short_to_sample_spent_no_time():
    one = Activity(np.zeros(1), np.zeros(1), np.zeros(1), np.zeros(1))
    assert set(one.by_motion().values()) == {0.0}
