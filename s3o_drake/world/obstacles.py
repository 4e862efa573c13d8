"""The obstacles a base moves among, as plan-view geometry: the floor inside the walls and
the footprints of the tables, chairs and contacts. The true world's (every chair) and a
belief's (the mapped and perceived chairs, `belief.known_world`) are both made here."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING

from shapely.geometry import Point, Polygon, box
from shapely.geometry.base import BaseGeometry
from shapely.ops import unary_union

from s3o_drake.world.furniture import chair_footprint, table_footprint

if TYPE_CHECKING:
    from s3o_drake.world.contents import SceneContents

Pose2 = tuple[float, float, float]
"""A planar pose (x, y, yaw) in the world frame: m, m, rad."""
#: Radius (m) of the obstacle a contact stands for: something at least a chair leg's size.
CONTACT_RADIUS = 0.1


@dataclass(frozen=True)
class Obstacles:
    """The known obstacles: the floor inside the walls, and the footprints of the tables and
    of the chairs the robot knows (mapped and perceived), not inflated."""

    room: Polygon
    footprints: tuple[Polygon, ...]
    _free: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    @classmethod
    def of(cls, bounds: Sequence[float], tables: Iterable, chair_poses: Iterable[Pose2],
           contacts: Iterable[Sequence[float]] = (), *,
           chair_margins: Sequence[float] | None = None) -> Obstacles:
        """The room's obstacles; `chair_margins` (m, one per chair) grows chair footprints,
        for a chair whose pose is only as good as perception."""
        chair_poses = list(chair_poses)
        margins = [0.0] * len(chair_poses) if chair_margins is None else list(chair_margins)
        if len(margins) != len(chair_poses):
            raise ValueError("chair_margins: one margin per chair")
        shapes = [table_footprint(t.center, t.yaw, t.size) for t in tables]
        shapes += [chair_footprint(list(p)) if m <= 0.0 else
                   chair_footprint(list(p)).buffer(m, join_style="mitre")
                   for p, m in zip(chair_poses, margins, strict=True)]
        shapes += [Point(*c[:2]).buffer(CONTACT_RADIUS) for c in contacts]
        return cls(room=box(*bounds), footprints=tuple(shapes))

    @classmethod
    def of_contents(cls, contents: SceneContents) -> Obstacles:
        """The obstacles of what a plant holds: every chair of the true world
        (`Scenario.contents`), or the mapped and perceived ones of a belief."""
        return cls.of(contents.room.bounds, contents.tables, [c.pose for c in contents.chairs])

    @cached_property
    def union(self) -> BaseGeometry:
        """The union of the footprints (empty when there are none)."""
        return unary_union(self.footprints) if self.footprints else Polygon()

    def free_space(self, clearance: float) -> BaseGeometry:
        """Positions at least `clearance` (m) from the walls and every footprint; made once
        per clearance (the abstraction asks for it for every state space)."""
        if clearance not in self._free:
            room = self.room.buffer(-clearance, join_style="mitre")
            self._free[clearance] = room if not self.footprints else \
                room.difference(self.union.buffer(clearance, quad_segs=16))
        return self._free[clearance]
