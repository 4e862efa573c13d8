"""Scan matching: a planar scan of walls and legs, placed where it falls on what the robot
knows of the room, finds the base's pose from a prior a few centimetres off."""

import math

import numpy as np
import pytest
from shapely.geometry import LineString, box
from shapely.ops import unary_union

from s3o_drake.world.furniture import legs_section
from s3o_drake.world.map import Room, Table
from s3o_drake.world.scan_matching import (
    MIN_POINTS,
    RoomSection,
    match_scan,
    range_points,
)

ROOM = Room(bounds=[0.0, 0.0, 6.0, 5.0])
TABLES = (Table("long", center=[2.0, 3.5], yaw=0.0, size=[1.6, 0.8, 0.04]),
          Table("small", center=[4.5, 1.5], yaw=0.4, size=[0.7, 0.7, 0.04]))
CHAIR = (2.0, 2.6, -math.pi / 2)  # at the long table, facing it
MAX_RANGE = 8.0
BEARINGS = np.linspace(-math.pi, math.pi, 360, endpoint=False)


def _scan(X_WB, chairs):
    """What a scanner at the base's origin sees from X_WB (x, y, yaw): the range along each
    of BEARINGS to the first wall or leg (shapely's intersection of each ray)."""
    walls = box(*ROOM.bounds).exterior
    world = unary_union([walls, legs_section(TABLES, chairs).boundary])
    ranges = []
    for b in BEARINGS:
        a = X_WB[2] + b
        ray = LineString([X_WB[:2], (X_WB[0] + MAX_RANGE * math.cos(a),
                                     X_WB[1] + MAX_RANGE * math.sin(a))])
        hit = ray.intersection(world)
        ranges.append(MAX_RANGE if hit.is_empty else
                      min(math.dist(X_WB[:2], p.coords[0]) for p in getattr(hit, "geoms", [hit])))
    return np.array(ranges)


TRUE = np.array([3.1, 2.2, 0.3])
PRIOR = TRUE + np.array([0.03, -0.02, 0.02])  # the localisation's report: a few cm and 1 degree off


def test_a_scan_of_what_the_robot_knows_places_the_base_to_a_millimetre():
    section = RoomSection(ROOM, TABLES, [CHAIR])
    p_B = range_points(_scan(TRUE, [CHAIR]), BEARINGS, max_range=MAX_RANGE)
    found = match_scan(section, p_B, prior=PRIOR)
    assert found is not None
    np.testing.assert_allclose(found.X_WB[:2], TRUE[:2], atol=0.001)
    assert found.X_WB[2] == pytest.approx(TRUE[2], abs=0.001)
    assert found.inliers == len(p_B) and found.rms < 0.001


def test_a_chair_the_robot_does_not_know_weighs_little():
    """The scan sees a chair that is in no map and that perception missed: its legs'
    returns fall on nothing the robot knows, and the robust loss discounts them."""
    unknown = (3.6, 2.8, 0.0)
    section = RoomSection(ROOM, TABLES, [CHAIR])
    p_B = range_points(_scan(TRUE, [CHAIR, unknown]), BEARINGS, max_range=MAX_RANGE)
    found = match_scan(section, p_B, prior=PRIOR)
    assert found is not None
    np.testing.assert_allclose(found.X_WB[:2], TRUE[:2], atol=0.002)
    assert found.X_WB[2] == pytest.approx(TRUE[2], abs=0.002)
    assert found.inliers < len(p_B)  # the unknown chair's returns


def test_a_scan_that_sees_too_little_gives_no_pose():
    section = RoomSection(ROOM, TABLES, [CHAIR])
    ranges = _scan(TRUE, [CHAIR])
    few = np.full_like(ranges, MAX_RANGE)  # nothing within range ...
    few[:MIN_POINTS - 1] = ranges[:MIN_POINTS - 1]  # ... but a few returns
    assert match_scan(section, range_points(few, BEARINGS, max_range=MAX_RANGE),
                      prior=PRIOR) is None


def test_scan_points_are_the_returns_in_the_base_frame():
    p = range_points([1.0, MAX_RANGE, 2.0, np.inf], [0.0, 0.5, math.pi / 2, 1.0],
                    max_range=MAX_RANGE, p_BS=(0.1, 0.0))
    np.testing.assert_allclose(p, [[1.1, 0.0], [0.1, 2.0]], atol=1e-12)
