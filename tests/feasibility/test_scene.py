"""The feasibility scene keeps the arm further from the chairs perception placed than from
what the map gives: a perceived chair may lie a little off, and an arm that passed it by
its padding alone touched it. The base's clearance does not change. A base that stands
within its padding may still move its arm."""

import dataclasses

import numpy as np
import pytest

from s3o_drake.belief.known_world import PLACEMENT_ERROR, Briefing, KnownWorld
from s3o_drake.feasibility.scene import FeasibilityScene

MARGIN = 0.03


def _chair_configurations(scene: FeasibilityScene, *, count: int = 4000):
    """Random configurations around the chair, each with the arm's and the base's distance
    to it (m)."""
    robot, plant = scene.robot, scene.plant
    chair = plant.GetBodyByName("chair", scene.models.chairs["chair"]).index()
    on_base = {b.index() for b in scene.base_bodies}
    rng = np.random.default_rng(0)
    for _ in range(count):
        # The chair stands at (2.0, 3.35); the robot east of it, any way round.
        pose = rng.uniform([2.4, 3.0, -np.pi], [3.0, 3.7, np.pi])
        arm = robot.arm_stow + rng.uniform(-1.5, 1.5, robot.num_arm_joints)
        q = robot.positions(*pose, arm=arm)
        clearance = scene.checker.inner.CalcRobotClearance(scene.positions.to_plant(q), 0.1)
        # Its distances are less the padding.
        near = {True: 1.0, False: 1.0}
        for body, other, d in zip(clearance.robot_indices(), clearance.other_indices(),
                                  clearance.distances(), strict=True):
            if other == chair:
                near[body in on_base] = min(near[body in on_base], d + scene.padding)
        yield q, near[False], near[True]


@pytest.fixture(scope="module")
def near_the_chair(scene):
    """Configurations, free in `scene`, in which the arm (first) or the base (second) comes
    within 1.5-3 cm of the chair and the other part stays 5 cm off."""
    found: dict[str, np.ndarray] = {}
    for q, arm, base in _chair_configurations(scene):
        if not scene.checker.CheckConfigCollisionFree(q):
            continue
        for part, mine, other in (("arm", arm, base), ("base", base, arm)):
            if part not in found and 0.015 < mine < MARGIN and other > 0.05:
                found[part] = q
        if len(found) == 2:
            return found["arm"], found["base"]
    pytest.fail("no configuration near the chair")


def test_an_arm_may_move_while_its_base_stands_within_its_padding(scene):
    on_base = {b.index() for b in scene.base_bodies}

    def base_within_padding_alone(q):
        """Whether the base alone comes within its padding of the world (and not into it)."""
        clearance = scene.checker.inner.CalcRobotClearance(scene.positions.to_plant(q), 0.1)
        within = [(body in on_base, d) for body, d in
                  zip(clearance.robot_indices(), clearance.distances(), strict=True) if d < 0]
        return bool(within) and all(base and d > 0.002 - scene.padding for base, d in within)

    standing = next((q for q, arm, base in _chair_configurations(scene)
                     if base < scene.padding and arm > 0.05 and base_within_padding_alone(q)),
                    None)
    assert standing is not None, "no configuration with the base within its padding"
    assert not scene.checker.CheckConfigCollisionFree(standing)
    assert scene.standing_checker.CheckConfigCollisionFree(standing)
    assert scene.arm_checker(standing) is scene.standing_checker


def test_the_arm_keeps_the_margin_from_a_chair_not_on_the_map(scenario, scene, near_the_chair):
    arm_near, base_near = near_the_chair
    wary = FeasibilityScene(dataclasses.replace(scenario.contents,
                                                unmapped_chairs_margin=MARGIN))
    assert not wary.checker.CheckConfigCollisionFree(arm_near)
    # The base's clearance is its footprint's, the same in every direction.
    assert wary.checker.CheckConfigCollisionFree(base_near)


def test_a_chair_on_the_map_gets_the_padding_alone(scenario, near_the_chair):
    arm_near, _ = near_the_chair
    mapped = [dataclasses.replace(c, mapped=True) for c in scenario.contents.chairs]
    known = FeasibilityScene(dataclasses.replace(
        scenario.contents, chairs=tuple(mapped), unmapped_chairs_margin=MARGIN))
    assert known.checker.CheckConfigCollisionFree(arm_near)


def test_the_belief_carries_the_perception_error_and_the_truth_none(scenario):
    assert scenario.contents.unmapped_chairs_margin == 0.0
    chairs = [list(c.pose) for c in scenario.chairs if not c.mapped]
    known = KnownWorld.of(Briefing.of(scenario), perceived_chairs=chairs,
                          pose=scenario.robot.start, dishes=[d.name for d in scenario.dishes])
    assert known.contents.unmapped_chairs_margin == PLACEMENT_ERROR > 0.0
