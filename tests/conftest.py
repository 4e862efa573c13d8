"""Fixtures that several test modules share: the small two-dish scenario, its feasibility
scene and its Fea^m checker.

Module-scoped, as each module had them before: the tests of a module share one instance,
and no module sees another's. A module that means something else by one of these names
(a different scenario, a RobotScene) defines its own fixture, which takes precedence.
"""

from pathlib import Path

import pytest

from s3o_drake.feasibility.check import FeasibilityChecker
from s3o_drake.feasibility.scene import FeasibilityScene
from s3o_drake.scenario import Scenario, load_scenario

TWO_DISHES = Path(__file__).resolve().parent.parent / "scenarios" / "small" / "two_dishes.yaml"


@pytest.fixture(scope="module")
def scenario() -> Scenario:
    """scenarios/small/two_dishes.yaml: a table (x 1.4..2.6, y 2.1..2.9, top at 0.75 m)
    with a plate at (1.85, 2.3) and a cup at (2.15, 2.3)."""
    return load_scenario(TWO_DISHES)


@pytest.fixture(scope="module")
def scene(scenario: Scenario) -> FeasibilityScene:
    """The feasibility scene (plant, collision checker) of `scenario`."""
    return FeasibilityScene(scenario)


@pytest.fixture(scope="module")
def checker(scene: FeasibilityScene) -> FeasibilityChecker:
    """The Fea^m check on `scene`, with the shipped reachability map."""
    return FeasibilityChecker(scene)
