"""Pictures a person reads faster than numbers: heatmaps, state spaces, the motion search
and the plan over the top view of the room."""

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import matplotlib

matplotlib.use("Agg")  # files only; never a window
import matplotlib.pyplot as plt
import numpy as np
from shapely.ops import unary_union

from s3o_drake.feasibility.oracle import Heatmap
from s3o_drake.io import write_atomically
from s3o_drake.scenario import Scenario

if TYPE_CHECKING:
    from s3o_drake.abstraction.ranking import StateSpace
    from s3o_drake.planning.plan import TaskMotionPlan
    from s3o_drake.planning.planner import PlanningResult


def _figure_bytes(fig) -> bytes:
    import io

    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=120, bbox_inches="tight")
    plt.close(fig)
    return buffer.getvalue()


def _heatmap_layer(ax, scenario: Scenario, heatmaps: Sequence[Heatmap], *, alpha: float):
    """Paints all crops into one room-sized layer, so that overlaps take the maximum."""
    x_min, y_min, x_max, y_max = scenario.room.bounds
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
    return ax.imshow(shown, extent=(x_min, x_max, y_min, y_max), origin="lower",
                     cmap="plasma", vmin=0.0, vmax=1.0, alpha=alpha, interpolation="nearest")


def feasibility_figure(scenario: Scenario, top_view: np.ndarray, heatmaps: Sequence[Heatmap],
                       path: Path, *, title: str = "") -> None:
    """Each dish's Fea^m heatmap over the top view of the room (the paper's Fig. 3, left).

    `top_view` is an orthophoto of the room (row 0 north) spanning `scenario.room.bounds`.
    Where two crops overlap, the larger probability shows.
    """
    x_min, y_min, x_max, y_max = scenario.room.bounds
    fig, ax = plt.subplots(figsize=(10, 10 * (y_max - y_min) / (x_max - x_min)))
    ax.imshow(top_view, extent=(x_min, x_max, y_min, y_max), origin="upper")
    image = _heatmap_layer(ax, scenario, heatmaps, alpha=0.75)
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


def _searched_state(result: "PlanningResult") -> tuple["StateSpace | None", int | None]:
    """The ranked StateSpace whose locations are the plan's, and its rank (0-based); None
    where the abstraction did not rank it (the V- methods, a random candidate)."""
    if result.abstraction is None or result.plan is None:
        return None, None
    wanted = {frozenset(g) for g in result.plan.groups}
    for rank, state in enumerate(result.abstraction.ranked):
        if {frozenset(g) for g in state.groups} == wanted:
            return state, rank
    return None, None


