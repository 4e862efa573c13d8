"""The base's motion profile (planning/navigation/base_motion.py): the segments and durations
that the BaseNavigator plays and the planner's cost model times."""

import itertools
import math
from pathlib import Path

import numpy as np
import pytest
from pydrake.common.value import AbstractValue
from shapely.geometry import LineString, Point

from s3o_drake.execution.base_navigator import BaseNavigator
from s3o_drake.execution.controllers import navigator_params
from s3o_drake.execution.messages import BaseCommand, CommandState
from s3o_drake.planning.navigation.base_motion import (
    CORNER_CUT,
    BaseProfile,
    MovingDrive,
    MovingTurn,
    SegmentSpec,
    backs_away,
    chain_time,
    motion_segments,
    smooth_chain_time,
    smooth_segments,
    trapezoid,
)
from s3o_drake.world.angles import wrap
from s3o_drake.world.choices import MOTIONS
from s3o_drake.world.robot import load_robot
from s3o_drake.world.scenario import load_scenario, with_overrides

UR5E = load_robot("ur5e")

REPO = Path(__file__).resolve().parents[2]
PROFILE = BaseProfile(speed=0.4)


def test_trapezoid_cruises_or_peaks_half_way():
    # 2 m at 0.4 m/s, 1 m/s²: 0.4 s ramps each way cover 0.08 m, the 1.84 m cruise 4.6 s.
    assert trapezoid(2.0, 0.4, 1.0) == pytest.approx((0.4, 0.4 + 4.6 + 0.4))
    # 0.1 m never reaches 0.4 m/s: peaks at sqrt(0.1) m/s, two ramps of sqrt(0.1) s.
    peak, duration = trapezoid(0.1, 0.4, 1.0)
    assert peak == pytest.approx(math.sqrt(0.1)) and duration == pytest.approx(2 * math.sqrt(0.1))
    assert trapezoid(0.0, 0.4, 1.0)[1] == 0.0
    # Arrays give the same numbers as scalars.
    lengths = np.array([0.0, 0.05, 0.16, 0.17, 3.0])
    np.testing.assert_allclose(PROFILE.drive_time(lengths),
                               [PROFILE.drive_time(float(x)) for x in lengths])
    assert PROFILE.turn_time(-1.0) == PROFILE.turn_time(1.0)


def test_backing_away_beyond_a_right_angle():
    assert not backs_away(0.0, 1.5)
    assert backs_away(0.0, 1.6)
    assert not backs_away(3.0, -3.0)  # 0.28 rad apart through π, not 6 rad
    np.testing.assert_array_equal(backs_away(np.array([0.0, math.pi]), 0.0), [False, True])


def test_segments_turn_drive_and_back_away():
    # Facing north; the first leg goes south (backed), the second east, then face west.
    segs = motion_segments([(0, 0), (0, -1), (1, -1)], math.pi / 2, math.pi)
    kinds = [(s.turn, round(s.length, 9)) for s in segs]
    # Backing: no turn, drive 1 m; then turn from north (backed south) to east: -pi/2;
    # drive 1 m; turn east -> west: pi.
    assert kinds == [(False, 1.0), (True, round(math.pi / 2, 9)), (False, 1.0),
                     (True, round(math.pi, 9))]
    assert segs[0].start[2] == segs[0].end[2] == pytest.approx(math.pi / 2)


def _random_paths(rng, m: int, k: int):
    points = rng.uniform(0, 5, (m, k + 1, 2))
    return points, rng.uniform(-math.pi, math.pi, m), rng.uniform(-math.pi, math.pi, m)


def test_chain_time_equals_the_segments_timed_one_by_one():
    rng = np.random.default_rng(3)
    points, yaw0, yaw1 = _random_paths(rng, 200, 4)
    # One item per leg; every other path gets a zero-length leg (skipped by both).
    points[::2, 2] = points[::2, 1]
    d = np.diff(points, axis=1)
    heading = np.arctan2(d[..., 1], d[..., 0])
    length = np.hypot(d[..., 0], d[..., 1])
    got, end = chain_time(PROFILE, heading, heading, length, PROFILE.drive_time(length),
                          yaw0, yaw1)
    want = [PROFILE.motion_time(p, a, b) for p, a, b in zip(points, yaw0, yaw1, strict=True)]
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(end, yaw1)


