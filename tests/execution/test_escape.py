"""The base's motion and its escapes over a collision predicate, without Drake: each test's
world is a few lines of numpy."""

import math
import subprocess
import sys

import numpy as np
import pytest

from s3o_drake.execution.escape import (
    ESCAPE_STEPS,
    FINAL_APPROACH,
    BaseSegment,
    MotionProfile,
    cut_at_collision,
    extend_trail,
    facing,
    plan_motion,
)
from s3o_drake.feasibility.landing import PaddedFree
from s3o_drake.world.angles import wrap

PROFILE = MotionProfile(speed=0.4)


def test_the_escape_search_imports_no_drake():
    code = ("import sys, s3o_drake.execution.escape; "
            "print([m for m in sys.modules if m.startswith('pydrake')])")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "[]"


def _drive(base, target, free, *, path=None, trail=(), turn=False):
    base, target = np.asarray(base, float), np.asarray(target, float)
    path = path if path is not None else (tuple(base[:2]), tuple(target[:2]))
    return plan_motion(base, target, path=path, stop=target, turn=turn, trail=trail,
                       free=free, profile=PROFILE)


def _end(cut) -> np.ndarray:
    """Where the motion ends (x, y, yaw), its yaw wrapped to (-π, π]."""
    end = np.asarray(cut.segments[-1].end)
    return np.array([end[0], end[1], wrap(end[2])])


def _all_free(cut, free) -> bool:
    poses = [seg.pose(s) for seg in cut.segments
             for s in np.linspace(0.0, seg.length, 30)]
    return bool(np.all(free(np.array(poses))))


def test_a_free_way_is_the_direct_motion():
    for free in (None, lambda poses: np.ones(len(poses), dtype=bool)):
        cut = _drive((0.0, 0.0, 0.0), (2.0, 1.0, 1.0), free)
        assert not cut.blocked and cut.hit is None
        kinds = [seg.turn for seg in cut.segments]
        assert kinds == [True, False, True]  # turn, drive, turn to the landing's yaw
        np.testing.assert_allclose(_end(cut), [2.0, 1.0, 1.0])


def test_a_collision_near_the_end_only_shortens_the_landing():
    def free(poses):  # a wall at x = 1.9
        return poses[:, 0] < 1.9

    cut = _drive((0.0, 0.0, 0.0), (2.0, 0.0, 0.0), free)
    assert not cut.blocked and cut.hit is not None and cut.hit[0] >= 1.9
    end = _end(cut)
    assert 1.9 - 0.05 < end[0] < 1.9 and free(end[None])[0]


def test_a_collision_far_from_the_end_blocks_the_way():
    def free(poses):  # a wall across the way, and no way round it
        return poses[:, 0] < 1.0

    cut = _drive((0.0, 0.0, 0.0), (3.0, 0.0, 0.0), free)
    assert cut.blocked and cut.hit[0] >= 1.0
    assert 3.0 - _end(cut)[0] > FINAL_APPROACH


def test_collisions_where_the_base_starts_are_ignored_until_it_is_free():
    def free(poses):  # the base starts a hair inside something
        return poses[:, 0] > 0.05

    cut = _drive((0.0, 0.0, 0.0), (2.0, 0.0, 0.0), free)
    assert not cut.blocked and cut.hit is None


def test_a_base_inside_the_padding_leaves_it_without_touching():
    """A landing left the base 5 mm from a table leg at its right front corner: inside the
    padding, so the first poses are not free. Turning right where it stands swings the
    corner into the leg. A plain test lets the base do it (nothing counts until the first
    free pose); a padded one knows the touch, and the base backs out first."""
    def padded(poses):  # free 2 cm back from the leg, and not turned right near it
        x, y, yaw = poses.T
        near = (np.abs(y) < 0.15) & (x > -0.2)
        return ~(near & ((x > -0.02) | (wrap(yaw) < -0.3)))

    def untouched(poses):  # the leg itself: a right turn where the base stands hits it
        x, y, yaw = poses.T
        return ~((np.abs(y) < 0.15) & (x > -0.1) & (wrap(yaw) < -0.2))

    target = (0.0, -2.0, -math.pi / 2)
    plain = _drive((0.0, 0.0, 0.0), target, padded)
    assert plain.segments[0].turn and not untouched(np.array([_end(_first(plain))]))[0]
    cut = _drive((0.0, 0.0, 0.0), target, PaddedFree(padded, untouched))
    assert not cut.blocked and not cut.segments[0].turn  # backs out first
    poses = [seg.pose(s) for seg in cut.segments for s in np.linspace(0.0, seg.length, 30)]
    assert np.all(untouched(np.array(poses)))
    np.testing.assert_allclose(_end(cut), [0.0, -2.0, -math.pi / 2], atol=1e-12)


