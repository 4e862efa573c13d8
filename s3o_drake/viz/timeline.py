"""timeline.png: what the base and the arm did over a run, the one above the other, under
the actions they carried out (`s3o run` writes it)."""

from __future__ import annotations

import io
from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only; never a window
import matplotlib.pyplot as plt
import numpy as np

from s3o_drake.execution.activity import Activity
from s3o_drake.world.files import write_atomically

ACTION_COLOURS = {"goto": "#4C72B0", "pickup": "#DD8452", "place": "#55A868"}


def _spans(t: np.ndarray, on: np.ndarray) -> list[tuple[float, float]]:
    """The intervals of `t` where `on` holds."""
    spans, start = [], None
    for ti, flag in zip(t, on, strict=True):
        if flag and start is None:
            start = ti
        elif not flag and start is not None:
            spans.append((start, ti))
            start = None
    if start is not None:
        spans.append((start, t[-1]))
    return spans


def timeline_figure(activity: Activity, outcomes: Sequence[Sequence[str]],
                    outcome_times: Sequence[float], path: Path, *, title: str = "") -> None:
    """The actions (each from the end of the one before to its own end, named and coloured
    by kind, a failed one hatched), and below them when the base moved (its speed and yaw
    rate) and when the arm moved (its fastest joint), on one time axis, as a PNG."""
    fig, (acts, base, arm) = plt.subplots(
        3, 1, figsize=(12, 4.8), sharex=True, gridspec_kw={"height_ratios": [1.1, 1, 1]})
    start = 0.0
    for k, ((action, argument, result), end) in enumerate(
            zip(outcomes, outcome_times, strict=True)):
        failed = result != "done"
        acts.barh(0, end - start, left=start, height=0.8,
                  color=ACTION_COLOURS.get(action, "0.6"), alpha=0.85,
                  hatch="//" if failed else None, edgecolor="white")
        label = f"{action} {argument}" + (" (failed)" if failed else "")
        acts.text((start + end) / 2, 0.42 if k % 2 else -0.42, label, ha="center",
                  va="center", fontsize=6.5, clip_on=True)
        start = end
    acts.set_yticks([])
    acts.set_ylim(-0.8, 0.8)
    acts.set_ylabel("actions", rotation=0, ha="right", va="center")
    for ax, moving, curves, name in (
            (base, activity.base_moving,
             ((activity.base_speed, "speed (m/s)"), (activity.yaw_rate, "yaw rate (rad/s)")),
             "base"),
            (arm, activity.arm_moving, ((activity.arm_speed, "fastest joint (rad/s)"),),
             "arm")):
        for a, b in _spans(activity.t, moving):
            ax.axvspan(a, b, color="0.85", linewidth=0)
        for values, label in curves:
            ax.plot(activity.t, values, linewidth=0.9, label=label)
        ax.set_ylabel(f"{name}\nmoving", rotation=0, ha="right", va="center")
        ax.legend(loc="upper right", fontsize=7, frameon=False)
        ax.set_ylim(bottom=0.0)
    arm.set_xlabel("simulated time (s)")
    total = float(activity.t[-1]) if len(activity.t) else 0.0
    together = activity.together()
    fig.suptitle((title + "\n" if title else "")
                 + f"the base and the arm moved together for {together:.1f} s of "
                 f"{total:.1f} s (grey: moving)", fontsize=10)
    fig.tight_layout()
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=110)
    plt.close(fig)
    write_atomically(path, buffer.getvalue())
