"""The run command end to end on a small scene."""

import base64
import re
import subprocess
import sys
from pathlib import Path

import cv2
import pytest

from s3o_drake.camera import overhead_camera
from s3o_drake.planning.plan import TaskMotionPlan
from s3o_drake.run import main as run_main
from s3o_drake.scenario import load_scenario

REPO = Path(__file__).resolve().parent.parent
SMALL = REPO / "scenarios" / "small" / "two_dishes.yaml"


def test_run_writes_playback_and_overhead_picture(tmp_path, capsys):
    out = tmp_path / "run"
    assert run_main([str(SMALL), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert str(out / "playback.html") in printed and str(out / "overhead.png") in printed

    html = (out / "playback.html").read_text()
    assert "<html" in html[:200] and "MeshCat.Viewer" in html
    # The recording holds the scene: the table, the chair, a dish and the robot's links by
    # name, inside the Meshcat commands that the page embeds as base64 data.
    commands = b"".join(base64.b64decode(data) for data in re.findall(
        r'fetch\("data:application/octet-binary;base64,([A-Za-z0-9+/=]+)"\)', html))
    for name in ("table", "chair", "plate_a", "base_link", "gripper_base", "animation"):
        assert name.encode() in commands, name

    image = cv2.imread(str(out / "overhead.png"))
    camera = overhead_camera(load_scenario(SMALL))
    assert image is not None and image.shape == (camera.height, camera.width, 3)
    assert image.std() > 10  # a picture, not a blank
    picture = cv2.imread(str(out / "feasibility.png"))
    assert picture is not None and picture.shape[0] > 300
    picture = cv2.imread(str(out / "state_space.png"))
    assert picture is not None and picture.shape[0] > 300
    assert str(out / "state_space.png") in printed

    # The plan: printed, written, and drawn.
    plan = TaskMotionPlan.read(out / "plan.json")
    assert plan.method == "S3O-GROP*" and {a.dish for a in plan.pickups} == {"plate_a", "cup_b"}
    assert "S3O-GROP* plan (seed 1)" in printed and "pickup plate_a" in printed
    for name in ("plan.png", "search.png"):
        picture = cv2.imread(str(out / name))
        assert picture is not None and picture.shape[0] > 300, name


@pytest.mark.parametrize("method", ["V-PETLON", "S3O-Random"])
def test_run_plans_with_the_method_and_seed_given(tmp_path, capsys, method):
    out = tmp_path / "run"
    assert run_main([str(SMALL), "--out", str(out), "--method", method, "--seed", "4"]) == 0
    plan = TaskMotionPlan.read(out / "plan.json")
    assert plan.method == method and plan.seed == 4
    assert f"{method} plan (seed 4)" in capsys.readouterr().out


def test_help_explains_every_option():
    result = subprocess.run([sys.executable, "-m", "s3o_drake.run", "--help"],
                            capture_output=True, text=True, check=True, cwd=REPO)
    for option in ("--out", "--meshcat", "--graphviz", "--method", "--seed", "S3O-GROP*",
                   "V-PETLON", "playback.html", "overhead.png", "plan.json", "search.png"):
        assert option in result.stdout


@pytest.mark.parametrize("argv, field", [
    (["--fast"], "--fast"),
    (["--method", "S3O-GROP**"], "--method"),
    (["--seed", "-1"], "--seed"),
    (["--seed", "one"], "--seed"),
])
def test_bad_option_is_one_line_and_status_2(tmp_path, argv, field):
    result = subprocess.run([sys.executable, "-m", "s3o_drake.run", str(SMALL), *argv],
                            capture_output=True, text=True, cwd=tmp_path)
    assert result.returncode == 2
    assert result.stderr.count("\n") == 1 and field in result.stderr
    assert not (tmp_path / "out").exists()
