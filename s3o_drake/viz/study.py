"""A study's pictures: the paper's Fig. 5 (completion and execution time per difficulty group
and method) and Table I as an image (`s3o evaluate`)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Protocol

import matplotlib
import matplotlib.figure

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np


class GroupResult(Protocol):
    """What the figure reads of one method in one difficulty group (a study's summary
    makes them: `experiments.summary.Cell`)."""

    group: str
    method: str
    runs: int
    completion: float
    completion_std: float
    execution_time: float
    execution_time_std: float


def plot_figure_five(cells: Sequence[GroupResult], methods: Sequence[str], groups: Sequence[str],
                     path: Path) -> None:
    """Writes `figure_five` to `path`."""
    fig = figure_five(cells, methods, groups)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def figure_five(cells: Sequence[GroupResult], methods: Sequence[str], groups: Sequence[str]
                ) -> matplotlib.figure.Figure:
    """The paper's Fig. 5: completion rate and execution time per difficulty group (in the
    order given) and method, bars with the spread over seeds as error bars. A group without
    runs keeps its place, its bars replaced by the words "no runs"."""
    at = {(c.group, c.method): c for c in cells}
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.2))
    width = 0.8 / len(methods)
    x = np.arange(len(groups))
    colours = plt.get_cmap("tab10")
    for ax, (label, value, spread) in zip(axes, (
            ("task completion rate", "completion", "completion_std"),
            ("execution time (s, simulated)", "execution_time", "execution_time_std")),
            strict=True):
        for i, method in enumerate(methods):
            offset = x + (i - (len(methods) - 1) / 2) * width
            for k, g in enumerate(groups):
                cell = at[(g, method)]
                mean = getattr(cell, value)
                if math.isnan(mean):  # no runs (or none with a time): no bar, a word
                    ax.text(offset[k], 0, "no runs", rotation=90, ha="center", va="bottom",
                            fontsize=7, color="0.4")
                    continue
                err = getattr(cell, spread)
                ax.bar(offset[k], mean, width, color=colours(i),
                       yerr=None if math.isnan(err) else err, capsize=3)
                if mean == 0:  # a real 0 would be an invisible bar
                    ax.plot([offset[k] - width / 2, offset[k] + width / 2], [0, 0],
                            color=colours(i), linewidth=3)
        ax.set_xticks(x, [g.capitalize() for g in groups])
        ax.set_xlim(-0.5, len(groups) - 0.5)  # every group, with bars or not
        ax.set_ylabel(label)
        ax.grid(axis="y", alpha=0.3)
    axes[0].set_ylim(0, 1.05)
    handles = [plt.Rectangle((0, 0), 1, 1, color=colours(i)) for i in range(len(methods))]
    # Below the axes: a legend inside them covers bars.
    fig.legend(handles, methods, loc="lower center", ncol=min(len(methods), 7), fontsize=8,
               frameon=False)
    runs = sum(at[(g, methods[0])].runs for g in groups)
    fig.suptitle(f"Completion and execution time by task difficulty ({runs} runs per method; "
                 "error bars: standard deviation over seeds; times: runs with a plan)")
    fig.tight_layout(rect=(0, 0.07, 1, 1))
    return fig


def plot_table(rows: Sequence[Sequence[str]], labels: Sequence[str], title: str,
               path: Path) -> None:
    """A table of text as a picture (the study's Table I)."""
    fig, ax = plt.subplots(figsize=(2.7 * len(labels), 1.9))
    ax.axis("off")
    table = ax.table(cellText=[list(r) for r in rows], colLabels=list(labels), loc="center",
                     cellLoc="center")
    table.scale(1, 1.6)
    ax.set_title(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
