"""What the robot knows when it plans: the `KnownWorld`, and its obstacle geometry, built once.

The planner never sees the true world. It knows its map (the room, the tables and the mapped
chairs, and the scenario's settings), the chairs its perception reports, the dishes that are
still to be collected, and where it stands now. A `KnownWorld` holds exactly that; perception
makes one from the overhead images (`s3o_drake.belief.perceive_known_world`), and the
planning pipeline (`s3o_drake.planning.pipeline.plan_from`) plans from it. A replan is the
same call with a newer KnownWorld: fewer dishes, another pose, chairs seen again.

`Obstacles` is the known obstacles' geometry, made once per KnownWorld: the free base
positions of the abstraction, the navigation map and the Drake oracle's base-clearance test
all read it.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np

from s3o_drake.world.choices import Goal
from s3o_drake.world.contents import SceneContents
from s3o_drake.world.goals import place_target_dishes, placed_object
from s3o_drake.world.map import Chair, Map, Table
from s3o_drake.world.objects import Dish
from s3o_drake.world.obstacles import Obstacles, Pose2
from s3o_drake.world.robot import Robot
from s3o_drake.world.settings import PlanningSettings, Settings, Uncertainty

if TYPE_CHECKING:  # the truth is read once, to make the first belief
    from s3o_drake.world.scenario import Scenario

PLACEMENT_ERROR = 0.025
"""How far (m) a point of a perceived chair may lie from where the chair truly is: the most
`s3o bench perception --tasks T --count 100` measured over both rooms' tasks (1,201 chairs;
median 0.0017, p99 0.0149, max 0.0223 in the dense room, 0.0200 in the spacious), rounded up.
The arm keeps this much more than its padding from the chairs that perception placed
(`SceneContents.unmapped_chairs_margin`): its padding alone is less than that error."""


def _pose(values: Iterable[float]) -> Pose2:
    x, y, yaw = (float(v) for v in values)
    return (x, y, yaw)


@dataclass(frozen=True)
class OverheadImages:
    """The overhead camera's depth image (m) and label image at planning time, and the labels
    of the robot's own pixels: what the learned Fea^m (the FCN) reads."""

    depth: np.ndarray
    label: np.ndarray
    robot_labels: frozenset[int] = frozenset()


@dataclass(frozen=True)
class Briefing:
    """What the robot is given before it looks: its map, the settings, the task's objects
    (what to collect or place, and where) and where it starts. Never the unmapped chairs:
    those it knows only by perceiving them. A scenario's is `Briefing.of(scenario)`."""

    map: Map
    settings: Settings
    objects: tuple[Dish, ...]
    start: Pose2
    robot: Robot
    """The robot itself: what it is, it knows."""

    @classmethod
    def of(cls, scenario: Scenario) -> Briefing:
        return cls(map=scenario.map, settings=scenario.settings,
                   objects=tuple(scenario.dishes), start=_pose(scenario.robot.start),
                   robot=scenario.robot_value)

    @property
    def tables(self) -> tuple[Table, ...]:
        return self.map.tables

    @property
    def dishes(self) -> tuple[Dish, ...]:
        """The objects (the name the schema and the goals' rules read)."""
        return self.objects


