"""The oracle's maps kept on disk (`S3O_CACHE`): read back only when everything they are
made of is the same, the code included; never a cause of a wrong or a missing map."""

import dataclasses
import functools
import os
from types import SimpleNamespace

import numpy as np
import pytest

from s3o_drake.feasibility import oracle_cache
from s3o_drake.feasibility.check import FeasibilityChecker
from s3o_drake.feasibility.oracle import FeasibilityOracle
from s3o_drake.feasibility.oracle_cache import CACHE_VARIABLE
from s3o_drake.feasibility.scene import FeasibilityScene
from s3o_drake.world.map import Chair
from s3o_drake.world.robot import RobotFiles, load_robot
from s3o_drake.world.settings import Uncertainty

CHEAP = {"cells": 8, "fine_cell": 0.5}  # a coarse map: the cache, not the map, is tested


@pytest.fixture
def folder(tmp_path, monkeypatch):
    monkeypatch.setenv(CACHE_VARIABLE, str(tmp_path / "cache"))
    return tmp_path / "cache"


@pytest.fixture
def computed(monkeypatch):
    """The dishes whose maps the oracle computes (rather than reads)."""
    calls = []
    real = FeasibilityOracle._expectation

    def counting(self, dish, *args, **kwargs):
        calls.append(dish)
        return real(self, dish, *args, **kwargs)

    monkeypatch.setattr(FeasibilityOracle, "_expectation", counting)
    return calls


def test_a_map_is_computed_once_and_read_back_the_same(folder, computed, checker):
    oracle = FeasibilityOracle(checker, Uncertainty())
    first = oracle.heatmap("plate_a", **CHEAP)
    again = FeasibilityOracle(checker, Uncertainty()).heatmap("plate_a", **CHEAP)
    assert computed == ["plate_a"] and len(list(folder.glob("*.npy"))) == 1
    np.testing.assert_array_equal(first.values, again.values)
    assert (first.x0, first.y0, first.cell) == (again.x0, again.y0, again.cell)


def _slow_square(log: str) -> np.ndarray:
    """A stand-in for a map's computation: logs that it ran, and takes long enough that a
    second process asks while it runs."""
    import time

    with open(log, "a") as f:
        f.write(f"{os.getpid()}\n")
    time.sleep(1.0)
    return np.arange(4.0) ** 2


def _ask(log: str) -> list[float]:
    return oracle_cache.cached_array(lambda: ("square",), lambda: _slow_square(log),
                                     robot=load_robot("ur5e")).tolist()


def test_a_map_asked_for_by_processes_at_once_is_computed_once(folder, tmp_path):
    """Two test processes, or a study beside a check of its tasks, asking for one map at
    the same time: one computes it, the other waits and reads it."""
    import multiprocessing

    log = str(tmp_path / "computed.log")
    with multiprocessing.get_context("fork").Pool(3) as pool:
        maps = pool.map(_ask, [log] * 3)
    assert maps == [[0.0, 1.0, 4.0, 9.0]] * 3
    assert len((tmp_path / "computed.log").read_text().splitlines()) == 1


def test_what_a_map_is_made_of_decides_whether_it_is_read(folder, computed, scenario,
                                                          checker, monkeypatch):
    oracle = FeasibilityOracle(checker, Uncertainty())
    oracle.heatmap("plate_a", **CHEAP)
    oracle.heatmap("cup_b", **CHEAP)  # another dish
    oracle.heatmap("plate_a", cells=8, fine_cell=0.25)  # another grid
    FeasibilityOracle(checker, Uncertainty(nav_xy_std=0.2)).heatmap("plate_a", **CHEAP)
    chair = Chair(name="chair_x", pose=[2.0, 1.6, 0.0])
    other = FeasibilityScene(dataclasses.replace(scenario.contents, chairs=(chair,)))
    FeasibilityOracle(FeasibilityChecker(other), Uncertainty()).heatmap("plate_a", **CHEAP)
    monkeypatch.setattr(oracle_cache, "code_digest", lambda robot: "other code")
    oracle.heatmap("plate_a", **CHEAP)
    assert computed == ["plate_a", "cup_b", "plate_a", "plate_a", "plate_a", "plate_a"]
    assert len(list(folder.glob("*.npy"))) == 6