def test_chain_time_with_a_stretch_of_legs_and_no_final_yaw():
    rng = np.random.default_rng(4)
    points, yaw0, _ = _random_paths(rng, 50, 5)
    d = np.diff(points, axis=1)
    heading = np.arctan2(d[..., 1], d[..., 0])
    length = np.hypot(d[..., 0], d[..., 1])
    # Legs 2..3 as one stretch: its own time holds their drives and the turn between them.
    inner = PROFILE.turn_time(wrap(heading[:, 3] - heading[:, 2]))
    stretch_time = PROFILE.drive_time(length[:, 2]) + inner + PROFILE.drive_time(length[:, 3])
    cols = [0, 1, 2, 4]
    h_in = heading[:, cols]
    h_out = h_in.copy()
    h_out[:, 2] = heading[:, 3]
    lengths = length[:, cols].copy()
    lengths[:, 2] += length[:, 3]
    own = PROFILE.drive_time(length[:, cols])
    own[:, 2] = stretch_time
    # NaN: the landing faces along the last leg (the plan's yaw of a goto without pickup).
    got, end = chain_time(PROFILE, h_in, h_out, lengths, own, yaw0, np.full(50, np.nan))
    last = np.arctan2(*(points[:, -1] - points[:, -2]).T[::-1])
    want = [PROFILE.motion_time(p, a, b) for p, a, b in zip(points, yaw0, last, strict=True)]
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(end, last)


@pytest.mark.parametrize("motion", MOTIONS)
def test_the_navigator_plays_the_profile_time(motion):
    """The navigator's motion lasts what the profile says, for constructed paths, stopping
    at every corner or driving through them."""
    scenario = with_overrides(load_scenario(REPO / "scenarios" / "small" / "two_dishes.yaml"),
                              (f"execution.motion={motion}",))
    navigator = BaseNavigator(robot=scenario.robot_value,
                              params=navigator_params(scenario, noise=False))
    profile = BaseProfile(speed=scenario.planner.speed, motion=motion)
    rng = np.random.default_rng(5)
    for cid in range(1, 21):
        points = rng.uniform(0.5, 3.5, (int(rng.integers(2, 6)), 2))
        yaw0, yaw1 = rng.uniform(-math.pi, math.pi, 2)
        context = navigator.CreateDefaultContext()
        state = np.zeros(2 * UR5E.num_positions)
        state[:3] = [*points[0], yaw0]
        navigator.GetInputPort("robot_state").FixValue(context, state)
        command = BaseCommand(id=cid, path=tuple(map(tuple, points)), pose=(*points[-1], yaw1))
        navigator.GetInputPort("base_command").FixValue(context, AbstractValue.Make(command))
        navigator.CalcForcedUnrestrictedUpdate(context, context.get_mutable_state())
        played = context.get_abstract_state(0).get_value()
        assert played.duration == pytest.approx(profile.motion_time(points, yaw0, yaw1),
                                                rel=1e-12)
        # Its status turns done settle_time after the motion ends, not before.
        end = played.duration + profile.settle_time
        context.SetTime(end - 1e-6)
        assert navigator.GetOutputPort("status").Eval(context).state is CommandState.RUNNING
        context.SetTime(end + 1e-6)
        assert navigator.GetOutputPort("status").Eval(context).state is CommandState.DONE


# --- smooth motion --------------------------------------------------------------------------

SMOOTH = BaseProfile(speed=0.4, motion="smooth")
HOLONOMIC = BaseProfile(speed=0.4, motion="smooth", holonomic=True)