def _first(cut):
    """The cut's first segment alone, as a cut."""
    return type(cut)(cut.segments[:1])


def test_a_turn_the_short_way_blocked_is_made_the_other_way_round():
    def free(poses):  # turning clockwise from yaw 0 hits a chair on the right
        yaw = wrap(poses[:, 2])
        return (yaw > -0.1) | (yaw < -1.2)

    cut = _drive((0.0, 0.0, 0.0), (0.0, -2.0, -math.pi / 2), free)
    assert not cut.blocked
    first = cut.segments[0]
    assert first.turn and first.end[2] > first.start[2]  # anticlockwise, the long way
    assert _all_free(cut, free)


def test_a_base_that_cannot_turn_where_it_stands_backs_out_first():
    def free(poses):  # a pocket: no turning within 0.2 m of where the base stands
        x, y, yaw = poses.T
        return ~((x > -0.2) & (np.abs(y) < 0.1) & (np.abs(wrap(yaw)) > 0.3))

    cut = _drive((0.0, 0.0, 0.0), (0.0, 2.0, math.pi / 2), free)
    assert not cut.blocked
    backed = cut.segments[0]
    assert not backed.turn and backed.end[0] == pytest.approx(-0.25)  # 5 cm steps
    assert -backed.end[0] in [pytest.approx(s) for s in ESCAPE_STEPS]
    np.testing.assert_allclose(_end(cut), [0.0, 2.0, math.pi / 2], atol=1e-12)
    assert _all_free(cut, free)


def _aisle(poses):
    """Open floor at x >= 4.5; west of it an aisle the base fits only facing west."""
    x, y, yaw = poses.T
    return (x >= 4.5) | ((x >= 2.9) & (np.abs(y) < 0.01) & (np.abs(wrap(yaw - math.pi)) < 0.01))


def test_a_base_that_cannot_leave_a_tight_spot_goes_back_the_way_it_came():
    came = PROFILE.segment((5.0, 0.0, math.pi), (3.0, 0.0, math.pi), turn=False, length=2.0)
    trail = extend_trail((), [came])
    cut = _drive((3.0, 0.0, math.pi), (6.0, 1.0, 0.0), _aisle, trail=trail)
    assert not cut.blocked
    back = cut.segments[0]
    assert back.start == (3.0, 0.0, math.pi) and back.end == (5.0, 0.0, math.pi)
    np.testing.assert_allclose(_end(cut), [6.0, 1.0, 0.0], atol=1e-12)
    assert _all_free(cut, _aisle)
    # A base that did not come that way (or stands off its trail's end) is blocked.
    assert _drive((3.0, 0.0, math.pi), (6.0, 1.0, 0.0), _aisle).blocked
    assert _drive((3.2, 0.0, math.pi), (6.0, 1.0, 0.0), _aisle, trail=trail).blocked


def test_a_noisy_landing_is_reached_along_the_planned_leg():
    """The planned leg runs along y = 0 to the stop (3, 0); the landing is 0.3 m north. The
    straight drive to it swings the whole leg into what the planned one clears."""
    def free(poses):
        x, y, _ = poses.T
        return (y < 0.05) | (x > 2.5)

    stop = np.array([3.0, 0.0])
    cut = plan_motion(np.array([0.0, 0.0, 0.0]), np.array([3.0, 0.3, 0.0]),
                      path=((0.0, 0.0), (3.0, 0.0)), stop=stop, turn=False, trail=(),
                      free=free, profile=PROFILE)
    assert not cut.blocked and _all_free(cut, free)
    drives = [seg for seg in cut.segments if not seg.turn]
    assert drives[0].end[1] == pytest.approx(0.0) and 2.5 < drives[0].end[0] < 3.0
    np.testing.assert_allclose(_end(cut)[:2], [3.0, 0.3], atol=1e-12)


