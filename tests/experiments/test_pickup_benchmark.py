"""The pickup benchmark: its command line, the reference trapezoids, and a two-pose run."""

import json
import math

import numpy as np
import pytest

from s3o_drake.commands.pickup_benchmark import (
    TIMINGS,
    main,
    trapezoid_duration,
    trapezoid_limits,
)
from tests.conftest import refused


@pytest.mark.parametrize("argv", [
    ["--poses", "0"],
    ["--count", "0"],
    ["--count", "100000"],
    ["--tasks", "no/such/task.yaml"],
    ["--seed", "-1"],
    ["--json", "/no/such/folder/out.json"],
    ["--bogus"],
])
def test_bad_arguments_are_one_line_exit_2(argv: list[str],
                                           capsys: pytest.CaptureFixture[str]) -> None:
    assert "error" in refused(main, argv, capsys)


def test_reference_trapezoids() -> None:
    v, a = np.array([1.0, 0.5]), np.array([2.0, 2.0])
    # Cruises: 2 rad at 1 rad/s after 0.5 s of accelerating; the slower joint sets the pace
    # of the second edge (0.5 rad at 0.5 rad/s).
    path = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 0.5]])
    assert trapezoid_duration(path, v, a) == pytest.approx((2.0 + 0.5) + (1.0 + 0.25))
    # Never reaches its cruise speed: a triangle; a repeated point costs nothing.
    short = np.array([[0.0, 0.0], [0.2, 0.0], [0.2, 0.0]])
    assert trapezoid_duration(short, v, a) == pytest.approx(2.0 * math.sqrt(0.2 / 2.0))
    # Half the arm's pace near the dish, as before TOPPRA.
    v_far, a_far = trapezoid_limits("approach")
    v_near, a_near = trapezoid_limits("descend")
    np.testing.assert_allclose(v_far[3:9], 1.0)
    np.testing.assert_allclose(a_far[3:9], 2.0)
    np.testing.assert_allclose(v_near[3:9], 0.5)
    np.testing.assert_allclose(a_near[3:9], 1.0)


def test_two_poses_in_the_restaurant(tmp_path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "pickups.json"
    assert main(["--poses", "2", "--count", "1", "--json", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "2 feasible poses (restaurant; seed 0)" in printed
    result = json.loads(out.read_text())
    assert result["figures"]["poses"] == 2
    for pose in result["poses"]:
        if pose["reason"] != "ok":
            continue
        # The same paths: TOPPRA under the UR5e's limits is faster than the trapezoids, and
        # rounding corners never slower than stopping at them.
        assert pose["toppra"] < pose["trapezoid"]
        assert pose["toppra"] <= pose["toppra_stops"] + 1e-9
        assert set(pose["segments"]) == set(TIMINGS)
