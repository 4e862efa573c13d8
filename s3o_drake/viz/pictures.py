"""Pictures a person reads faster than numbers: heatmaps, state spaces, the motion search
and the plan over the top view of the room.

Each figure function returns its `Labels`: the names it put on the picture, so that what
the pictures say can be checked against plan.json without reading pixels. Labels are
placed where they cover no dish name, mark or label placed before them (`_declutter`).
"""

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import matplotlib

matplotlib.use("Agg")  # files only; never a window
import matplotlib.pyplot as plt
import numpy as np
from shapely.ops import unary_union

from s3o_drake.feasibility.oracle import Heatmap
from s3o_drake.planning.plan import Place
from s3o_drake.viz.floor import Floor
from s3o_drake.world.files import write_atomically
from s3o_drake.world.goals import place_target_name, shown_name, with_place_targets
from s3o_drake.world.scenario import Scenario
from s3o_drake.world.words import counted

if TYPE_CHECKING:
    from matplotlib.text import Text

    from s3o_drake.abstraction.ranking import StateSpace
    from s3o_drake.planning.methods import PlanningResult
    from s3o_drake.planning.plan import TaskMotionPlan
    from s3o_drake.world.camera import OverheadCamera


@dataclass(frozen=True)
class Labels:
    """What a picture names.

    `tables`: each table's outline as drawn, (x_min, y_min, x_max, y_max) in metres, read
    back from the picture's artists (`floor.Floor.draw`).
    `locations`: each location it shows, by name, with the dishes it gives it (plan.png:
    picked from that location's stop; state_space.png: the location's cells). `stops`:
    plan.png's stop labels in visiting order, "1 · l2" (stop number · location). `panels`:
    feasibility.png's panels, a dish each. `overlaps`: labels that found no spot clear of
    the dish names, marks and other labels, not even as a number keyed beside the plot
    (0 unless the picture is very crowded).
    """

    title: str = ""
    locations: dict[str, tuple[str, ...]] = field(default_factory=dict)
    stops: tuple[str, ...] = ()
    panels: tuple[str, ...] = ()
    overlaps: int = 0
    tables: dict[str, tuple[float, float, float, float]] = field(default_factory=dict)
    colours: tuple[tuple[float, ...], ...] = ()
    """The colour of each location (state_space.png) or stop (plan.png), in order."""


def location_colours(n: int) -> list[tuple[float, float, float, float]]:
    """`n` colours, no two alike: matplotlib's tab10 up to 10 (the pictures' usual look),
    tab20 up to 20, beyond that n hues spread over the turbo map. tab10 alone repeats
    after 10, and at 30 dishes two locations of a plain Voronoi state space shared one."""
    if n <= 10:
        return [plt.get_cmap("tab10")(k) for k in range(n)]
    if n <= 20:
        return [plt.get_cmap("tab20")(k) for k in range(n)]
    return [plt.get_cmap("turbo")(x) for x in np.linspace(0.05, 0.95, n)]


def stop_label(number: int, location: str) -> str:
    """plan.png's label of the `number`-th stop (1-based), at `location`."""
    return f"{number} · {location}"


_NAME_BOX = {"boxstyle": "round,pad=0.15", "fc": "white", "alpha": 0.7}
KEY_FONT = 6  # the numbers that stand in for labels with no clear spot, and their key
KEY_ROWS = 40  # a key longer than this is set in KEY_COLUMNS columns
KEY_COLUMNS = 3
_Spot = tuple[float, float, str, str]  # x, y (data), horizontal and vertical alignment


def _pixels_per_metre(ax) -> tuple[float, float]:
    (x0, y0), (x1, y1) = ax.transData.transform([(0.0, 0.0), (1.0, 1.0)])
    return x1 - x0, y1 - y0


