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

import numpy as np

from s3o_drake.world.choices import Goal
from s3o_drake.world.goals import place_target_dishes, placed_object
from s3o_drake.world.obstacles import Obstacles, Pose2
from s3o_drake.world.scenario import Chair, Dish, Scenario


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
class KnownWorld:
    """What the robot knows when it plans.

    `settings` is the scenario as a map and its settings: the room, the tables, the mapped
    chairs only (never the unmapped ones: the robot knows those only by perceiving them),
    no dishes, and the planner's, noise and camera settings. The rest is what changes
    between plans: the perceived chairs, the dishes that remain, and the robot's pose.
    """

    settings: Scenario
    perceived_chairs: tuple[Pose2, ...]
    dishes: tuple[Dish, ...]
    """What the plan is for: the objects left to collect or to place, and the place target
    of each object to place (an object of its kind standing at its place, named
    `goals.place_target_name`; `places`)."""
    pose: Pose2
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
    def of(cls, scenario: Scenario, *, perceived_chairs: Iterable[Sequence[float]],
           pose: Sequence[float] | None = None, dishes: Iterable[str] | None = None,
           overhead: OverheadImages | None = None, held: str = "") -> KnownWorld:
        """The robot's knowledge in `scenario` with these perceived chairs, standing at
        `pose` (default: the scenario's start) with the objects `dishes` left (default:
        all) and the place targets of those to place; `held` (one of `dishes`) is in the
        gripper, so only its place target is planned for."""
        left = None if dishes is None else set(dishes)
        kept = [d for d in scenario.dishes if d.goal != Goal.STAY.value
                and (left is None or d.name in left) and d.name != held]
        targets = {placed_object(t.name): t for t in place_target_dishes(scenario)}
        kept += [t for name, t in targets.items() if left is None or name in left]
        if held and held not in targets:
            raise ValueError(f"held: {held!r} is no object to place")
        here = _pose(scenario.robot.start if pose is None else pose)
        settings = dataclasses.replace(
            scenario, chairs=[c for c in scenario.chairs if c.mapped], dishes=[],
            robot=dataclasses.replace(scenario.robot, start=list(here)))
        return cls(settings=settings, perceived_chairs=tuple(_pose(p) for p in perceived_chairs),
                   dishes=tuple(kept), pose=here, overhead=overhead,
                   fixtures=tuple(d for d in scenario.dishes if d.goal == Goal.STAY.value),
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
            perceived_chairs=chairs, overhead=self.overhead if overhead is None else overhead,
            settings=dataclasses.replace(self.settings, robot=dataclasses.replace(
                self.settings.robot, start=list(_pose(pose)))))

    @property
    def planner(self):
        return self.settings.planner

    @property
    def uncertainty(self):
        return self.settings.uncertainty

    @property
    def mapped_chairs(self) -> tuple[Pose2, ...]:
        return tuple(_pose(c.pose) for c in self.settings.chairs)

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
        return Obstacles.of(self.settings.room.bounds, self.settings.tables, self.chair_poses,
                            self.contacts)

    def obstacles_grown(self, margin: float) -> Obstacles:
        """`obstacles` with each perceived chair grown by `margin` (m): the room as it may
        be where perception errs by up to `margin`."""
        if margin <= 0.0:
            return self.obstacles
        margins = [0.0] * len(self.mapped_chairs) + [margin] * len(self.perceived_chairs)
        return Obstacles.of(self.settings.room.bounds, self.settings.tables, self.chair_poses,
                            self.contacts, chair_margins=margins)

    def as_scenario(self) -> Scenario:
        """The known world as a Scenario, for what builds a Drake plant of it (the oracle's
        FeasibilityScene): the perceived chairs as unmapped chairs `perceived_<i>`, the
        dishes that remain, the robot at its pose."""
        seen = [Chair(name=f"perceived_{i}", pose=list(p), mapped=False)
                for i, p in enumerate(self.perceived_chairs)]
        return dataclasses.replace(self.settings, chairs=[*self.settings.chairs, *seen],
                                   dishes=[*self.dishes, *self.fixtures])