def test_a_stop_it_cannot_turn_in_is_driven_into_along_its_heading():
    """The final turn at the stop (2, 0) towards north is blocked: the base turns before it
    and drives the last 0.3 m straight in, facing the stop's heading."""
    def free(poses):
        x, y, yaw = poses.T
        return ~((x > 1.5) & (np.abs(y) < 0.3) & (yaw > 0.2) & (yaw < 1.4))

    target = (2.0, 0.0, math.pi / 2)
    cut = _drive((0.0, 0.0, 0.0), target, free)
    assert not cut.blocked and facing(cut.segments, target[2]) and _all_free(cut, free)
    last = cut.segments[-1]
    assert not last.turn and last.start[1] == pytest.approx(-0.3)
    np.testing.assert_allclose(_end(cut), target, atol=1e-12)


def test_a_cut_stops_a_sample_early_when_the_collision_is_a_hair_past_it():
    seg = PROFILE.segment((0.0, 0.0, 0.0), (1.0, 0.0, 0.0), turn=False, length=1.0)
    # Samples every 0.02 m: 0.5 is free, the collision starts 0.0005 m past it.
    cut = cut_at_collision([seg], lambda p: p[:, 0] < 0.5005, PROFILE)
    assert _end(cut)[0] == pytest.approx(0.48)
    cut = cut_at_collision([seg], lambda p: p[:, 0] < 0.51, PROFILE)
    assert _end(cut)[0] == pytest.approx(0.5)


def test_the_trail_starts_at_the_last_long_drive_s_last_leg():
    def seg(start, end, turn=False):
        length = abs(end[2] - start[2]) if turn else math.dist(start[:2], end[:2])
        return BaseSegment.make(start, end, turn=turn, length=length, max_speed=1.0, accel=1.0)

    turn = seg((0, 0, 0), (0, 0, 1.0), turn=True)
    leg_1 = seg((0, 0, 1.0), (1, 0, 1.0))
    leg_2 = seg((1, 0, 1.0), (2, 0, 1.0))
    face = seg((2, 0, 1.0), (2, 0, 1.5), turn=True)
    trail = extend_trail((), [turn, leg_1, leg_2, face])
    assert trail == (leg_2, face)
    # A turn in place, or a short corrective move, adds to it.
    nudge = seg((2, 0, 1.5), (2.1, 0, 1.5))
    assert extend_trail(trail, [nudge]) == (leg_2, face, nudge)


def test_segments_follow_the_trapezoidal_profile():
    seg = PROFILE.segment((0.0, 0.0, 0.0), (2.0, 0.0, 0.0), turn=False, length=2.0)
    # 0.4 m/s reached in 0.4 s at 1 m/s²: 0.08 m to speed up, 0.08 to brake.
    assert seg.speed == pytest.approx(0.4) and seg.duration == pytest.approx(0.4 + 1.84 / 0.4
                                                                             + 0.4)
    assert seg.at(0.2) == pytest.approx((0.02, 0.2))
    assert seg.at(seg.duration) == pytest.approx((2.0, 0.0))
    np.testing.assert_allclose(seg.pose(1.0), [1.0, 0.0, 0.0])