@dataclass(frozen=True)
class KnownWorld:
    """What the robot knows when it plans.

    `map` is what it was given of the room: the room, the tables, the mapped chairs only
    (never the unmapped ones: the robot knows those only by perceiving them); `settings` are
    the run's parameters; `robot`, the robot itself. The rest is what changes between plans:
    the perceived chairs, the objects that remain, and the robot's pose.
    """

    map: Map
    settings: Settings
    perceived_chairs: tuple[Pose2, ...]
    dishes: tuple[Dish, ...]
    """What the plan is for: the objects left to collect or to place, and the place target
    of each object to place (an object of its kind standing at its place, named
    `goals.place_target_name`; `places`)."""
    pose: Pose2
    robot: Robot
    overhead: OverheadImages | None = field(default=None, compare=False)
    fixtures: tuple[Dish, ...] = ()
    """The objects that stay where they are (a plate something goes onto): obstacles only."""
    held: str = ""
    """The object in the gripper ("" for none): an object to place, picked already; the
    plan is for its place target only."""
    contacts: tuple[tuple[float, float], ...] = ()
    """Where the base was blocked by something neither the map nor the camera showed (the
    base navigator's bumper reading, plan view): each an obstacle of CONTACT_RADIUS to the
    navigation map, so that a replan does not send the base the same way again. The Drake
    checks (pickups, free stops) do not see them: the robot knows a point, not a shape."""

    @classmethod
    def of(cls, given: Briefing | Scenario, *, perceived_chairs: Iterable[Sequence[float]],
           pose: Sequence[float] | None = None, dishes: Iterable[str] | None = None,
           overhead: OverheadImages | None = None, held: str = "") -> KnownWorld:
        """The robot's knowledge with what it was `given` (a Briefing, or a scenario's) and
        these perceived chairs, standing at `pose` (default: its start) with the objects
        `dishes` left (default: all) and the place targets of those to place; `held` (one
        of `dishes`) is in the gripper, so only its place target is planned for."""
        given = given if isinstance(given, Briefing) else Briefing.of(given)
        left = None if dishes is None else set(dishes)
        kept = [d for d in given.objects if d.goal != Goal.STAY.value
                and (left is None or d.name in left) and d.name != held]
        targets = {placed_object(t.name): t for t in place_target_dishes(given)}
        kept += [t for name, t in targets.items() if left is None or name in left]
        if held and held not in targets:
            raise ValueError(f"held: {held!r} is no object to place")
        here = given.start if pose is None else _pose(pose)
        return cls(map=given.map, settings=given.settings,
                   perceived_chairs=tuple(_pose(p) for p in perceived_chairs),
                   dishes=tuple(kept), pose=here, robot=given.robot, overhead=overhead,
                   fixtures=tuple(d for d in given.objects if d.goal == Goal.STAY.value),
                   held=held)

    @classmethod
    def perfect(cls, scenario: Scenario, **kwargs) -> KnownWorld:
        """Perfect perception: the scenario's unmapped chairs exactly (tests, and benchmarks
        that measure planning alone)."""
        chairs = [c.pose for c in scenario.chairs if not c.mapped]
        return cls.of(scenario, perceived_chairs=chairs, **kwargs)

    def moved(self, *, pose: Sequence[float], dishes: Iterable[str],
              perceived_chairs: Iterable[Sequence[float]] | None = None,
              overhead: OverheadImages | None = None) -> KnownWorld:
        """The same map later: the robot at `pose` with `dishes` left (and, when given, the
        chairs and images of a new look)."""
        left = set(dishes)
        chairs = self.perceived_chairs if perceived_chairs is None else \
            tuple(_pose(p) for p in perceived_chairs)
        return dataclasses.replace(
            self, pose=_pose(pose),
            dishes=tuple(d for d in self.dishes
                         if d.name in left or placed_object(d.name) in left),
            perceived_chairs=chairs, overhead=self.overhead if overhead is None else overhead)

    @property
    def planner(self) -> PlanningSettings:
        return self.settings.planner

    @property
    def uncertainty(self) -> Uncertainty:
        return self.settings.uncertainty

    @property
    def mapped_chairs(self) -> tuple[Pose2, ...]:
        return tuple(_pose(c.pose) for c in self.map.chairs)

    @property
    def chair_poses(self) -> tuple[Pose2, ...]:
        """Every chair the robot knows: mapped, then perceived."""
        return self.mapped_chairs + self.perceived_chairs

    @property
    def dish_names(self) -> list[str]:
        return [d.name for d in self.dishes]

    @property
    def places(self) -> dict[str, str]:
        """Each object to place that is left, and the name of its place target."""
        return {placed_object(d.name): d.name for d in self.dishes if placed_object(d.name)}

    @cached_property
    def obstacles(self) -> Obstacles:
        return Obstacles.of(self.map.room.bounds, self.map.tables, self.chair_poses,
                            self.contacts)

    def obstacles_grown(self, margin: float) -> Obstacles:
        """`obstacles` with each perceived chair grown by `margin` (m): the room as it may
        be where perception errs by up to `margin`."""
        if margin <= 0.0:
            return self.obstacles
        margins = [0.0] * len(self.mapped_chairs) + [margin] * len(self.perceived_chairs)
        return Obstacles.of(self.map.room.bounds, self.map.tables, self.chair_poses,
                            self.contacts, chair_margins=margins)

    @property
    def contents(self) -> SceneContents:
        """The known world as a Drake plant holds it (the planner's scene): the mapped
        chairs and the perceived ones (`perceived_<i>`), the objects that remain and the
        fixtures, the robot at its pose. The contacts are not in it: the robot knows a
        point, not a shape."""
        seen = [Chair(name=f"perceived_{i}", pose=list(p), mapped=False)
                for i, p in enumerate(self.perceived_chairs)]
        return SceneContents(room=self.map.room, tables=self.map.tables,
                             chairs=(*self.map.chairs, *seen),
                             dishes=(*self.dishes, *self.fixtures), start=self.pose,
                             robot=self.robot, floor_margin=self.settings.camera.margin,
                             unmapped_chairs_margin=PLACEMENT_ERROR)
