"""A scenario written as Drake model directives (`s3o directives`): Drake's own parser and
model_visualizer open it, and it holds what the project's builder builds, where it builds it."""

import os
import subprocess
import sys

import numpy as np
import pytest
from pydrake.multibody.parsing import LoadModelDirectives, Parser, ProcessModelDirectives
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph
from pydrake.multibody.tree import BodyIndex
from pydrake.systems.framework import DiagramBuilder

from s3o_drake.commands.directives import main as directives
from s3o_drake.world.builder import populate_plant
from s3o_drake.world.resources import RESTAURANT, SCENARIOS_DIR
from s3o_drake.world.scenario import load_scenario
from tests.conftest import refused


def _plant():
    plant, scene_graph = AddMultibodyPlantSceneGraph(DiagramBuilder(), 0.0)
    return plant, scene_graph


def _body_poses(plant) -> dict[tuple[str, str], np.ndarray]:
    context = plant.CreateDefaultContext()
    poses = {}
    for i in range(plant.num_bodies()):
        body = plant.get_body(BodyIndex(i))
        key = (plant.GetModelInstanceName(body.model_instance()), body.name())
        poses[key] = plant.EvalBodyPoseInWorld(context, body).GetAsMatrix4()
    return poses


@pytest.mark.parametrize("path", [RESTAURANT, SCENARIOS_DIR / "tidy_home.yaml"],
                         ids=lambda p: p.stem)
def test_directives_load_in_a_fresh_plant_with_the_builders_bodies_where_it_puts_them(
        tmp_path, capsys, path):
    assert directives([str(path), "--out", str(tmp_path)]) == 0
    dmd = tmp_path / f"{path.stem}.dmd.yaml"
    assert str(dmd) in capsys.readouterr().out

    scenario = load_scenario(path)
    built, built_geometry = _plant()
    populate_plant(built, built_geometry, scenario.contents)
    built.Finalize()
    loaded, loaded_geometry = _plant()
    parser = Parser(loaded)
    parser.package_map().AddPackageXml(str(tmp_path / "package.xml"))
    ProcessModelDirectives(LoadModelDirectives(str(dmd)), loaded, parser)
    loaded.Finalize()

    expected, got = _body_poses(built), _body_poses(loaded)
    # The floor and walls are on the builder's world body; the directives' static room
    # model holds them in one body of its own.
    assert set(got) - set(expected) == {("room", "room")}
    assert set(expected) <= set(got)
    assert {name for name, _ in expected} >= {c.name for c in scenario.chairs}
    for key, X_WB in expected.items():
        np.testing.assert_allclose(got[key], X_WB, atol=1e-12, err_msg=str(key))
    assert (loaded_geometry.model_inspector().num_geometries()
            == built_geometry.model_inspector().num_geometries())


def test_model_visualizer_opens_them_headless(tmp_path):
    assert directives([str(SCENARIOS_DIR / "tidy_home.yaml"), "--out", str(tmp_path)]) == 0
    command = [sys.executable, "-m", "pydrake.visualization.model_visualizer", "--loop_once",
               str(tmp_path / "tidy_home.dmd.yaml")]
    shown = subprocess.run(command, capture_output=True, text=True, timeout=120,
                           env=dict(os.environ, ROS_PACKAGE_PATH=str(tmp_path)))
    assert shown.returncode == 0, shown.stderr[-2000:]
    # Without the package on the path the robot's URL is unknown: the test sees a load.
    unknown = subprocess.run(command, capture_output=True, text=True, timeout=120,
                             env={k: v for k, v in os.environ.items()
                                  if k != "ROS_PACKAGE_PATH"})
    assert unknown.returncode != 0 and "s3o_tidy_home" in unknown.stderr


def test_bad_input_is_one_line_exit_2_and_writes_nothing(tmp_path, capsys):
    out = tmp_path / "out"
    assert "no such scenario" in refused(directives, [str(tmp_path / "nope.yaml"), "--out",
                                                      str(out)], capsys)
    assert "--set planner.top_k" in refused(
        directives, [str(RESTAURANT), "--out", str(out), "--set", "planner.top_k=none"], capsys)
    (tmp_path / "file").write_text("")
    assert "--out" in refused(directives, [str(RESTAURANT), "--out", str(tmp_path / "file")],
                              capsys)
    assert not out.exists()