def _around(ax, xy: Sequence[float], marker_size: float) -> list[_Spot]:
    """Spots for a label beside a marker of `marker_size` points at `xy`, just clear of
    it: above right first, then the other diagonals, the sides, above and below."""
    gap = marker_size * ax.figure.dpi / 72.0 / 2.0 + 3.0  # pixels: its radius, a margin
    sx, sy = _pixels_per_metre(ax)
    dx, dy = gap / sx, gap / sy
    x, y = xy[0], xy[1]
    return [(x + dx, y + dy, "left", "bottom"), (x + dx, y - dy, "left", "top"),
            (x - dx, y + dy, "right", "bottom"), (x - dx, y - dy, "right", "top"),
            (x + dx, y, "left", "center"), (x - dx, y, "right", "center"),
            (x, y + dy, "center", "bottom"), (x, y - dy, "center", "top")]


def _along(ax, a: Sequence[float], b: Sequence[float]) -> list[_Spot]:
    """Spots for a label on the segment a-b, from its middle outwards, then beside it."""
    a, b = np.asarray(a[:2], dtype=float), np.asarray(b[:2], dtype=float)
    spots: list[_Spot] = [(*(a + t * (b - a)), "center", "center")
                          for t in (0.5, 0.4, 0.6, 0.3, 0.7, 0.2, 0.8)]
    sx, sy = _pixels_per_metre(ax)
    normal = np.array([a[1] - b[1], b[0] - a[0]]) / max(np.linalg.norm(b - a), 1e-9)
    for side in (1.0, -1.0):
        for t in (0.5, 0.35, 0.65):
            x, y = a + t * (b - a) + side * 12.0 * normal / np.array([sx, sy])
            spots.append((x, y, "center", "center"))
    return spots


