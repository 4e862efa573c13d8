"""Pictures a person reads faster than numbers: heatmaps over the room's top view."""

from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only; never a window
import matplotlib.pyplot as plt
import numpy as np

from s3o_drake.feasibility.oracle import Heatmap
from s3o_drake.io import write_atomically
from s3o_drake.scenario import Scenario


def _figure_bytes(fig) -> bytes:
    import io

    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=120, bbox_inches="tight")
    plt.close(fig)
    return buffer.getvalue()


def feasibility_figure(scenario: Scenario, top_view: np.ndarray, heatmaps: Sequence[Heatmap],
                       path: Path, *, title: str = "") -> None:
    """Each dish's Fea^m heatmap over the top view of the room (the paper's Fig. 3, left).

    `top_view` is an orthophoto of the room (row 0 north) spanning `scenario.room.bounds`.
    Where two crops overlap, the larger probability shows.
    """
    x_min, y_min, x_max, y_max = scenario.room.bounds
    fig, ax = plt.subplots(figsize=(10, 10 * (y_max - y_min) / (x_max - x_min)))
    ax.imshow(top_view, extent=(x_min, x_max, y_min, y_max), origin="upper")
    # Paint all crops into one room-sized layer so that overlaps take the maximum.
    cell = min(h.cell for h in heatmaps) if heatmaps else 0.05
    cols, rows = round((x_max - x_min) / cell), round((y_max - y_min) / cell)
    layer = np.zeros((rows, cols))
    xs = x_min + (np.arange(cols) + 0.5) * cell
    ys = y_min + (np.arange(rows) + 0.5) * cell
    for heatmap in heatmaps:
        j = np.floor((xs - heatmap.x0) / heatmap.cell).astype(int)
        i = np.floor((ys - heatmap.y0) / heatmap.cell).astype(int)
        h_rows, h_cols = heatmap.values.shape
        jj, ii = np.meshgrid(j, i)
        inside = (jj >= 0) & (jj < h_cols) & (ii >= 0) & (ii < h_rows)
        values = np.zeros_like(layer)
        values[inside] = heatmap.values[ii[inside], jj[inside]]
        layer = np.maximum(layer, values)
    shown = np.ma.masked_where(layer <= 0.0, layer)
    image = ax.imshow(shown, extent=(x_min, x_max, y_min, y_max), origin="lower",
                      cmap="plasma", vmin=0.0, vmax=1.0, alpha=0.75, interpolation="nearest")
    fig.colorbar(image, ax=ax, fraction=0.03, pad=0.02, label="Fea$^m$ (probability of a pick)")
    for dish in scenario.dishes:
        ax.plot(*dish.position, marker="o", markersize=5, color="cyan", markeredgecolor="k")
        ax.annotate(dish.name, dish.position, xytext=(4, 4), textcoords="offset points",
                    fontsize=8, color="k",
                    bbox={"boxstyle": "round,pad=0.15", "fc": "white", "alpha": 0.7})
    ax.set_xlim(x_min, x_max)
    ax.set_ylim(y_min, y_max)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(title or "Motion-level feasibility of each dish (base yaw facing the dish)")
    write_atomically(path, _figure_bytes(fig))
