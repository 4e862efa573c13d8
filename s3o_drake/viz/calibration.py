"""The reliability diagram of Fea^m against executed pickups (`s3o calibrate`)."""

from __future__ import annotations

import io
from collections.abc import Mapping
from pathlib import Path
from typing import Protocol

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from s3o_drake.world.files import write_atomically


class ReliabilityBin(Protocol):
    """What the diagram reads of one bin of predicted Fea^m."""

    low: float
    high: float
    count: int
    mean_predicted: float
    interval: tuple[float, float] | None
    """None for an empty bin, which the diagram leaves out."""

    @property
    def observed(self) -> float: ...


class ReliabilityCurve(Protocol):
    """What the diagram reads of one group's pickups (`s3o calibrate` makes them:
    `experiments.calibration.Calibration`)."""

    count: int
    ece: float
    brier: float
    bins: tuple[ReliabilityBin, ...]


def reliability_figure(figures: Mapping[str, ReliabilityCurve], path: Path, *,
                       title: str) -> None:
    """The reliability diagram of each group in `figures` (one curve each, all binned
    alike) above the pickups per bin, as a PNG at `path`."""
    first = next(iter(figures.values()))
    edges = [b.low for b in first.bins] + [first.bins[-1].high]
    width = edges[1] - edges[0]
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(6.4, 7.2), sharex=True,
                                      gridspec_kw={"height_ratios": [3, 1]})
    top.plot([0, 1], [0, 1], color="0.6", linestyle="--", linewidth=1, label="calibrated")
    groups = len(figures)
    for k, (name, f) in enumerate(figures.items()):
        filled = [b for b in f.bins if b.count]
        x = np.array([b.mean_predicted for b in filled])
        y = np.array([b.observed for b in filled])
        errors = np.array([[b.observed - b.interval[0], b.interval[1] - b.observed]
                           for b in filled]).T
        line = top.errorbar(x, y, yerr=errors, marker="o", capsize=3, linewidth=1.5,
                            label=f"{name}: {f.count} pickups, ECE {f.ece:.3f}, "
                                  f"Brier {f.brier:.3f}")
        colour = line[0].get_color()
        for b, xi, yi in zip(filled, x, y, strict=True):
            top.annotate(str(b.count), (xi, yi), textcoords="offset points", xytext=(5, -11),
                         fontsize=7, color=colour)
        # Side by side within each bin, one bar per group.
        offsets = np.array([b.low for b in f.bins]) + width * (k + 0.5) / groups
        counts = [b.count for b in f.bins]
        bars = bottom.bar(offsets, counts, width=width / groups * 0.9, color=colour)
        bottom.bar_label(bars, labels=[str(c) if c else "" for c in counts], fontsize=7)
    top.set_xlim(0, 1)
    # Room above a success of 1 for the legend, so that it hides no point.
    top.set_ylim(-0.02, 1.04 + 0.075 * (groups + 1))
    top.set_yticks(np.linspace(0.0, 1.0, 6))
    top.set_ylabel("observed success")
    top.set_title(title, fontsize=10)
    top.legend(loc="upper left", fontsize=8)
    top.grid(alpha=0.3)
    bottom.set_xticks(edges)
    bottom.set_xlabel("predicted Fea^m (bin)")
    bottom.set_ylabel("pickups")
    bottom.margins(y=0.25)
    fig.tight_layout()
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=120)
    plt.close(fig)
    write_atomically(Path(path), buffer.getvalue())