def test_without_the_variable_nothing_is_kept(tmp_path, monkeypatch, computed, checker):
    monkeypatch.delenv(CACHE_VARIABLE, raising=False)
    monkeypatch.chdir(tmp_path)
    oracle = FeasibilityOracle(checker, Uncertainty())
    oracle.heatmap("plate_a", **CHEAP)
    oracle.heatmap("plate_a", **CHEAP)
    assert computed == ["plate_a", "plate_a"] and not list(tmp_path.iterdir())


def test_a_file_cut_short_is_computed_again_and_replaced(folder, computed, checker):
    oracle = FeasibilityOracle(checker, Uncertainty())
    first = oracle.heatmap("plate_a", **CHEAP)
    (path,) = folder.glob("*.npy")
    path.write_bytes(path.read_bytes()[:40])
    again = oracle.heatmap("plate_a", **CHEAP)
    assert computed == ["plate_a", "plate_a"]
    np.testing.assert_array_equal(first.values, again.values)
    np.testing.assert_array_equal(np.load(path), first.values)
    assert not list(folder.glob(".*.tmp"))


def test_the_code_digest_changes_with_a_source_file_or_the_robot_model(tmp_path,
                                                                        monkeypatch):
    package, models = tmp_path / "package", tmp_path / "models"
    (package / "feasibility").mkdir(parents=True)
    (models / "ur5e" / "fcn").mkdir(parents=True)
    (models / "furniture").mkdir()
    (package / "feasibility" / "oracle.py").write_text("A = 1\n")
    (models / "ur5e" / "robot.urdf").write_text("<robot/>")
    monkeypatch.setattr(oracle_cache, "_PACKAGE_DIR", package)
    monkeypatch.setattr(oracle_cache, "MODELS_DIR", models)
    robot = SimpleNamespace(files=RobotFiles(models / "ur5e"))  # what the digest reads of one
    digest = functools.partial(oracle_cache.code_digest.__wrapped__, robot)
    before = digest()
    (package / "notes.txt").write_text("not code")
    (models / "ur5e" / "fcn" / "fcn.pt").write_bytes(b"weights")  # the network's: no map's
    assert digest() == before
    (package / "feasibility" / "oracle.py").write_text("A = 2\n")
    edited = digest()
    (models / "ur5e" / "robot.urdf").write_text("<robot name='other'/>")
    assert len({before, edited, digest()}) == 3


def test_a_benchmark_that_times_the_oracle_bypasses_the_cache(folder, computed, checker):
    oracle = FeasibilityOracle(checker, Uncertainty())
    oracle.heatmap("plate_a", **CHEAP)
    with oracle_cache.bypassed():
        oracle.heatmap("plate_a", **CHEAP)
        oracle.heatmap("cup_b", **CHEAP)
    assert computed == ["plate_a", "plate_a", "cup_b"]
    assert len(list(folder.glob("*.npy"))) == 1
    assert os.environ[CACHE_VARIABLE] == str(folder)


def test_the_same_chairs_under_other_names_share_a_map(folder, computed, scenario):
    """A belief names its chairs perceived_0, ...; the true world chair_1, ...: the same
    chairs, the same map, computed once."""
    def with_chair(name):
        chair = Chair(name=name, pose=[2.0, 1.6, 0.0])
        scene = FeasibilityScene(dataclasses.replace(scenario.contents, chairs=(chair,)))
        return FeasibilityOracle(FeasibilityChecker(scene), Uncertainty())

    true = with_chair("chair_1").heatmap("plate_a", **CHEAP)
    believed = with_chair("perceived_0").heatmap("plate_a", **CHEAP)
    assert computed == ["plate_a"]
    np.testing.assert_array_equal(true.values, believed.values)
