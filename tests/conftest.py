"""Fixtures that several test modules share: the small two-dish scenario, its feasibility
scene and its Fea^m checker.

Module-scoped, as each module had them before: the tests of a module share one instance,
and no module sees another's. A module that means something else by one of these names
(a different scenario, a RobotScene) defines its own fixture, which takes precedence.
"""

import hashlib
import math
import multiprocessing
import os
import shutil
import tempfile
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pytest

from s3o_drake.belief.known_world import KnownWorld
from s3o_drake.feasibility.check import FeasibilityChecker
from s3o_drake.feasibility.oracle import Heatmap
from s3o_drake.feasibility.oracle_cache import CACHE_VARIABLE
from s3o_drake.feasibility.planning_scene import PlanningScene
from s3o_drake.feasibility.scene import FeasibilityScene
from s3o_drake.planning.pipeline import PlanningResult, plan_from
from s3o_drake.world.objects import Dish
from s3o_drake.world.scenario import Scenario, load_scenario
from s3o_drake.world.worker_processes import THREADS_VARIABLE, core_count

TWO_DISHES = Path(__file__).resolve().parents[1] / "scenarios" / "small" / "two_dishes.yaml"
COARSE_MAPS = {"cells": 32, "fine_cell": 0.125}
"""`compute_heatmaps` arguments for coarse maps, where a test is not about their accuracy:
32 cells of 12.5 cm, the landing's success evaluated at that spacing (and halved where it
changes). On two_dishes 3.4x cheaper than the fine evaluation, values within 0.07 of it
(0.003 on average)."""



class StepClock:
    """A stand-in clock for budget tests (`world.deadline`): it stands still until the test
    moves it on (`advance`), so what a budget cuts does not depend on the machine's speed.
    Held in shared memory: the search workers that planning forks read and move the same
    clock."""

    def __init__(self) -> None:
        self._now = multiprocessing.get_context("fork").Value("d", 0.0)

    def __call__(self) -> float:
        return self._now.value

    def advance(self, seconds: float) -> None:
        with self._now.get_lock():
            self._now.value += seconds


def clingo_proves(monkeypatch: pytest.MonkeyPatch) -> None:
    """Below 12 locations clingo stops once 0.3 s of wall time pass without a cheaper order
    (`planner.STALL`); its proof of an 8-location order takes 0.04 s idle, and a busy
    machine can stretch that past the wait. For tests that assert the proof: clingo waits
    for it."""
    from s3o_drake.planning.task import planner

    monkeypatch.setattr(planner, "STALL", 60.0)


def still_clock() -> float:
    """A clock that stands still: a budget on it never runs out, so that a test's plan is
    the one that no budget cuts, on any machine."""
    return 0.0

@pytest.fixture(scope="session")
def _meshcat_server():
    """The test process's one Meshcat, made on its main thread and kept to its end: Drake
    aborts when a Meshcat is destroyed on another thread, and one held in a test diagram's
    reference cycles would be freed on whichever thread the garbage collector runs next
    (as `commands.common.start_meshcat` keeps the commands' server)."""
    from pydrake.geometry import Meshcat

    return Meshcat()


@pytest.fixture
def meshcat(_meshcat_server):
    """The process's Meshcat, emptied of what an earlier test drew."""
    _meshcat_server.Delete()
    _meshcat_server.DeleteRecording()
    return _meshcat_server


@pytest.fixture(scope="module")
def scenario() -> Scenario:
    """scenarios/small/two_dishes.yaml: a table (x 1.4..2.6, y 2.1..2.9, top at 0.75 m)
    with a plate at (1.85, 2.3) and a cup at (2.15, 2.3)."""
    return load_scenario(TWO_DISHES)


@pytest.fixture(scope="module")
def scene(scenario: Scenario) -> FeasibilityScene:
    """The feasibility scene (plant, collision checker) of `scenario`."""
    return FeasibilityScene(scenario.contents)


@pytest.fixture(scope="module")
def checker(scene: FeasibilityScene) -> FeasibilityChecker:
    """The Fea^m check on `scene`, with the shipped reachability map."""
    return FeasibilityChecker(scene)


