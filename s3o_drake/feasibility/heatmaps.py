"""Fea^m heatmaps of many dishes, spread over worker processes, with a progress bar.

Each worker builds its own scene and checker once (they hold Drake contexts that cannot
cross processes) and then computes whole heatmaps. A heatmap is an expectation without
sampling (`FeasibilityOracle.expectation`), so the maps are the same whatever the worker
count.
"""

import logging
from collections.abc import Sequence
from pathlib import Path
from typing import Protocol

from tqdm import tqdm

from s3o_drake.feasibility.check import FeasibilityChecker
from s3o_drake.feasibility.oracle import (
    CROP_CELLS,
    CROP_SIZE,
    FINE_CELL,
    FeasibilityOracle,
    Heatmap,
)
from s3o_drake.feasibility.reachability.map import ReachabilityMap
from s3o_drake.feasibility.scene import FeasibilityScene
from s3o_drake.world.contents import SceneContents
from s3o_drake.world.obstacles import Obstacles
from s3o_drake.world.settings import Uncertainty
from s3o_drake.world.worker_processes import process_pool

# Each worker process's oracle, made once by its initializer.
_worker_oracle: FeasibilityOracle | None = None


class SceneSource(Protocol):
    """A room and a noise model to rate pickups in: the true world (a `Scenario`: every
    chair, for labels and ground truth) or a belief (a `KnownWorld`: what a planner knows)."""

    @property
    def contents(self) -> SceneContents: ...

    @property
    def uncertainty(self) -> Uncertainty: ...


def make_oracle(source: SceneSource, *, method: str = "map",
                reachability: Path | None = None,
                obstacles: Obstacles | None = None) -> FeasibilityOracle:
    """Scene, checker and oracle for a room (its chairs: those it lists); `obstacles` are
    its furniture's footprints when the caller has them already."""
    scene = FeasibilityScene(source.contents, obstacles=obstacles)
    rmap = ReachabilityMap.shared(reachability, robot=scene.robot) if method == "map" else None
    return FeasibilityOracle(FeasibilityChecker(scene, rmap, method=method),
                             source.uncertainty)


def _init_worker(contents: SceneContents, uncertainty: Uncertainty, method: str,
                 reachability: Path | None, obstacles: Obstacles | None = None) -> None:
    global _worker_oracle
    logging.getLogger("drake").setLevel(logging.WARNING)  # one line per worker is noise
    scene = FeasibilityScene(contents, obstacles=obstacles)
    rmap = ReachabilityMap.shared(reachability, robot=scene.robot) if method == "map" else None
    _worker_oracle = FeasibilityOracle(FeasibilityChecker(scene, rmap, method=method),
                                       uncertainty)


def _heatmap_job(job: tuple) -> Heatmap:
    dish, size, cells, whole_room, fine_cell = job
    if whole_room:
        return _worker_oracle.room_heatmap(dish, cell=size)
    return _worker_oracle.heatmap(dish, size=size, cells=cells, fine_cell=fine_cell)


def oracle_heatmaps(oracle: FeasibilityOracle, dishes: Sequence[str], *,
                    size: float = CROP_SIZE, cells: int = CROP_CELLS,
                    progress: bool = False) -> list[Heatmap]:
    """Crop heatmaps of the dishes from an oracle the caller holds (a plan's one scene)."""
    bar = tqdm(dishes, desc="feasibility heatmaps", unit="dish", disable=not progress)
    return [oracle.heatmap(name, size=size, cells=cells) for name in bar]


def compute_heatmaps(source: SceneSource, dishes: Sequence[str] | None = None, *,
                     workers: int = 1, size: float = CROP_SIZE,
                     cells: int = CROP_CELLS, whole_room: bool = False,
                     method: str = "map", reachability: Path | None = None,
                     progress: bool = True, obstacles: Obstacles | None = None,
                     fine_cell: float = FINE_CELL) -> list[Heatmap]:
    """Heatmaps of the dishes (default: all), in their order.

    Crops of `size` metres at `cells` x `cells` around each dish, or, with
    `whole_room=True`, the whole room at a cell of `size` metres. `obstacles`: the
    room's furniture footprints, when the caller has them (a KnownWorld's). `fine_cell`:
    the grid the oracle evaluates crops on starts at least this fine (`expectation`; a
    coarser one costs less, for coarse maps). Each worker
    builds its own scene; a caller that holds an oracle already uses `oracle_heatmaps`.
    """
    contents = source.contents
    names = list(dishes) if dishes is not None else [d.name for d in contents.dishes]
    jobs = [(name, size, cells, whole_room, fine_cell) for name in names]
    bar = tqdm(total=len(jobs), desc="feasibility heatmaps", unit="dish", disable=not progress)
    results: list[Heatmap] = []
    if workers <= 1 or len(jobs) <= 1:
        _init_worker(contents, source.uncertainty, method, reachability, obstacles)
        for job in jobs:
            results.append(_heatmap_job(job))
            bar.update()
    else:
        with process_pool(min(workers, len(jobs)), preload=(__name__,),
                          initializer=_init_worker,
                          initargs=(contents, source.uncertainty, method, reachability,
                                    obstacles)) as pool:
            for heatmap in pool.map(_heatmap_job, jobs):
                results.append(heatmap)
                bar.update()
    bar.close()
    return results