def test_a_smooth_motion_whose_moved_lead_in_is_blocked_keeps_to_the_planned_leg():
    """The smooth motion moves the lead in to the stop (1.9, 0) by the landing's 0.2 m of
    noise; that leg clips a table the planned one clears. The base drives the planned leg,
    stopping and going, and lands where it was sent, not short and not blocked."""
    def free(poses):
        x, y, _ = poses.T
        return ~((x > 1.0) & (x < 1.8) & (y > 0.08))

    smooth = MotionProfile(speed=0.4, motion="smooth")
    target = np.array([2.0, 0.2, 0.0])
    cut = plan_motion(np.array([0.0, 0.0, 0.0]), target,
                      path=((0.0, 0.0), (1.9, 0.0), (2.0, 0.0)), stop=(2.0, 0.0), turn=False,
                      trail=(), free=free, profile=smooth)
    assert not cut.blocked and cut.hit is None and _all_free(cut, free)
    np.testing.assert_allclose(_end(cut), target, atol=1e-9)


def test_a_smooth_motion_out_of_a_tight_stop_is_kept_where_no_motion_can_face_the_next():
    """The base stands where it can turn only after backing out 5 cm, and at the next stop
    the turn to its heading is blocked whichever way the base comes. No motion lands facing
    it; the smooth one backed out of the first stop ends where the stop-and-go one does,
    so the base drives its path smoothly, not stopping at every corner."""
    def free(poses):
        x, y, yaw = poses.T
        pocket = (y < 0.04) & (np.abs(wrap(yaw + math.pi / 2)) > 0.05)
        at_stop = (y > 1.8) & (x > 0.4) & (np.abs(wrap(yaw - math.pi / 2)) > 0.1)
        return ~(pocket | at_stop)

    smooth = MotionProfile(speed=0.4, motion="smooth")
    base, target = np.array([0.0, 0.0, -math.pi / 2]), np.array([0.6, 2.0, 0.0])
    path = ((0.0, 0.0), (0.05, 0.6), (0.6, 1.2), (0.6, 2.0))
    cuts = [plan_motion(base, target, path=path, stop=target[:2], turn=False, trail=(),
                        free=free, profile=profile)
            for profile in (smooth, smooth.stop_and_go())]
    for cut in cuts:
        assert not cut.blocked and not facing(cut.segments, target[2])
        assert _all_free(cut, free)
    moving, stopping = cuts
    np.testing.assert_allclose(_end(moving)[:2], _end(stopping)[:2], atol=1e-9)
    assert not all(isinstance(seg, BaseSegment) for seg in moving.segments)
    assert (sum(seg.duration for seg in moving.segments)
            < sum(seg.duration for seg in stopping.segments) - 2.0)


def test_a_smooth_base_backed_out_of_a_tight_stop_backs_its_next_leg_where_that_turns_less():
    """The base cannot turn where it stands; its next stop is 12 cm away, through a way out
    0.6 m behind it. Backed 5 cm out, the smooth motion goes on as from a stop: it backs the
    leg to the way out (a small turn) instead of turning round to drive it, and round again
    at its end. The paper's stop-and-go motion takes the waypoints as they come."""
    yaw = 2.4

    def free(poses):
        x, y, heading = poses.T
        return ~((np.hypot(x, y) < 0.04) & (np.abs(wrap(heading - yaw)) > 0.05))

    smooth = MotionProfile(speed=0.4, motion="smooth")
    base, target = np.array([0.0, 0.0, yaw]), np.array([-0.02, -0.12, 1.64])
    path = ((0.0, 0.0), (0.62, -0.11), (-0.02, -0.12))

    def turned(cut) -> float:
        return sum(seg.length for seg in cut.segments if isinstance(seg, BaseSegment)
                   and seg.turn)

    moving, stopping = (plan_motion(base, target, path=path, stop=target[:2], turn=False,
                                    trail=(), free=free, profile=profile)
                        for profile in (smooth, smooth.stop_and_go()))
    for cut in (moving, stopping):
        assert not cut.blocked and cut.hit is None and _all_free(cut, free)
        np.testing.assert_allclose(_end(cut)[:2], target[:2], atol=1e-9)
    out = moving.segments[0]
    assert not out.turn and out.length == pytest.approx(ESCAPE_STEPS[0])
    assert turned(moving) < 2.5 < 6.0 < turned(stopping)
    assert (sum(seg.duration for seg in moving.segments)
            < sum(seg.duration for seg in stopping.segments) - 4.0)
