"""The floor under the map pictures, drawn from the world's geometry in metres.

The pictures used to lay their data over the overhead camera's image warped onto the floor.
That image is a perspective view: whatever stands above the floor (a table top, 0.75 m up)
appears displaced away from the camera's axis, by up to 0.3 m at the room's edges, and the
warp left streaks where the camera sees under nothing. Here every outline is the footprint
the planner and the simulation use (`world.furniture`, `world.robot`): a table is drawn where
it stands, whatever its height.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np
from matplotlib.patches import Polygon as PolygonPatch
from shapely.geometry import Polygon, box

from s3o_drake.world.furniture import chair_footprint, table_footprint
from s3o_drake.world.scenario import Scenario

_FLOOR = "#f4f1ea"
_TABLE = ("#c8a878", "#6b4e2a")  # face, edge
_MAPPED_CHAIR = ("#b9b9b9", "#555555")
_PERCEIVED_CHAIR = ("#f2a65a", "#a0522d")
_ROBOT = "#1f5fbf"


@dataclass(frozen=True)
class Floor:
    """What lies on the floor of a map picture: the room, the tables and the mapped chairs
    (the map), the chairs the robot perceived, optionally the unmapped chairs as they are
    (dashed: where a picture is about perception) and the robot's footprint."""

    bounds: tuple[float, float, float, float]
    tables: tuple[tuple[str, Polygon], ...]
    mapped_chairs: tuple[Polygon, ...] = ()
    perceived_chairs: tuple[Polygon, ...] = ()
    true_chairs: tuple[Polygon, ...] = ()
    robot: Polygon | None = None

    @classmethod
    def of(cls, scenario: Scenario, *,
           perceived: Iterable[Sequence[float]] | None = None, truth: bool = False,
           robot_pose: Sequence[float] | None = None) -> Floor:
        """The floor of `scenario`. `perceived`: the chair poses the robot perceived (None:
        the unmapped chairs where they are, as a perfect perception would give them);
        `truth`: also the unmapped chairs as they are, dashed; `robot_pose`: the robot's
        footprint there (default the scenario's start)."""
        unmapped = [c.pose for c in scenario.chairs if not c.mapped]
        pose = scenario.robot.start if robot_pose is None else robot_pose
        return cls(
            bounds=tuple(float(v) for v in scenario.room.bounds),
            tables=tuple((t.name, table_footprint(t.center, t.yaw, t.size))
                         for t in scenario.tables),
            mapped_chairs=tuple(chair_footprint(c.pose) for c in scenario.chairs if c.mapped),
            perceived_chairs=tuple(chair_footprint(list(p)) for p in
                                   (unmapped if perceived is None else perceived)),
            true_chairs=tuple(chair_footprint(p) for p in unmapped) if truth else (),
            robot=scenario.robot_value.footprint(float(pose[0]), float(pose[1]),
                                                 float(pose[2])))

    def draw(self, ax) -> dict[str, tuple[float, float, float, float]]:
        """Draws the floor on `ax`, under the data (negative z-order) but for the outlines
        of the true chairs and the robot, which stay visible over it; returns each table's drawn
        outline's bounds (x_min, y_min, x_max, y_max), read back from its artist."""
        x_min, y_min, x_max, y_max = self.bounds
        _patch(ax, box(x_min, y_min, x_max, y_max), facecolor=_FLOOR, edgecolor="k",
               linewidth=1.5, zorder=-3)
        drawn = {}
        for name, outline in self.tables:
            patch = _patch(ax, outline, facecolor=_TABLE[0], edgecolor=_TABLE[1], zorder=-2)
            xy = patch.get_xy()
            drawn[name] = (float(xy[:, 0].min()), float(xy[:, 1].min()),
                           float(xy[:, 0].max()), float(xy[:, 1].max()))
        for outline in self.mapped_chairs:
            _patch(ax, outline, facecolor=_MAPPED_CHAIR[0], edgecolor=_MAPPED_CHAIR[1],
                   zorder=-2)
        for k, outline in enumerate(self.perceived_chairs):
            _patch(ax, outline, facecolor=_PERCEIVED_CHAIR[0], edgecolor=_PERCEIVED_CHAIR[1],
                   alpha=0.8, zorder=-2, label="perceived chair" if k == 0 else None)
        for k, outline in enumerate(self.true_chairs):
            _patch(ax, outline, facecolor="none", edgecolor="k", linestyle="--",
                   linewidth=0.9, zorder=2.1, label="true chair" if k == 0 else None)
        if self.robot is not None:
            _patch(ax, self.robot, facecolor="none", edgecolor=_ROBOT, linewidth=1.2,
                   zorder=2.1)
        return drawn


def _patch(ax, outline: Polygon, **style) -> PolygonPatch:
    """One polygon (its exterior; the footprints have no holes) as a patch in metres."""
    patch = PolygonPatch(np.asarray(outline.exterior.coords), closed=True, **style)
    ax.add_patch(patch)
    return patch