def state_space_figure(scenario: Scenario, top_view: np.ndarray, result: "PlanningResult",
                       path: Path, *, title: str = "") -> None:
    """The state space the plan used, over the top view and the heatmaps (the paper's
    Fig. 3, right).

    Each location is filled in its own colour, outlined and named as in plan.json; inside a
    merged location the Voronoi borders between its dishes' cells are dashed. Dishes are
    marked in their location's colour; unreachable dishes (empty cells) get a red cross.
    The title says where the abstraction ranked this state space, when it did.
    """
    from shapely.plotting import plot_polygon

    plan, partition = result.plan, result.partition
    state, rank = _searched_state(result)
    index = {d: i for i, d in enumerate(partition.dishes)}
    x_min, y_min, x_max, y_max = scenario.room.bounds
    fig, ax = plt.subplots(figsize=(10, 10 * (y_max - y_min) / (x_max - x_min)))
    ax.imshow(top_view, extent=(x_min, x_max, y_min, y_max), origin="upper")
    if result.heatmaps:
        image = _heatmap_layer(ax, scenario, result.heatmaps, alpha=0.45)
        fig.colorbar(image, ax=ax, fraction=0.03, pad=0.02,
                     label="Fea$^m$ (probability of a pick)")
    colours = plt.get_cmap("tab10")
    unreachable = set(partition.unreachable) | set(plan.unreachable)
    for k, (names, location_name) in enumerate(zip(plan.groups, plan.locations, strict=True)):
        colour = colours(k % 10)
        group = [index[n] for n in names]
        location = unary_union([partition.cells[i] for i in group])
        fea = "" if state is None else \
            " (Fea$^t$ " + ", ".join(f"{state.task_feasibility[n]:.2f}" for n in names) + ")"
        label = f"{location_name}: {' + '.join(names)}{fea}"
        if not location.is_empty:
            for polygon in getattr(location, "geoms", [location]):
                if polygon.geom_type != "Polygon" or polygon.area <= 0:
                    continue
                plot_polygon(polygon, ax=ax, add_points=False, facecolor=(*colour[:3], 0.3),
                             edgecolor=colour, linewidth=2.0, label=label)
                label = None
            if len(group) > 1:  # the merged cells' former borders
                for i in group:
                    cell = partition.cells[i]
                    if not cell.is_empty:
                        for polygon in getattr(cell, "geoms", [cell]):
                            if polygon.geom_type == "Polygon":
                                plot_polygon(polygon, ax=ax, add_points=False,
                                             facecolor="none", edgecolor=colour,
                                             linewidth=0.8, linestyle="--")
        for i, name in zip(group, names, strict=True):
            _mark_dish(ax, partition.p_WO[i], name, colour, name in unreachable,
                       label if label and location.is_empty else None)
    for name in sorted(unreachable - {n for g in plan.groups for n in g}):
        _mark_dish(ax, partition.p_WO[index[name]], name, "red", True, None)
    ax.legend(loc="upper left", bbox_to_anchor=(0.0, -0.08), fontsize=8, ncol=2,
              frameon=False)
    ax.set_xlim(x_min, x_max)
    ax.set_ylim(y_min, y_max)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    locations = f"{len(plan.groups)} location" + ("" if len(plan.groups) == 1 else "s")
    abstraction = result.abstraction
    if abstraction is None:
        where = "the plain Voronoi state space (no merging)"
    elif state is None:
        where = f"a state space outside the {len(abstraction.ranked)} ranked best"
    else:
        top = abstraction.probabilities
        p_rank = top[rank] if rank < len(top) else 0.0
        search = "all candidates" if abstraction.exhaustive and abstraction.complete else \
            "beam search"
        where = (f"the state space ranked {rank + 1} of {abstraction.count} ({search}), "
                 f"Score {state.score:.2f}, p = {p_rank:.2f}")
    ax.set_title(title or f"{plan.method} searched {where}: {locations}")
    write_atomically(path, _figure_bytes(fig))


def _mark_dish(ax, p: np.ndarray, name: str, colour, unreachable: bool, label) -> None:
    ax.plot(*p, marker="x" if unreachable else "o", markersize=7,
            color="red" if unreachable else colour,
            markeredgecolor="red" if unreachable else "k", linestyle="none", label=label)
    ax.annotate(name, p, xytext=(4, 4), textcoords="offset points", fontsize=8, color="k",
                bbox={"boxstyle": "round,pad=0.15", "fc": "white", "alpha": 0.7})


def _room_axes(scenario: Scenario, top_view: np.ndarray, ax) -> None:
    x_min, y_min, x_max, y_max = scenario.room.bounds
    ax.imshow(top_view, extent=(x_min, x_max, y_min, y_max), origin="upper")
    ax.set_xlim(x_min, x_max)
    ax.set_ylim(y_min, y_max)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")


def _dish_marks(ax, scenario: Scenario, unreachable: Sequence[str] = ()) -> None:
    for dish in scenario.dishes:
        lost = dish.name in unreachable
        ax.plot(*dish.position, marker="x" if lost else "o", markersize=7 if lost else 5,
                color="red" if lost else "cyan", markeredgecolor="red" if lost else "k",
                linestyle="none")
        ax.annotate(dish.name + (" (unreachable)" if lost else ""), dish.position,
                    xytext=(4, 4), textcoords="offset points", fontsize=7, color="k",
                    bbox={"boxstyle": "round,pad=0.15", "fc": "white", "alpha": 0.7})