def _declutter(ax, labels: Sequence[tuple["Text", Sequence[_Spot]]],
               marks: Sequence = ()) -> int:
    """Places each label, in order, at the first of its spots where its box clears the
    `marks` (single-point markers) and the labels placed before it. A label with no clear
    spot becomes a number, placed the same way or up to 11 times as far out (with a thin
    line back), its text listed under that number in a key beside the plot (at 30 dishes
    0.22 m apart the names cannot all fit); a number with no clear spot either takes its
    first. Returns how many labels could not be cleared.

    Order is priority: dish names first, so that nothing else covers them. A spot counts
    as clear only inside the plot.
    """
    renderer = ax.figure.canvas.get_renderer()
    taken = [mark.get_window_extent(renderer) for mark in marks]
    frame = ax.get_window_extent(renderer)  # a label outside the plot would meet the title
    crowded = 0
    key: list[str] = []

    def place(text, spots) -> tuple[bool, object]:
        for x, y, ha, va in [*spots, spots[0]]:
            text.set_position((x, y))
            text.set_horizontalalignment(ha)
            text.set_verticalalignment(va)
            box = text.get_window_extent(renderer).padded(2.0)  # the name box's margin
            inside = (frame.x0 <= box.x0 and box.x1 <= frame.x1 and frame.y0 <= box.y0
                      and box.y1 <= frame.y1)
            if inside and not any(box.overlaps(other) for other in taken):
                return True, box
        return False, box

    for text, spots in labels:
        clear, box = place(text, spots)
        if not clear:
            key.append(f"{len(key) + 1:>2} {text.get_text()}")
            text.set_text(str(len(key)))
            text.set_fontsize(KEY_FONT)
            # Farther out too, on a thin line back to where the label belongs.
            anchor = np.mean([(x, y) for x, y, _, _ in spots], axis=0)
            farther = [(*(anchor + k * (np.array((x, y)) - anchor)), ha, va)
                       for k in (1.0, 2.0, 3.0, 4.5, 6.0, 8.0, 11.0) for x, y, ha, va in spots]
            clear, box = place(text, farther)
            crowded += not clear
            x, y = text.get_position()
            if clear and math.dist((x, y), anchor) > 1.5 * math.dist(spots[0][:2], anchor):
                ax.plot([anchor[0], x], [anchor[1], y], color="0.3", linewidth=0.4)
        taken.append(box)
    if key:
        rows = -(-len(key) // KEY_COLUMNS) if len(key) > KEY_ROWS else len(key)
        for c in range(0, len(key), rows):
            ax.text(1.02 + 0.16 * (c // rows), 1.0, "\n".join(key[c:c + rows]),
                    transform=ax.transAxes, va="top", ha="left", fontsize=KEY_FONT,
                    family="monospace")
    return crowded


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


def _room_axes(floor: Floor, ax, limits: Sequence[float] | None = None
               ) -> dict[str, tuple[float, float, float, float]]:
    """The floor in metres; `limits` (x_min, y_min, x_max, y_max) zoom in. Returns the
    tables' drawn outlines (`Labels.tables`)."""
    tables = floor.draw(ax)
    x_min, y_min, x_max, y_max = floor.bounds if limits is None else limits
    ax.set_xlim(x_min, x_max)
    ax.set_ylim(y_min, y_max)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    return tables


def _name_dishes(ax, dishes: Sequence[tuple[str, Sequence[float], object, bool]],
                 *, fontsize: float = 8, marker_size: float = 6):
    """Marks each dish (name, position, colour, unreachable: a red cross) and names it;
    returns the names with their spots and the marks, for `_declutter`."""
    names, marks = [], []
    for name, p, colour, lost in dishes:
        (mark,) = ax.plot(p[0], p[1], marker="x" if lost else "o",
                          markersize=marker_size + (2 if lost else 0),
                          color="red" if lost else colour,
                          markeredgecolor="red" if lost else "k", linestyle="none")
        marks.append(mark)
        text = ax.text(p[0], p[1], shown_name(name) + (" (unreachable)" if lost else ""),
                       fontsize=fontsize, color="k", bbox=_NAME_BOX)
        names.append((text, _around(ax, p, mark.get_markersize())))
    return names, marks


def _positions(scenario: Scenario) -> dict[str, Sequence[float]]:
    """Where each object stands, and each place target (`goals.place_target_name`)."""
    return {d.name: d.position for d in with_place_targets(scenario).dishes}


def _scenario_dishes(scenario: Scenario, unreachable: Sequence[str] = (),
                     colour="cyan") -> list[tuple[str, Sequence[float], object, bool]]:
    return [(name, p, colour, name in unreachable) for name, p in _positions(scenario).items()]


def feasibility_figure(scenario: Scenario, floor: Floor, heatmaps: Sequence[Heatmap],
                       path: Path, *, title: str = "") -> Labels:
    """Each dish's Fea^m heatmap in a panel of its own over the top view (small multiples:
    where one dish's map overlaps another's, both stay readable), zoomed to the heatmap's
    crop; the panel's dish is named, the others are small grey dots.

    `floor` is what lies on the room's floor (`floor.Floor`), drawn under each panel.
    """
    x_min, y_min, x_max, y_max = scenario.room.bounds
    cols = min(3, max(1, len(heatmaps)))
    rows = max(1, -(-len(heatmaps) // cols))
    fig, axes = plt.subplots(rows, cols, figsize=(4.6 * cols, 4.4 * rows + 0.6), squeeze=False)
    where = _positions(scenario)
    image, tables = None, {}
    for ax, heatmap in zip(axes.flat, heatmaps, strict=False):
        hx0, hx1, hy0, hy1 = heatmap.extent
        limits = (max(hx0, x_min), max(hy0, y_min), min(hx1, x_max), min(hy1, y_max))
        tables = _room_axes(floor, ax, limits)
        shown = np.ma.masked_where(heatmap.values <= 0.0, heatmap.values)
        image = ax.imshow(shown, extent=heatmap.extent, origin="lower", cmap="plasma",
                          vmin=0.0, vmax=1.0, alpha=0.75, interpolation="nearest")
        others = [p for name, p in where.items() if name != heatmap.dish]
        if others:
            ax.plot(*np.asarray(others).T, marker="o", markersize=3, color="0.6",
                    linestyle="none")
        names, marks = _name_dishes(ax, [(heatmap.dish, where[heatmap.dish], "cyan", False)])
        _declutter(ax, names, marks)
        ax.set_title(shown_name(heatmap.dish), fontsize=11)
    for ax in axes.flat[len(heatmaps):]:
        ax.set_visible(False)
    if image is not None:
        fig.colorbar(image, ax=axes, fraction=0.03, pad=0.02,
                     label="Fea$^m$ (probability of a pick)")
    title = title or ("Motion-level feasibility of each dish, as the plan used it (base facing "
                      "the dish; 0 where a stop sent there would collide)")
    fig.suptitle(title)
    write_atomically(path, _figure_bytes(fig))
    return Labels(title=title, panels=tuple(shown_name(h.dish) for h in heatmaps),
                  tables=tables)


def overhead_figure(scenario: Scenario, camera: "OverheadCamera", color: np.ndarray,
                    path: Path) -> Labels:
    """The overhead camera's colour image with axes in metres: the camera looks straight
    down, so its pixels are a uniform grid on the floor, and the axes are true there
    (tables and chairs stand taller and lean outwards by perspective). The room's walls
    are outlined."""
    from shapely.geometry import box
    from shapely.plotting import plot_polygon

    x0, x1, y0, y1 = camera.floor_extent()
    fig, ax = plt.subplots(figsize=(10, 10 * (y1 - y0) / (x1 - x0)))
    ax.imshow(color, extent=(x0, x1, y0, y1), origin="upper")
    plot_polygon(box(*scenario.room.bounds), ax=ax, add_points=False, facecolor="none",
                 edgecolor="white", linewidth=1.0, linestyle="--")
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    title = (f"The overhead camera's perspective image, from {scenario.camera.height:g} m "
             "(axes: metres at floor level only;\nwhat stands above the floor looks farther "
             "from the centre than it is; dashed: the room's walls)")
    ax.set_title(title)
    write_atomically(path, _figure_bytes(fig))
    return Labels(title=title)


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


def _outline(ax, geometry, **style) -> None:
    """Draws the polygons of `geometry` (a cell or a union of cells) with `style`;
    `label` goes to the first one only (one legend entry)."""
    from shapely.plotting import plot_polygon

    for polygon in getattr(geometry, "geoms", [geometry]):
        if polygon.geom_type == "Polygon" and polygon.area > 0:
            plot_polygon(polygon, ax=ax, add_points=False, **style)
            style["label"] = None


def state_space_figure(scenario: Scenario, floor: Floor, result: "PlanningResult",
                       path: Path, *, title: str = "") -> Labels:
    """The state space the plan used, over the top view and the heatmaps (the paper's
    Fig. 3, right).

    Each location is filled in its own colour, outlined and named as in plan.json; inside a
    merged location the Voronoi borders between its dishes' cells are dashed. Dishes are
    marked in their location's colour; unreachable dishes (empty cells) get a red cross.
    The title says where the abstraction ranked this state space, when it did.
    """
    plan, partition = result.plan, result.partition
    state, rank = _searched_state(result)
    index = {d: i for i, d in enumerate(partition.dishes)}
    x_min, y_min, x_max, y_max = scenario.room.bounds
    fig, ax = plt.subplots(figsize=(10, 10 * (y_max - y_min) / (x_max - x_min)))
    tables = _room_axes(floor, ax)
    if result.heatmaps:
        image = _heatmap_layer(ax, scenario, result.heatmaps, alpha=0.45)
        fig.colorbar(image, ax=ax, fraction=0.03, pad=0.02,
                     label="Fea$^m$ (probability of a pick)")
    colours = location_colours(len(plan.groups))
    unreachable = set(partition.unreachable) | set(plan.unreachable)
    dishes, locations = [], {}
    for k, (names, location_name) in enumerate(zip(plan.groups, plan.locations, strict=True)):
        colour = colours[k]
        group = [index[n] for n in names]
        location = unary_union([partition.cells[i] for i in group])
        fea = "" if state is None else \
            " (Fea$^t$ " + ", ".join(f"{state.task_feasibility[n]:.2f}" for n in names) + ")"
        label = f"{location_name}: {' + '.join(shown_name(n) for n in names)}{fea}"
        locations[location_name] = tuple(names)
        if location.is_empty:  # the legend still names it, with the dishes' marker
            ax.plot([], [], marker="x", color="red", linestyle="none", label=label)
        _outline(ax, location, facecolor=(*colour[:3], 0.3), edgecolor=colour,
                 linewidth=2.0, label=label)
        if len(group) > 1:  # the merged cells' former borders
            for i in group:
                _outline(ax, partition.cells[i], facecolor="none", edgecolor=colour,
                         linewidth=0.8, linestyle="--")
        dishes += [(n, partition.p_WO[i], colour, n in unreachable)
                   for i, n in zip(group, names, strict=True)]
    placed = {d[0] for d in dishes}
    dishes += [(n, partition.p_WO[index[n]], "red", True) for n in sorted(unreachable - placed)]
    names, marks = _name_dishes(ax, dishes, marker_size=7)
    crowded = _declutter(ax, names, marks)
    if ax.get_legend_handles_labels()[0]:  # the empty plan has no locations to name
        ax.legend(loc="upper left", bbox_to_anchor=(0.0, -0.08), fontsize=8, ncol=2,
                  frameon=False)
    count = counted(len(plan.groups), "location")
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
    title = title or f"{plan.method} searched {where}: {count}"
    ax.set_title(title)
    write_atomically(path, _figure_bytes(fig))
    return Labels(title=title, locations=locations, overlaps=crowded, tables=tables,
                  colours=tuple(colours))


def search_figure(scenario: Scenario, floor: Floor, heatmaps: Sequence[Heatmap],
                  plan: "TaskMotionPlan", path: Path) -> Labels:
    """The winning motion search's samples of its first and last generation over the
    heatmaps, one colour per goto (the paper's Fig. 4): CMA-ES starts spread over the
    feasible regions and ends concentrated where the utility is highest."""
    x_min, y_min, x_max, y_max = scenario.room.bounds
    aspect = (y_max - y_min) / (x_max - x_min)
    fig, axes = plt.subplots(1, 2, figsize=(16, 8 * aspect + 0.8))
    gotos = plan.gotos
    colours = location_colours(len(gotos))
    crowded = 0
    for ax, samples, name in ((axes[0], plan.early_samples, "first"),
                              (axes[1], plan.late_samples, "last")):
        tables = _room_axes(floor, ax)
        if heatmaps:
            _heatmap_layer(ax, scenario, heatmaps, alpha=0.45)
        names, marks = _name_dishes(ax, _scenario_dishes(scenario, plan.unreachable),
                                    fontsize=7, marker_size=5)
        crowded += _declutter(ax, names, marks)
        points = np.asarray(samples, dtype=float).reshape(len(samples), -1, 2)
        for k, goto in enumerate(gotos):
            colour = colours[k]
            if points.size:
                ax.scatter(points[:, k, 0], points[:, k, 1], s=22, color=colour,
                           edgecolors="k", linewidths=0.4,
                           label=f"goto {stop_label(k + 1, goto.location)}")
            ax.plot(*goto.pose[:2], marker="*", markersize=18, markerfacecolor="none",
                    markeredgecolor=colour, markeredgewidth=2.0)
        ax.set_title(f"{plan.method}: samples of the {name} generation "
                     f"({len(samples)}); stars: the plan's stops", fontsize=10)
        if gotos and points.size:
            ax.legend(loc="upper left", fontsize=8, framealpha=0.8)
    write_atomically(path, _figure_bytes(fig))
    return Labels(title=plan.method, tables=tables, stops=tuple(stop_label(k + 1, g.location)
                                                 for k, g in enumerate(gotos)),
                  overlaps=crowded)


def plan_figure(scenario: Scenario, floor: Floor, plan: "TaskMotionPlan",
                path: Path, *, start: Sequence[float] | None = None, title: str = "") -> Labels:
    """The plan over the top view: the driven paths, each stop with its heading and its
    label "k · l" (the k-th stop, at location l as plan.json names it), thin lines from
    each stop to the dishes picked there with their Fea^m, unreachable dishes crossed.
    Dish names are placed first and nothing covers them."""
    x_min, y_min, x_max, y_max = scenario.room.bounds
    fig, ax = plt.subplots(figsize=(10, 10 * (y_max - y_min) / (x_max - x_min)))
    tables = _room_axes(floor, ax)
    labels, marks = _name_dishes(ax, _scenario_dishes(scenario, plan.unreachable),
                                 fontsize=7, marker_size=5)
    fea_labels = []  # after the stops': the numbers may move furthest from their place
    colours = location_colours(len(plan.gotos))
    dish_xy = _positions(scenario)
    start = scenario.robot.start if start is None else start
    (mark,) = ax.plot(start[0], start[1], marker="s", markersize=10, color="white",
                      markeredgecolor="k")
    marks.append(mark)
    labels.append((ax.text(start[0], start[1], "start", fontsize=8),
                   _around(ax, start, mark.get_markersize())[1:]))
    stops: list[str] = []
    locations: dict[str, tuple[str, ...]] = {}
    stop, colour, location = start[:2], "white", ""
    for action in plan.actions:
        if hasattr(action, "path"):
            colour = colours[len(stops)]
            location = action.location
            stops.append(stop_label(len(stops) + 1, location))
            locations.setdefault(location, ())
            p = np.asarray(action.path)
            ax.plot(p[:, 0], p[:, 1], color=colour, linewidth=2.5, alpha=0.9)
            x, y, yaw = action.pose
            ax.annotate("", (x + 0.35 * np.cos(yaw), y + 0.35 * np.sin(yaw)), (x, y),
                        arrowprops={"arrowstyle": "->", "color": "k", "lw": 1.5})
            (mark,) = ax.plot(x, y, marker="o", markersize=11, color=colour,
                              markeredgecolor="k")
            marks.append(mark)
            text = ax.text(x, y, stops[-1], fontsize=8, fontweight="bold",
                           bbox={"boxstyle": "round,pad=0.2", "fc": "white",
                                 "ec": colour, "lw": 1.5})
            labels.append((text, _around(ax, (x, y), mark.get_markersize())))
            stop = (x, y)
        else:
            d = dish_xy[place_target_name(action.dish) if isinstance(action, Place)
                        else action.dish]
            locations[location] += (action.dish,)
            ax.plot([stop[0], d[0]], [stop[1], d[1]], color=colour, linewidth=1.0,
                    linestyle=":")
            text = ax.text(0.0, 0.0, f"{action.feasibility:.2f}", fontsize=7, color="k",
                           bbox={"boxstyle": "round,pad=0.1", "fc": "white", "alpha": 0.6})
            fea_labels.append((text, _along(ax, stop, d)))
    crowded = _declutter(ax, labels + fea_labels, marks)
    title = title or (f"{plan.method}: {counted(len(plan.gotos), 'stop')} "
                      f"(number · location), {counted(len(plan.pickups), 'pickup')}"
                      + (f", {counted(len(plan.places), 'place')}" if plan.places else "")
                      + ", predicted "
                      f"{plan.predicted_time:.0f} s, utility {plan.utility:.1f} "
                      "(on the dotted lines: Fea$^m$)")
    ax.set_title(title, fontsize=11)
    write_atomically(path, _figure_bytes(fig))
    return Labels(title=title, locations=locations, stops=tuple(stops), overlaps=crowded,
                  tables=tables,
                  colours=tuple(colours))
