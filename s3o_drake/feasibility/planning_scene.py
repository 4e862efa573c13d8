"""One Drake scene of a belief, built once per plan and shared by everything that asks Drake
about it: the oracle's heatmaps, the free-stop test and the recovery's stop check.

A `PlanningScene` holds what the robot knows as Drake sees it: a `FeasibilityScene` of the
known world's contents (the map, the perceived chairs, the objects that remain; never the
unmapped chairs), its collision checker and the known obstacles, and makes the oracle and
the free-stop test from them when first asked. Building the plant and its collision checker
takes about 0.3 s; a plan (with its network re-plan and its stop checks) builds it once.
"""

from __future__ import annotations

from functools import cached_property
from pathlib import Path

from s3o_drake.belief.known_world import KnownWorld
from s3o_drake.feasibility.check import FeasibilityChecker
from s3o_drake.feasibility.oracle import FeasibilityOracle
from s3o_drake.feasibility.reachability.map import ReachabilityMap
from s3o_drake.feasibility.scene import FeasibilityScene
from s3o_drake.feasibility.stops import FreeStops


class PlanningScene:
    """The known world's plant, checker and obstacles (module docstring)."""

    def __init__(self, known: KnownWorld, *, reachability: Path | None = None):
        self.known = known
        self.obstacles = known.obstacles
        self.scene = FeasibilityScene(known.contents, obstacles=known.obstacles)
        self._reachability = reachability

    @cached_property
    def checker(self) -> FeasibilityChecker:
        """The pickup check on the known world (with the reachability map)."""
        rmap = ReachabilityMap.shared(self._reachability, robot=self.scene.robot)
        return FeasibilityChecker(self.scene, rmap, method="map")

    @cached_property
    def oracle(self) -> FeasibilityOracle:
        """Fea^m on the known world under the settings' noise model."""
        return FeasibilityOracle(self.checker, self.known.uncertainty)

    @cached_property
    def free_stops(self) -> FreeStops:
        """The stops free in the known world (`stops.py`)."""
        return FreeStops(self.scene, self.known.dish_names)
