"""BaseScanner: four depth rows around the base make a planar scan in the base's frame; in
the simulated restaurant it falls on the room's walls and legs."""

import math

import numpy as np
import pytest
from pydrake.systems.sensors import ImageDepth32F

from s3o_drake.world.base_scanner import (
    SCAN_FOV,
    SCAN_HEIGHT,
    SIDE_OFFSET,
    BaseScanner,
    scanner_info,
    scanner_mounts,
)
from s3o_drake.world.builder import build_world_diagram, robot_hold_state
from s3o_drake.world.scan_matching import RoomSection, match_scan
from s3o_drake.world.scenario import load_scenario, with_overrides
from tests.conftest import TWO_DISHES

MOUNTS = scanner_mounts(base_length=0.6, base_width=0.4)


def _row(depth: float) -> ImageDepth32F:
    image = ImageDepth32F(scanner_info().width(), scanner_info().height())
    image.mutable_data[:] = depth
    return image


def test_the_cameras_sit_outside_each_side_and_look_out_level():
    front, left = MOUNTS[:2]
    np.testing.assert_allclose(front.translation(), [0.3 + SIDE_OFFSET, 0.0, SCAN_HEIGHT],
                               atol=1e-12)
    np.testing.assert_allclose(left.translation(), [0.0, 0.2 + SIDE_OFFSET, SCAN_HEIGHT],
                               atol=1e-12)
    for X_BC, heading in zip(MOUNTS, (0.0, 0.5 * math.pi, math.pi, 1.5 * math.pi),
                             strict=True):
        axis = X_BC.rotation().matrix()[:, 2]
        np.testing.assert_allclose(axis, [math.cos(heading), math.sin(heading), 0.0],
                                   atol=1e-12)


def test_a_wall_ahead_is_a_line_of_returns_and_nothing_seen_is_left_out():
    scanner = BaseScanner(mounts=MOUNTS, info=scanner_info())
    context = scanner.CreateDefaultContext()
    scanner.GetInputPort("depth_0").FixValue(context, _row(2.0))  # a wall 2 m ahead
    for i in (1, 2, 3):
        scanner.GetInputPort(f"depth_{i}").FixValue(context, _row(np.inf))
    points = np.array(scanner.GetOutputPort("base_scan").Eval(context).points_B)
    assert len(points) == scanner_info().width()
    np.testing.assert_allclose(points[:, 0], 0.3 + SIDE_OFFSET + 2.0, atol=1e-6)
    half_width = 2.0 * math.tan(SCAN_FOV / 2)
    assert np.abs(points[:, 1]).max() == pytest.approx(half_width)  # the view's edge
    assert len(np.unique(points[:, 1].round(9))) == len(points)


def test_in_the_restaurant_the_scan_places_the_base_where_it_stands():
    """The world with the robot localising by its report has the scanner; its scan,
    matched to the room (every chair known), puts the base at its true pose, and matched
    to the map alone (the unmapped chairs' legs unknown), within a millimetre."""
    scenario = with_overrides(load_scenario(TWO_DISHES.parents[1] / "restaurant.yaml"),
                              ["uncertainty.localization=reported"])
    world = build_world_diagram(scenario, seed=0)
    context = world.CreateDefaultContext()
    world.GetInputPort("robot_desired_state").FixValue(context, robot_hold_state(scenario))
    points = np.array(world.GetOutputPort("base_scan").Eval(context).points_B)
    assert len(points) > 500
    true = np.array(scenario.robot.start)
    prior = true + np.array([0.03, -0.02, 0.02])
    room = RoomSection(scenario.room, scenario.tables, [c.pose for c in scenario.chairs])
    found = match_scan(room, points, prior=prior)
    np.testing.assert_allclose(found.X_WB, true, atol=1e-4)
    assert found.inliers == len(points) and found.rms < 1e-4
    mapped = RoomSection(scenario.room, scenario.tables,
                         [c.pose for c in scenario.chairs if c.mapped])
    found = match_scan(mapped, points, prior=prior)
    np.testing.assert_allclose(found.X_WB, true, atol=1e-3)
    assert found.inliers < len(points)  # the unmapped chairs' legs