def _rounded_corner(center, radius: float = 0.447, start: float = -math.pi / 2,
                    turn: float = math.pi / 2, pieces: int = 4) -> list[np.ndarray]:
    """The polyline the navigation map makes round an obstacle's corner: short legs on a
    circle."""
    return [np.asarray(center) + radius * np.array([math.cos(start + turn * q / pieces),
                                                    math.sin(start + turn * q / pieces)])
            for q in range(pieces + 1)]


def _smooth_paths(rng, m: int = 200, k: int = 6) -> tuple[np.ndarray, np.ndarray]:
    points = rng.uniform(0, 5, (m, k + 1, 2))
    points[::3, 2] = points[::3, 1]  # a leg of no length
    for r in range(0, m, 4):  # a rounded corner in the middle
        points[r, 1:6] = _rounded_corner(rng.uniform(1, 4, 2), start=rng.uniform(-3, 3),
                                         turn=rng.choice([-1, 1]) * math.pi / 2)
    count = np.full(m, k + 1)
    count[::7] = 3
    return points, count


def _states(segments) -> list[tuple[np.ndarray, np.ndarray]]:
    """Each segment's (first, last) [x, y, yaw, rates]; a turn in place's from its poses."""
    out = []
    for s in segments:
        if isinstance(s, SegmentSpec):
            out.append((np.array([*s.start, 0, 0, 0]), np.array([*s.end, 0, 0, 0])))
        else:
            out.append((np.array(s.state(0.0)), np.array(s.state(s.duration))))
    return out


@pytest.mark.parametrize("profile", [SMOOTH, HOLONOMIC], ids=["differential", "holonomic"])
def test_smooth_times_are_the_segments_timed_one_by_one(profile):
    """The planner's vectorised time (`smooth_chain_time`) is the navigator's segments'
    (`smooth_segments`): one arithmetic. The segments join without a jump in pose or speed,
    and end at the path's end with the landing yaw."""
    rng = np.random.default_rng(4)
    points, count = _smooth_paths(rng)
    yaw0 = rng.uniform(-math.pi, math.pi, len(points))
    yaw1 = rng.uniform(-math.pi, math.pi, len(points))
    yaw1[::5] = np.nan
    got, landing = smooth_chain_time(profile, points, count, yaw0, yaw1)
    for p, n, a, b, t in zip(points, count, yaw0, landing, got, strict=True):
        segments = smooth_segments(profile, p[:n], a, b)
        assert profile.motion_time(p[:n], a, b) == pytest.approx(t, abs=1e-4)
        states = _states(segments)
        for (_, end), (start, _) in itertools.pairwise(states):
            np.testing.assert_allclose(start, end, atol=1e-6)
        assert states[-1][1][:2] == pytest.approx(p[n - 1], abs=1e-9)
        assert wrap(states[-1][1][2] - b) == pytest.approx(0.0, abs=1e-9)
        assert np.abs(states[-1][1][3:]).max() < 1e-9  # at rest


def test_a_rounded_corner_is_one_moving_turn_within_the_limits():
    """The map's rounded corner (four short legs round a table's corner) is driven through
    as one turn of 90 degrees without stopping, within the base's speed, yaw rate, yaw
    acceleration and linear acceleration, cutting no more than CORNER_CUT inside the path;
    the drive then takes a third less time than stopping at each corner."""
    path = [np.array([-2.0, -0.447]), *_rounded_corner((0.0, 0.0)), np.array([0.447, 2.0])]
    segments = smooth_segments(SMOOTH, path, 0.0, math.pi / 2)
    turns = [s for s in segments if isinstance(s, MovingTurn)]
    assert len(turns) == 1 and turns[0].angle == pytest.approx(math.pi / 2)
    assert not [s for s in segments if isinstance(s, SegmentSpec)]  # no turn in place
    t = np.linspace(0.0, sum(s.duration for s in segments), 4000)
    states = []
    for tau in t:
        for s in segments:
            if tau <= s.duration:
                states.append(s.state(tau))
                break
            tau -= s.duration
    states = np.array(states)
    speed = np.hypot(states[:, 3], states[:, 4])
    dt = t[1] - t[0]
    assert speed.max() <= SMOOTH.speed + 1e-9
    assert np.abs(states[:, 5]).max() <= SMOOTH.yaw_rate + 1e-9
    assert np.abs(np.diff(states[:, 5])).max() / dt <= SMOOTH.yaw_acceleration * 1.01
    assert np.abs(np.diff(speed)).max() / dt <= SMOOTH.acceleration * 1.01
    line = LineString([tuple(p) for p in path])
    deviation = max(line.distance(Point(x, y)) for x, y in states[:, :2])
    assert 0.02 < deviation <= CORNER_CUT + 1e-6
    stop_and_go = PROFILE.motion_time(path, 0.0, math.pi / 2)
    assert SMOOTH.motion_time(path, 0.0, math.pi / 2) < 0.7 * stop_and_go


