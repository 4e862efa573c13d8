"""Fig. 5 of a small study: every group keeps its place; a group without runs says so
instead of showing bars of 0; a real 0 is seen."""

import math

import matplotlib.pyplot as plt
import pytest
from matplotlib.patches import Rectangle

from s3o_drake.experiments.summary import Cell
from s3o_drake.viz.study import figure_five

GROUPS = ("easy", "moderate", "difficult")
METHODS = ("S3O-GROP*", "V-GROP*")


def _cell(group: str, method: str, completion: float, time: float) -> Cell:
    runs = 0 if math.isnan(completion) else 1
    return Cell(group, method, tasks=runs, runs=runs, seeds=runs, completion=completion,
                completion_std=math.nan, fraction=completion, fraction_std=math.nan,
                execution_time=time, execution_time_std=math.nan, planning_time=1.0)


@pytest.fixture
def figure():
    cells = [_cell("easy", m, 1.0, 170.0) for m in METHODS]
    cells += [_cell("moderate", "S3O-GROP*", 0.0, 150.0), _cell("moderate", "V-GROP*", 1.0, 160.0)]
    cells += [_cell("difficult", m, math.nan, math.nan) for m in METHODS]
    fig = figure_five(cells, METHODS, GROUPS)
    yield fig
    plt.close(fig)


def test_a_group_without_runs_keeps_its_place_and_says_so(figure):
    completion, _ = figure.axes[:2]
    for ax in figure.axes[:2]:
        low, high = ax.get_xlim()
        words = [t for t in ax.texts if t.get_text() == "no runs"]
        assert len(words) == len(METHODS)  # one per method, in the difficult group
        assert all(1.5 < t.get_position()[0] < 2.5 and low < t.get_position()[0] < high
                   for t in words)
        assert [t.get_text() for t in ax.get_xticklabels()] == ["Easy", "Moderate",
                                                                "Difficult"]
        bars = [p for p in ax.patches if isinstance(p, Rectangle) and p.get_width() < 1]
        assert all(p.get_x() + p.get_width() < 1.5 for p in bars)  # none in the empty group
    # The moderate group's real completion of 0 is a line where its bar would be.
    zero = [line for line in completion.lines
            if list(line.get_ydata()) == [0, 0] and 0.5 < min(line.get_xdata()) < 1.0]
    assert len(zero) == 1


def test_the_legend_stands_below_the_bars(figure):
    (legend,) = figure.legends
    box = legend.get_window_extent(figure.canvas.get_renderer())
    for ax in figure.axes[:2]:
        assert box.y1 <= ax.get_window_extent(figure.canvas.get_renderer()).y0
    assert [t.get_text() for t in legend.get_texts()] == list(METHODS)
