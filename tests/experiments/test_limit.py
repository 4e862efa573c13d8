"""The lower bound on a task's execution time: its parts on geometry whose answer is known.
(That no executed run falls below it is checked on the local study's runs,
tests/experiments/test_evaluate.py.)"""

import math

import numpy as np
import pytest
import shapely

from s3o_drake.experiments.limit import (
    pickable_region,
    stroke_time,
    tour_length,
)
from s3o_drake.feasibility.oracle import Heatmap


def test_a_stroke_is_a_trapezoid_or_a_triangle():
    # 0.07 m at 0.1 m/s and 0.5 m/s²: cruises (0.02 m to reach 0.1 m/s and stop).
    assert stroke_time(0.07, 0.1, 0.5) == pytest.approx(0.07 / 0.1 + 0.1 / 0.5)
    # 0.01 m never reaches the cruise speed: accelerate half way, brake the rest.
    assert stroke_time(0.01, 0.1, 0.5) == pytest.approx(2 * math.sqrt(0.01 / 0.5))
    assert stroke_time(0.0, 0.1, 0.5) == 0.0


def test_the_tour_is_the_spanning_tree_of_the_start_and_the_regions():
    square = shapely.box(0, 0, 1, 1)
    # A row of squares 1 m apart, east of the start: 2 + 1 + 1.
    row = [shapely.affinity.translate(square, 2 + 2 * k, 0) for k in range(3)]
    assert tour_length((0.0, 0.5), row) == pytest.approx(4.0)
    # Two regions that overlap cost nothing between them (one stop may serve both), and
    # the tree still joins the third: 2 (start to the first) + 0 + 1.
    overlapping = [row[0], shapely.affinity.translate(row[0], 0.5, 0), row[1]]
    assert tour_length((0.0, 0.5), overlapping) == pytest.approx(2.5)
    assert tour_length((0.0, 0.0), []) == 0.0


def test_the_pickable_region_is_the_cells_with_a_chance():
    values = np.zeros((4, 4))
    values[1, 2] = 0.3
    values[2, 2] = 1e-6
    region = pickable_region(Heatmap("d", values, x0=10.0, y0=20.0, cell=0.5))
    assert region.equals(shapely.box(11.0, 20.5, 11.5, 21.5))
    assert pickable_region(Heatmap("d", np.zeros((2, 2)), 0.0, 0.0, 1.0)).is_empty