def search_figure(scenario: Scenario, top_view: np.ndarray, heatmaps: Sequence[Heatmap],
                  plan: "TaskMotionPlan", path: Path) -> None:
    """The winning motion search's samples of its first and last generation over the
    heatmaps, one colour per goto (the paper's Fig. 4): CMA-ES starts spread over the
    feasible regions and ends concentrated where the utility is highest."""
    x_min, y_min, x_max, y_max = scenario.room.bounds
    aspect = (y_max - y_min) / (x_max - x_min)
    fig, axes = plt.subplots(1, 2, figsize=(16, 8 * aspect + 0.8))
    colours = plt.get_cmap("tab10")
    gotos = plan.gotos
    for ax, samples, name in ((axes[0], plan.early_samples, "first"),
                              (axes[1], plan.late_samples, "last")):
        _room_axes(scenario, top_view, ax)
        if heatmaps:
            _heatmap_layer(ax, scenario, heatmaps, alpha=0.45)
        _dish_marks(ax, scenario, plan.unreachable)
        points = np.asarray(samples, dtype=float).reshape(len(samples), -1, 2)
        for k, goto in enumerate(gotos):
            colour = colours(k % 10)
            if points.size:
                ax.scatter(points[:, k, 0], points[:, k, 1], s=22, color=colour,
                           edgecolors="k", linewidths=0.4, label=f"goto {goto.location}")
            ax.plot(*goto.pose[:2], marker="*", markersize=18, markerfacecolor="none",
                    markeredgecolor=colour, markeredgewidth=2.0)
        ax.set_title(f"{plan.method}: samples of the {name} generation "
                     f"({len(samples)}); stars: the plan's stops", fontsize=10)
        if gotos and points.size:
            ax.legend(loc="upper left", fontsize=8, framealpha=0.8)
    write_atomically(path, _figure_bytes(fig))


def plan_figure(scenario: Scenario, top_view: np.ndarray, plan: "TaskMotionPlan",
                path: Path, *, start: Sequence[float] | None = None, title: str = "") -> None:
    """The plan over the top view: the driven paths, each stop with its heading, and
    thin lines from each stop to the dishes picked there; unreachable dishes crossed."""
    x_min, y_min, x_max, y_max = scenario.room.bounds
    fig, ax = plt.subplots(figsize=(10, 10 * (y_max - y_min) / (x_max - x_min)))
    _room_axes(scenario, top_view, ax)
    _dish_marks(ax, scenario, plan.unreachable)
    colours = plt.get_cmap("tab10")
    dish_xy = {d.name: d.position for d in scenario.dishes}
    start = scenario.robot.start if start is None else start
    ax.plot(start[0], start[1], marker="s", markersize=10, color="white", markeredgecolor="k")
    ax.annotate("start", start[:2], xytext=(6, -12), textcoords="offset points", fontsize=8)
    stop, colour, k = start[:2], "white", -1
    for action in plan.actions:
        if hasattr(action, "path"):
            k += 1
            colour = colours(k % 10)
            p = np.asarray(action.path)
            ax.plot(p[:, 0], p[:, 1], color=colour, linewidth=2.5, alpha=0.9)
            x, y, yaw = action.pose
            ax.annotate("", (x + 0.35 * np.cos(yaw), y + 0.35 * np.sin(yaw)), (x, y),
                        arrowprops={"arrowstyle": "->", "color": "k", "lw": 1.5})
            ax.plot(x, y, marker="o", markersize=14, color=colour, markeredgecolor="k")
            ax.annotate(str(k + 1), (x, y), ha="center", va="center", fontsize=8,
                        fontweight="bold")
            stop = (x, y)
        else:
            d = dish_xy[action.dish]
            ax.plot([stop[0], d[0]], [stop[1], d[1]], color=colour, linewidth=1.0,
                    linestyle=":")
            ax.annotate(f"{action.feasibility:.2f}", ((stop[0] + d[0]) / 2, (stop[1] + d[1]) / 2),
                        fontsize=7, color="k", ha="center",
                        bbox={"boxstyle": "round,pad=0.1", "fc": "white", "alpha": 0.6})
    stops = len(plan.gotos)
    ax.set_title(title or f"{plan.method}: {stops} stop{'s' if stops != 1 else ''}, "
                          f"{len(plan.pickups)} pickups, predicted {plan.predicted_time:.0f} s, "
                          f"utility {plan.utility:.1f} (numbers on the dotted lines: Fea$^m$)")
    write_atomically(path, _figure_bytes(fig))