PLATE = "  - {name: plate_a, table: table, position: [1.85, 2.3], kind: plate}\n"
CUP = "  - {name: cup_b, table: table, position: [2.15, 2.3], kind: cup}\n"
BOWL_NORTH = "  - {name: bowl_north, table: long_table, position: [2.5, 2.35], kind: bowl}\n"


def one_dish(scene: str, left_out: str) -> str:
    """scenarios/small/`scene`.yaml without the dish line `left_out`: a task of one dish,
    for a test that is not about how many (the oracle's map of each dish is most of a
    task's difficulty, and its drive and pickup most of a run: a second dish costs about
    twice both)."""
    one = (TWO_DISHES.parent / f"{scene}.yaml").read_text().replace(left_out, "")
    assert one.count("kind:") == 1
    return one


def cups_along_edges(scenario: Scenario, count: int) -> list[tuple[Dish, np.ndarray]]:
    """`count` cups 0.22 m apart along the long edges of the scenario's tables, 0.1 m in
    from each edge, each with the unit vector out of its table (a crowded task at scale)."""
    cups = []
    for t in scenario.tables:
        hx, hy = t.size[0] / 2 - 0.1, t.size[1] / 2 - 0.1
        c, s = math.cos(t.yaw), math.sin(t.yaw)
        for side in (-1, 1):
            for x in np.linspace(-hx, hx, max(1, round(2 * hx / 0.22))):
                p = np.asarray(t.center) + np.array([c * x - s * side * hy,
                                                     s * x + c * side * hy])
                cups.append((Dish(name=f"cup_{len(cups):02d}", table=t.name,
                                  position=[float(p[0]), float(p[1])], kind="cup"),
                             np.array([-s * side, c * side])))
    assert len(cups) >= count
    return cups[:count]


class OracleMapsOnce:
    """The planning pipeline (`plan_from`), with the Drake oracle's coarse Fea^m of each
    known world (`COARSE_MAPS`): the executive's tests plan the same small scenes again and
    again, the oracle is most of a plan's time, and they are not about the maps' accuracy.
    Kept per process by what they are made of (the known world's plant contents, its
    contacts and its noise model), and across the test processes by the oracle's own cache
    (`S3O_CACHE`, set for the session by `pytest_configure`). Plugged in as the
    ExecutiveSystem's `plan_from`; `heatmaps(known)` hands out the maps alone."""

    def __init__(self) -> None:
        self._maps: dict[str, Sequence[Heatmap]] = {}

    def heatmaps(self, known: KnownWorld) -> Sequence[Heatmap]:
        """The oracle's coarse maps of `known`'s remaining dishes."""
        key = hashlib.sha1(repr((known.contents, known.contacts, known.uncertainty))
                           .encode()).hexdigest()
        if key not in self._maps:
            oracle = PlanningScene(known).oracle
            self._maps[key] = [oracle.heatmap(d.name, **COARSE_MAPS)
                               for d in known.contents.dishes]
        return self._maps[key]

    def __call__(self, known: KnownWorld, **kwargs) -> PlanningResult:
        if known.planner.feasibility != "oracle" or kwargs.get("heatmaps") is not None:
            return plan_from(known, **kwargs)
        return plan_from(known, heatmaps=self.heatmaps(known), **kwargs)


def pytest_configure(config: pytest.Config) -> None:
    # The test processes share the cores as a study's workers do (world/worker_processes).
    workers = getattr(config, "workerinput", {}).get("workercount")
    if workers:
        os.environ.setdefault(THREADS_VARIABLE, str(max(1, core_count() // workers)))
    # One oracle cache for the session: the controlling process makes the folder before
    # the test processes start, and they and every process they start inherit it.
    if not hasattr(config, "workerinput") and CACHE_VARIABLE not in os.environ:
        os.environ[CACHE_VARIABLE] = tempfile.mkdtemp(prefix="s3o_oracle_cache_")
        config.add_cleanup(lambda: shutil.rmtree(os.environ.pop(CACHE_VARIABLE),
                                                 ignore_errors=True))


ORACLE_MAPS_ONCE = OracleMapsOnce()


def refused(main, argv: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    """What a command's `main` says when it refuses `argv`: it exits with status 2 and one
    line on stderr, which is returned."""
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    return err
