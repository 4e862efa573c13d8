"""Where the base stands when it picks: the execution's landing, as Fea^m models it."""

import math

import numpy as np
import pytest

from s3o_drake.feasibility.landing import (
    CHECK_STEP_XY,
    FINAL_APPROACH,
    TURN_TOLERANCE,
    pickup_poses,
    stop_short,
    turn_until,
)
from s3o_drake.world.angles import facing_yaw

# `checker` (tests/conftest.py) is on scenarios/small/two_dishes.yaml: a table x 1.4..2.6,
# y 2.1..2.9; plate_a at (1.85, 2.3), 0.2 m inside its free south edge.


def test_a_target_inside_the_table_stops_short_at_its_edge(checker):
    target = np.array([[1.85, 2.0, math.pi / 2]])  # facing north, front 0.21 m into the table
    assert not checker.base_free(target)[0]
    (pose,), (landed,) = stop_short(checker.base_free, target)
    assert landed
    assert checker.base_free(pose[None])[0]
    # Straight back along the heading, by whole check steps, and no further than needed.
    assert pose[0] == pytest.approx(1.85) and pose[2] == pytest.approx(math.pi / 2)
    back = 2.0 - pose[1]
    assert back / CHECK_STEP_XY == pytest.approx(round(back / CHECK_STEP_XY))
    one_less = pose + np.array([0.0, CHECK_STEP_XY, 0.0])
    assert not checker.base_free(one_less[None])[0]
    # A free target is kept as it is.
    free = np.array([[1.85, 1.45, math.pi / 2]])
    poses, landed = stop_short(checker.base_free, free)
    assert landed[0]
    np.testing.assert_array_equal(poses, free)


def test_a_target_deep_in_the_table_blocks_the_drive(checker):
    # The base would need more than FINAL_APPROACH of backing out: blocked, not landed.
    target = np.array([[2.0, 2.9, math.pi / 2]])
    _, landed = stop_short(checker.base_free, target)
    assert not landed[0]
    assert FINAL_APPROACH < 2.9 - 1.55


def test_a_turn_stops_at_the_last_free_yaw(checker):
    # Backed up to the south wall (y = 0), facing away from it: turning sideways swings the
    # rear corners (0.42 m from the centre) into the wall.
    pose = np.array([[1.0, 0.36, math.pi / 2]])
    assert checker.base_free(pose)[0]
    (yaw,) = turn_until(checker.base_free, pose, np.array([0.0]))
    assert math.pi / 2 > yaw > 0.0
    stopped = np.array([[pose[0, 0], pose[0, 1], yaw]])
    assert checker.base_free(stopped)[0]
    # In the open it turns all the way.
    open_pose = np.array([[1.85, 1.0, math.pi / 2]])
    (yaw,) = turn_until(checker.base_free, open_pose, np.array([0.0]))
    assert yaw == pytest.approx(0.0)


def test_the_base_picks_facing_the_dish(checker):
    dish = np.array([1.85, 2.3])
    nominal = np.array([[1.85, 1.5], [1.5, 1.5]])
    noise = np.array([[0.05, -0.03, 0.2], [0.0, 0.0, 0.01]])
    poses, landed = pickup_poses(checker.base_free, nominal, dish, noise)
    assert landed.all()
    np.testing.assert_allclose(poses[:, :2], nominal + noise[:, :2])
    # A yaw error beyond the tolerance is turned away; a smaller one is left.
    assert poses[0, 2] == pytest.approx(facing_yaw(poses[0, :2], dish))
    assert abs(poses[1, 2] - facing_yaw(poses[1, :2], dish)) <= TURN_TOLERANCE
    assert poses[1, 2] == pytest.approx(facing_yaw(nominal[1], dish) + 0.01)


def test_a_landing_with_no_way_back_along_its_heading_comes_from_the_stop_it_was_sent_to():
    """Free everywhere but in a band 0.6 m deep behind the target: straight back along the
    heading is blocked, so the base, sent to a free stop beside it, lands at the first free
    pose on the way from there, not nowhere."""
    def free(poses):
        poses = np.asarray(poses).reshape(-1, 3)
        return ~((poses[:, 0] > -0.6) & (poses[:, 0] <= 0.0) & (np.abs(poses[:, 1]) < 0.05))

    target = np.array([[0.0, 0.0, 0.0]])  # heading +x: back is -x, all blocked to -0.6 m
    _, landed = stop_short(free, target)
    assert not landed[0]
    poses, landed = stop_short(free, target, sent=np.array([[0.0, 0.2]]))
    assert landed[0] and poses[0, 0] == 0.0 and 0.05 <= poses[0, 1] <= 0.05 + 0.02 + 1e-9
