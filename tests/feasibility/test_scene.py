"""The feasibility scene keeps the arm further from the chairs perception placed than from
what the map gives: a perceived chair may lie a little off, and an arm that passed it by
its padding alone touched it. The base's clearance does not change."""

import dataclasses

import numpy as np
import pytest

from s3o_drake.belief.known_world import PLACEMENT_ERROR, Briefing, KnownWorld
from s3o_drake.feasibility.scene import FeasibilityScene

MARGIN = 0.03


def _near_the_chair(scene: FeasibilityScene, *, count: int = 4000):
    """Configurations, free in `scene`, in which the arm (first) or the base (second) comes
    within 1.5-3 cm of the chair and the other part stays 5 cm off."""
    robot, plant = scene.robot, scene.plant
    chair = plant.GetBodyByName("chair", scene.models.chairs["chair"]).index()
    base = scene.robot_instances.body(robot.base_link)
    on_base = {b.index() for b in plant.GetBodiesWeldedTo(base)}
    rng = np.random.default_rng(0)
    found: dict[str, np.ndarray] = {}
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
        if not scene.checker.CheckConfigCollisionFree(q):
            continue
        for part, mine, other in (("arm", near[False], near[True]),
                                  ("base", near[True], near[False])):
            if part not in found and 0.015 < mine < MARGIN and other > 0.05:
                found[part] = q
        if len(found) == 2:
            return found["arm"], found["base"]
    pytest.fail("no configuration near the chair")


@pytest.fixture(scope="module")
def near_the_chair(scene):
    return _near_the_chair(scene)


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
