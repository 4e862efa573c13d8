"""The gap to the reference plan per task (`s3o bench limit --picture`): for each room, each
configuration's relative gap in predicted time and its gap in judged completion, task by
task."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import matplotlib
import matplotlib.figure

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np


def gap_figure(by_room: Mapping[str, Mapping[str, Sequence[Mapping]]]
               ) -> matplotlib.figure.Figure:
    """One column per room: above, each configuration's predicted time over the
    reference's minus 1 (%), below its judged completion minus the reference's, per task
    (in the order of the default's tasks); the median as a dashed line. `by_room`: room ->
    configuration -> rows with `task`, `time` and `completion`
    (`experiments.limit_study.gaps_by_room`)."""
    rooms = list(by_room)
    fig, axes = plt.subplots(2, max(1, len(rooms)), figsize=(6.5 * max(1, len(rooms)), 6.5),
                             squeeze=False, sharey="row")
    colours = plt.get_cmap("tab10")
    for column, room in enumerate(rooms):
        configurations = by_room[room]
        tasks = sorted({g["task"] for found in configurations.values() for g in found})
        at = {task: k for k, task in enumerate(tasks)}
        for k, (name, found) in enumerate(configurations.items()):
            x = np.array([at[g["task"]] for g in found]) + (k - len(configurations) / 2) * 0.08
            for row, field, scale in ((0, "time", 100.0), (1, "completion", 1.0)):
                values = np.array([g[field] for g in found]) * scale
                axis = axes[row][column]
                axis.plot(x, values, "o", ms=4, color=colours(k), label=name)
                axis.axhline(float(np.median(values)), color=colours(k), ls="--", lw=0.8)
        for row, label in ((0, "predicted time vs reference (%)"),
                           (1, "judged completion vs reference")):
            axis = axes[row][column]
            axis.axhline(0.0, color="black", lw=0.8)
            axis.set_ylabel(label)
            axis.grid(alpha=0.3)
        axes[0][column].set_title(f"{room} ({len(tasks)} tasks)")
        axes[0][column].set_xticks(range(len(tasks)))
        axes[0][column].set_xticklabels([])
        axes[1][column].set_xlabel("task")
        axes[1][column].set_xticks(range(len(tasks)))
        axes[1][column].set_xticklabels([Path(t).stem.replace("task_", "") for t in tasks],
                                        rotation=90, fontsize=7)
    axes[0][0].legend(fontsize=8, loc="upper right")
    fig.tight_layout()
    return fig


def plot_gaps(by_room: Mapping[str, Mapping[str, Sequence[Mapping]]], path: Path) -> None:
    """Writes `gap_figure` to `path`."""
    fig = gap_figure(by_room)
    fig.savefig(path, dpi=110)
    plt.close(fig)
