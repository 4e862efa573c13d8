"""How often the reachability map agrees with exhaustive IK, on random queries.

Queries are drawn as a planner and its noise make them: a dish of the scene, a base position
uniform in the disc of radius `max_distance` around it (inside the room), the yaw facing the
dish plus navigation noise, and a reach offset of the dish (T^m, horizontal). Both methods
answer every query (`FeasibilityChecker` with method "map" and method "ik"); the report
gives the agreement over all queries and over those whose base is collision-free (the base
check is shared, so those are the informative ones), and lists the disagreements. The
command is `s3o bench reachability-agreement`.
"""

import math
import time
from dataclasses import dataclass, field

import numpy as np

from s3o_drake.feasibility.check import FeasibilityChecker
from s3o_drake.feasibility.reachability.map import ReachabilityMap
from s3o_drake.feasibility.scene import FeasibilityScene
from s3o_drake.world.angles import facing_yaw
from s3o_drake.world.resources import RESTAURANT

DEFAULT_SCENARIOS = (str(RESTAURANT),)
MAX_DISTANCE = 1.1
YAW_STD = 0.05
REACH_STD = 0.01


@dataclass
class Queries:
    """Random queries of one scene: dish names (n,), base poses (n, 3), reach offsets (n, 3)."""

    dishes: list[str]
    bases: np.ndarray
    offsets: np.ndarray


def sample_queries(scene: FeasibilityScene, count: int, rng: np.random.Generator, *,
                   max_distance: float = MAX_DISTANCE, yaw_std: float = YAW_STD,
                   reach_std: float = REACH_STD, vertical_reach: bool = False) -> Queries:
    """`count` queries around the scene's dishes (see the module docstring).

    The reach offset is horizontal (the dish's y_o is 2D), or 3D with `vertical_reach`.
    """
    names = sorted(scene.dishes)
    x_min, y_min, x_max, y_max = scene.contents.room.bounds
    dishes, bases = [], []
    while len(bases) < count:
        name = names[rng.integers(len(names))]
        p_WD, _ = scene.dish_p_WD(name)
        r = max_distance * math.sqrt(rng.uniform())
        angle = rng.uniform(-math.pi, math.pi)
        xy = p_WD + r * np.array([math.cos(angle), math.sin(angle)])
        if not (x_min < xy[0] < x_max and y_min < xy[1] < y_max):
            continue
        yaw = float(facing_yaw(xy, p_WD)) + rng.normal(0.0, yaw_std)
        dishes.append(name)
        bases.append([xy[0], xy[1], yaw])
    offsets = np.zeros((count, 3))
    dims = 3 if vertical_reach else 2
    offsets[:, :dims] = rng.normal(0.0, reach_std, size=(count, dims))
    return Queries(dishes, np.array(bases), offsets)


@dataclass
class Agreement:
    """Outcome counts of map vs IK."""

    total: int = 0
    agree: int = 0
    base_free: int = 0
    agree_base_free: int = 0
    feasible_ik: int = 0
    feasible_map: int = 0
    map_seconds: float = 0.0
    ik_seconds: float = 0.0
    disagreements: list[str] = field(default_factory=list)

    def line(self) -> str:
        return (f"agreement {self.agree}/{self.total} = {self.agree / max(self.total, 1):.1%}; "
                f"base collision-free {self.agree_base_free}/{self.base_free} = "
                f"{self.agree_base_free / max(self.base_free, 1):.1%}; feasible: IK "
                f"{self.feasible_ik}, map {self.feasible_map}; time per check: map "
                f"{1e3 * self.map_seconds / max(self.total, 1):.2f} ms, IK "
                f"{1e3 * self.ik_seconds / max(self.total, 1):.1f} ms")


def measure(scene: FeasibilityScene, queries: Queries, reachability: ReachabilityMap, *,
            fallback_ik: bool = False, ik_map_seeds: bool = True, label: str = "",
            result: Agreement | None = None, progress: bool = False) -> Agreement:
    """Runs both methods on the queries; adds to `result` (or a new Agreement).

    `ik_map_seeds=False` keeps the map's candidates out of exhaustive IK's seeds, so that
    the reference owes the map nothing (it then misses a few solutions it would confirm).
    """
    from tqdm import tqdm

    result = result if result is not None else Agreement()
    by_map = FeasibilityChecker(scene, reachability, method="map", fallback_ik=fallback_ik)
    by_ik = FeasibilityChecker(scene, reachability if ik_map_seeds else None, method="ik")
    for i in tqdm(range(len(queries.dishes)), desc=label or "queries", disable=not progress):
        dish, base, offset = queries.dishes[i], queries.bases[i], queries.offsets[i]
        start = time.perf_counter()
        a = by_map.check(base, dish, offset)
        middle = time.perf_counter()
        b = by_ik.check(base, dish, offset)
        result.map_seconds += middle - start
        result.ik_seconds += time.perf_counter() - middle
        result.total += 1
        result.feasible_map += a.feasible
        result.feasible_ik += b.feasible
        same = a.feasible == b.feasible
        result.agree += same
        if b.reason != "base_collision":
            result.base_free += 1
            result.agree_base_free += same
        if not same:
            result.disagreements.append(
                f"{label} {dish} base=({base[0]:.3f}, {base[1]:.3f}, {base[2]:.3f}) "
                f"offset=({offset[0]:.4f}, {offset[1]:.4f}): map {a.reason}/{a.grasp}, "
                f"IK {b.reason}/{b.grasp}")
    return result
