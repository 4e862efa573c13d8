"""The playback's first view (`first_view`): the page opens on the robot, large enough to
see its arm, with the room it works in behind it and no wall in between."""

import math

import numpy as np
import pytest

from s3o_drake.execution.execute import MESHCAT_FOV, first_view
from s3o_drake.world.resources import RESTAURANT, RESTAURANT_DENSE, SCENARIOS_DIR
from s3o_drake.world.scenario import load_scenario

ROBOT_TOP = 1.3  # m: the arm stowed above the deck


def _angle(a: np.ndarray, b: np.ndarray) -> float:
    return math.degrees(math.acos(np.clip(a @ b / np.linalg.norm(a) / np.linalg.norm(b), -1, 1)))


def _over_the_walls(p_WC: np.ndarray, p_WR: np.ndarray, bounds, wall_height: float) -> bool:
    """Whether the line from the camera to the robot's base passes above the walls."""
    for s in np.linspace(0.0, 1.0, 400):
        p = p_WC + s * (p_WR - p_WC)
        x_min, y_min, x_max, y_max = bounds
        on_a_wall = not (x_min < p[0] < x_max and y_min < p[1] < y_max)
        if on_a_wall and p[2] <= wall_height and (
                x_min - 0.1 < p[0] < x_max + 0.1 and y_min - 0.1 < p[1] < y_max + 0.1):
            return False
    return True


@pytest.mark.parametrize("path", [RESTAURANT, RESTAURANT_DENSE, SCENARIOS_DIR / "tidy_home.yaml",
                                  SCENARIOS_DIR / "small" / "two_dishes.yaml"],
                         ids=lambda p: p.stem)
def test_the_first_view_shows_the_robot_large_with_the_room_behind_it(path):
    scenario = load_scenario(path)
    bounds, start = scenario.room.bounds, scenario.robot.start
    p_WC, p_WT = first_view(bounds, start, scenario.room.wall_height)
    view = p_WT - p_WC
    base = np.array([start[0], start[1], 0.2])
    top = np.array([start[0], start[1], ROBOT_TOP])
    # The robot is in view and fills more than a quarter of its height.
    assert max(_angle(view, base - p_WC), _angle(view, top - p_WC)) < MESHCAT_FOV / 2
    assert _angle(base - p_WC, top - p_WC) > MESHCAT_FOV / 4
    # The room's centre is in view, beyond the robot.
    centre = np.array([(bounds[0] + bounds[2]) / 2, (bounds[1] + bounds[3]) / 2, 0.0])
    assert _angle(view, centre - p_WC) < MESHCAT_FOV / 2
    assert np.linalg.norm(centre - p_WC) >= np.linalg.norm(base - p_WC) - 0.5
    assert _over_the_walls(p_WC, base, bounds, scenario.room.wall_height)


def test_a_robot_against_a_wall_is_seen_over_it():
    bounds = [0.0, 0.0, 10.0, 8.0]
    start = (0.45, 4.0, 0.0)  # 0.45 m from the west wall, the room's centre to the east
    p_WC, _ = first_view(bounds, start, 1.0)
    assert p_WC[0] < 0.0  # outside the room, behind the robot
    assert _over_the_walls(p_WC, np.array([*start[:2], 0.2]), bounds, 1.0)