def test_a_differential_base_still_turns_in_place_to_start_and_to_land():
    """It cannot move sideways: it turns to its first leg (or backs it) and to the landing
    yaw at rest; a holonomic base turns while it drives and takes no longer than its
    translation or its turn, whichever is longer."""
    path = [(0.0, 0.0), (2.0, 0.0)]
    kinds = [type(s).__name__ for s in smooth_segments(SMOOTH, path, 1.4, -math.pi / 2)]
    assert kinds == ["SegmentSpec", "MovingDrive", "SegmentSpec"]
    (motion,) = smooth_segments(HOLONOMIC, path, math.pi / 2, math.pi)
    assert motion.duration == pytest.approx(max(HOLONOMIC.drive_time(2.0),
                                                HOLONOMIC.turn_time(math.pi / 2)))
    halfway = motion.state(motion.yaw_duration / 2)  # turned halfway, while it drives
    assert halfway[2] == pytest.approx(3 * math.pi / 4) and halfway[3] > 0.1


def test_an_unknown_motion_is_refused():
    with pytest.raises(ValueError, match="motion"):
        BaseProfile(speed=0.4, motion="glide")


def test_a_differential_base_backs_its_first_leg_where_that_turns_it_less():
    """Facing a table (north), it backs a leg straight away from it without turning; a leg
    across it (100 degrees off) that the path follows on is driven forwards, where backing
    it turned 1.4 rad one way at the start and 3.1 rad the other way at the cusp."""
    def in_place(path, yaw, target):
        segments = smooth_segments(SMOOTH, path, yaw, target)
        return [round(s.end[2] - s.start[2], 2) for s in segments
                if isinstance(s, SegmentSpec)], segments

    turns, segments = in_place([(0.0, 0.0), (0.0, -1.0), (1.5, -1.0)], math.pi / 2, 0.0)
    assert turns[0] == pytest.approx(-math.pi / 2, abs=0.01)  # only the cusp
    assert len(turns) == 1 and segments[0].end[2] == pytest.approx(math.pi / 2)
    across = math.radians(100)
    first = (math.cos(math.pi / 2 + across), math.sin(math.pi / 2 + across))
    path = [(0.0, 0.0), first, (first[0] - 2.0, first[1] - 0.2)]
    turns, segments = in_place(path, math.pi / 2, math.pi)
    assert sum(abs(t) for t in turns) < 1.9
    assert isinstance(segments[1], MovingDrive) and segments[1].start[2] == pytest.approx(
        math.pi / 2 + across)  # facing along it
    other = smooth_segments(SMOOTH, path, math.pi / 2, math.pi, other_way=True)
    assert sum(s.length for s in other if isinstance(s, SegmentSpec)) > 4.0
    # The planner times the motion the navigator plays.
    points = np.array(path)[None]
    time, _ = smooth_chain_time(SMOOTH, points, np.array([3]), np.array([math.pi / 2]),
                                np.array([math.pi]))
    assert time[0] == pytest.approx(SMOOTH.motion_time(path, math.pi / 2, math.pi))
