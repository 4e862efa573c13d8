"""The run command end to end on a small scene: plan, execute, report, playback."""

import base64
import contextlib
import io
import json
import math
import re
import shutil
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from s3o_drake.commands.run_scenario import main as run_main
from s3o_drake.execution.messages import PickupRecord
from s3o_drake.planning.plan import TaskMotionPlan
from s3o_drake.world.angles import facing_yaw, wrap
from s3o_drake.world.furniture import DISH_SHAPES
from s3o_drake.world.scenario import load_scenario
from tests.conftest import ORACLE_MAPS_ONCE, refused

REPO = Path(__file__).resolve().parents[2]
SMALL = REPO / "scenarios" / "small" / "two_dishes.yaml"


@pytest.fixture(scope="module")
def exact_run(tmp_path_factory):
    """two_dishes.yaml planned and executed without simulated noise (seed 1)."""
    out = tmp_path_factory.mktemp("run") / "run"
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):  # capsys is per test, the run per module
        status = run_main([str(SMALL), "--out", str(out), "--no-noise"])
    return status, out, printed.getvalue()


def test_without_noise_every_dish_is_collected(exact_run):
    status, out, printed = exact_run
    assert status == 0
    report = json.loads((out / "report.json").read_text())
    assert report["collected"] == report["dishes"] == 2
    assert sorted(report["collected_dishes"]) == ["cup_b", "plate_a"]
    assert report["finished"] and report["reason"] == "plan ended"
    assert all(outcome == "done" for _, _, outcome in report["outcomes"])
    # Execution time is simulated time: the drive and two pickups, the arm moving while
    # the base drives; the plan predicted it (tests/planning/test_time_model.py holds the
    # model to the simulation).
    assert 10.0 < report["execution_time"] < 120.0
    plan = TaskMotionPlan.read(out / "plan.json")
    assert plan.predicted_time == pytest.approx(report["execution_time"], rel=0.1)
    assert report["planning_time"] > 0 and report["realtime_rate"] > 1.0
    plan = TaskMotionPlan.read(out / "plan.json")
    assert plan.method == "S3O-GROP*" and {a.dish for a in plan.pickups} == {"plate_a", "cup_b"}
    # The report follows the plan's actions one by one.
    assert [(a, b) for a, b, _ in report["outcomes"]] == [
        ("goto", x.location) if hasattr(x, "path") else ("pickup", x.dish)
        for x in plan.actions]
    # A record per executed pickup: the plan's Fea^m from the planned stop, the stop
    # where the base really stood (without noise: the planned one, within the navigator's
    # goal tolerance, facing the dish), the outcome; no reach noise was drawn.
    records = [PickupRecord.from_dict(r) for r in report["pickups"]]
    assert [(r.dish, r.predicted) for r in records] == [(a.dish, a.feasibility)
                                                        for a in plan.pickups]
    stop = plan.gotos[0].pose
    dishes = {d.name: d for d in load_scenario(SMALL).dishes}
    for r in records:
        assert r.succeeded and r.reach_noise is None and r.method == "S3O-GROP*"
        assert r.source == "fcn" and r.kind == dishes[r.dish].kind
        assert r.planned_pose == pytest.approx(stop)
        assert r.actual_pose[:2] == pytest.approx(stop[:2], abs=0.03)
        assert abs(wrap(r.actual_pose[2] - facing_yaw(r.actual_pose[:2],
                                                      dishes[r.dish].position))) < 0.05
    # The summary puts each pickup's prediction beside its outcome.
    for r in records:
        assert f"pickup {r.dish}: done (predicted Fea^m {r.predicted:.2f})" in printed


def test_outputs_are_written_and_open(exact_run):
    _, out, _ = exact_run
    html = (out / "playback.html").read_text()
    assert "<html" in html[:200] and "MeshCat.Viewer" in html
    assert not re.search(r"<script[^>]+src=[\"']https?:", html)  # self-contained
    # The recording holds the scene and the dishes by name, inside the Meshcat commands
    # that the page embeds as base64 data.
    commands = b"".join(base64.b64decode(data) for data in re.findall(
        r'fetch\("data:application/octet-binary;base64,([A-Za-z0-9+/=]+)"\)', html))
    for name in ("table", "chair", "plate_a", "cup_b", "base_link", "gripper_base",
                 "animation"):
        assert name.encode() in commands, name
    for name in ("overhead.png", "feasibility.png", "state_space.png", "plan.png",
                 "search.png"):
        picture = cv2.imread(str(out / name))
        assert picture is not None and picture.shape[0] > 300, name
        assert picture.std() > 10, name  # a picture, not a blank


@pytest.mark.skipif(shutil.which("chromium") is None, reason="needs Chromium (.ci/run installs it)")
def test_playback_renders_in_headless_chromium(exact_run, tmp_path):
    _, out, _ = exact_run
    shot = tmp_path / "shot.png"
    subprocess.run(["chromium", "--headless", "--no-sandbox",
                    "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
                    "--window-size=1000,700",
                    "--virtual-time-budget=8000", f"--screenshot={shot}",
                    (out / "playback.html").as_uri()],
                   check=True, capture_output=True, timeout=120)
    image = cv2.imread(str(shot))
    assert image is not None and image.shape[:2] == (700, 1000)
    # The scene, not an empty page: many colours (floor, tables, chairs, robot, dishes).
    colours = {tuple(c) for c in (image[::4, ::4] // 32).reshape(-1, 3)}
    assert len(colours) > 12 and image.std() > 15


def outputs_off(*fields: str) -> list[str]:
    """The options that turn off the run's outputs `fields` (outputs.playback ...)."""
    return [item for field in fields for item in ("--set", f"outputs.{field}=false")]


NO_PICTURES = outputs_off("playback", "overhead", "feasibility", "state_space")
"""For a run whose test is not about its pictures (about a second each)."""


def test_set_replaces_a_field_and_large_reaching_noise_fails_some_pickups(tmp_path):
    """--set uncertainty.reach_std=0.08 (the scenario says 0.01): the run reaches with that
    noise, its report names what was replaced, and some pickups fail, without a crash.
    Open loop (a second --set): with the scenario's recovery every miss is tried again and
    replanned, five times the simulated time, which tests/execution/test_recovery.py covers."""
    assert load_scenario(SMALL).uncertainty.reach_std == 0.01
    out = tmp_path / "run"
    assert run_main([str(SMALL), "--out", str(out), "--seed", "3",
                     "--set", "uncertainty.reach_std=0.08", "--set", "execution.recovery=none",
                     *NO_PICTURES]) == 1
    report = json.loads((out / "report.json").read_text())
    assert report["overrides"][:2] == ["uncertainty.reach_std=0.08", "execution.recovery=none"]
    assert report["recoveries"] == []
    failed = [o for a, _, o in report["outcomes"] if a == "pickup" and o != "done"]
    assert failed and all(o.startswith("failed: ") for o in failed)
    # The records say the same, with the reach error drawn for each pickup.
    records = [PickupRecord.from_dict(r) for r in report["pickups"]]
    assert [f"failed: {r.outcome}" for r in records if not r.succeeded] == failed
    assert all(r.reach_noise is not None for r in records if not r.outcome.startswith("turn"))
    assert report["collected"] < report["dishes"] and report["finished"]


# --method reaches the planner as the scenario's method does (exact_run's S3O-GROP*): one
# other method, V-PETLON, whose plan was made on no state space. The S3O methods' plans
# are tests/planning/test_methods.py's.
@pytest.mark.parametrize("method", ["V-PETLON"])
def test_run_plans_with_the_method_and_seed_given(tmp_path, capsys, method):
    out = tmp_path / "run"
    assert run_main([str(SMALL), "--out", str(out), "--method", method, "--seed", "4",
                     "--no-noise", *NO_PICTURES]) in (0, 1)
    plan = TaskMotionPlan.read(out / "plan.json")
    assert plan.method == method and plan.seed == 4
    printed = capsys.readouterr().out
    assert f"{method} plan (seed 4)" in printed and "Collected" in printed
    report = json.loads((out / "report.json").read_text())
    assert (f"Execution time: predicted {plan.predicted_time:.1f} s, simulated "
            f"{report['execution_time']:.1f} s") in printed


def test_help_explains_every_option():
    result = subprocess.run([sys.executable, "-m", "s3o_drake.run", "--help"],
                            capture_output=True, text=True, check=True, cwd=REPO)
    for option in ("--out", "--meshcat", "--method", "--seed", "--no-noise", "--feasibility",
                   "S3O-GROP*", "V-PETLON", "report.json", "playback.html", "plan.json",
                   "Exit status", "docs/commands.md"):
        assert option in result.stdout
    # Every output, one by one, where the help points: its --help fits a screen.
    docs = (REPO / "docs" / "commands.md").read_text()
    section = docs.split("\n## s3o run\n", 1)[1].split("\n## ", 1)[0]
    for output in ("report.json", "plan.json", "playback.html", "overhead.png",
                   "feasibility.png", "state_space.png", "plan.png", "search.png",
                   "Exit status"):
        assert output in section


@pytest.mark.parametrize("argv, field", [
    (["--fast"], "--fast"),
    (["--method", "S3O-GROP**"], "--method"),
    (["--seed", "-1"], "--seed"),
    (["--seed", "one"], "--seed"),
    (["--set", "planner.top_kk=3"], "planner.top_kk"),
    (["--set", "uncertainty.nav_xy_std=-1"], "uncertainty.nav_xy_std"),
    (["--set", "planner"], "--set"),
])
def test_bad_option_is_one_line_and_status_2(tmp_path, monkeypatch, capsys, argv, field):
    monkeypatch.chdir(tmp_path)  # where the run writes by default: out/
    assert field in refused(run_main, [str(SMALL), *argv], capsys)
    assert not (tmp_path / "out").exists()


def test_a_bad_field_is_one_line_and_status_2_from_the_shell(tmp_path):
    """As a user starts the command: a field found bad once Drake and the scenario's
    modules have loaded is still the one line on stderr (and an argument that the parser
    refuses, before them: tests/commands/test_command_startup.py)."""
    result = subprocess.run([sys.executable, "-m", "s3o_drake.run", str(SMALL), "--set",
                             "uncertainty.nav_xy_std=-1"],
                            capture_output=True, text=True, cwd=tmp_path)
    assert result.returncode == 2
    assert result.stderr.count("\n") == 1 and "uncertainty.nav_xy_std" in result.stderr
    assert not (tmp_path / "out").exists()


def _report(**changes) -> dict:
    """A report.json's data as the run writes it, for the summary's words."""
    report = {"dishes": 2, "collected": 2, "collected_dishes": ["cup_b", "plate_a"],
              "execution_time": 40.0, "finished": True, "reason": "plan ended",
              "outcomes": [["goto", "l0", "done"], ["pickup", "plate_a", "done"],
                           ["pickup", "cup_b", "done"]],
              "pickups": [], "recoveries": [], "unreachable": [], "planning_time": 3.861,
              "wall_time": 4.0, "realtime_rate": 10.0, "simulated_time": 41.0}
    return {**report, **changes}


def test_the_summary_says_complete_only_when_every_dish_was_collected():
    from s3o_drake.commands.run_scenario import describe_execution

    assert describe_execution(_report()).endswith("plan ended: every dish collected.")
    missed = _report(collected=1, collected_dishes=["plate_a"], outcomes=[
        ["goto", "l0", "done"], ["pickup", "plate_a", "done"], ["pickup", "cup_b",
                                                                 "failed: no_ik"]])
    text = describe_execution(missed)
    assert text.endswith("plan ended: 1 pickup failed (cup_b).") and "complete" not in text
    # A failed attempt that a retry made good is no failure of the run.
    retried = _report(outcomes=[["goto", "l0", "done"], ["pickup", "cup_b", "failed: no_ik"],
                                ["pickup", "cup_b", "done"], ["pickup", "plate_a", "done"]])
    assert describe_execution(retried).endswith("plan ended: every dish collected.")
    lost = _report(collected=1, collected_dishes=["plate_a"], unreachable=["cup_b"])
    assert describe_execution(lost).endswith("plan ended: 1 dish unreachable (cup_b).")
    blocked = _report(reason="goto l0 failed: blocked", collected=0, collected_dishes=[])
    assert describe_execution(blocked).endswith("; goto l0 failed: blocked.")


def test_the_terminal_reports_one_planning_time(exact_run):
    """The plan's "planned in" and the summary's "planning took" are one figure when the
    run planned once (the planner sums the plans' own planning times)."""
    _, out, printed = exact_run
    report = json.loads((out / "report.json").read_text())
    assert not any(r["kind"] == "replan" for r in report["recoveries"])
    plan = TaskMotionPlan.read(out / "plan.json")
    assert report["planning_time"] == pytest.approx(plan.planning_time, abs=1e-9)
    figures = set(re.findall(r"(?:planned in|planning took) ([0-9.]+) s", printed))
    assert figures == {f"{plan.planning_time:.2f}"}


def test_the_terminal_numbers_stops_and_names_locations_as_plan_json(exact_run):
    _, out, printed = exact_run
    plan = TaskMotionPlan.read(out / "plan.json")
    for k, goto in enumerate(plan.gotos, 1):
        assert f"goto {goto.location:<4} (stop {k}) to" in printed


def test_the_outputs_show_the_latest_plan():
    """After a replan the outputs show the plan of what remained (and the state space it
    searched); when the replan found none, the plan before it."""
    import types

    from s3o_drake.commands.run_scenario import latest_plan

    first, replanned = object(), object()
    run = types.SimpleNamespace(plan=first, result=types.SimpleNamespace(plan=replanned))
    assert latest_plan(run) is replanned
    run.result.plan = None
    assert latest_plan(run) is first
    run.result = None
    assert latest_plan(run) is first


def test_after_a_replan_the_outputs_show_the_latest_plan(tmp_path, monkeypatch, capsys):
    """blocked_aisle.yaml with perception that misses the chairs at first: the first drive
    is blocked and the replan goes round. plan.json, plan.png and the terminal show the
    replan; the predicted time compared with the simulated one is the first plan's."""
    from s3o_drake.execution import execute as execution

    scenario = load_scenario(REPO / "scenarios" / "small" / "blocked_aisle.yaml")
    chairs = [list(c.pose) for c in scenario.chairs]
    looks = []

    def perceive(color, depth, label):
        looks.append(1)
        return [] if len(looks) == 1 else chairs

    plain = execution.execute
    firsts = []

    def with_late_chairs(*args, **kwargs):
        # The test is about the outputs, not the maps' accuracy: each plan's Fea^m is the
        # oracle's coarse map (tests/conftest.py), as the recovery tests plan this scene.
        run = plain(*args, perceive=perceive, plan_from=ORACLE_MAPS_ONCE, **kwargs)
        firsts.append(run.plan)
        return run

    monkeypatch.setattr(execution, "execute", with_late_chairs)
    out = tmp_path / "run"
    assert run_main([str(REPO / "scenarios" / "small" / "blocked_aisle.yaml"), "--out",
                     str(out), "--no-noise", *NO_PICTURES]) == 0
    printed = capsys.readouterr().out
    report = json.loads((out / "report.json").read_text())
    assert [r["kind"] for r in report["recoveries"]] == ["replan"]
    # The scenario plans from the Drake oracle's Fea^m (planner.feasibility), not the network's.
    assert report["feasibility"] == "oracle"
    assert {p["source"] for p in report["pickups"]} == {"oracle"}
    plan, (first,) = TaskMotionPlan.read(out / "plan.json"), firsts
    # The replan starts where the blocked drive stopped, not at the scenario's start.
    assert plan.gotos[0].path[0] != pytest.approx(first.gotos[0].path[0])
    assert "The latest of 2 plans" in printed and "planning took" in printed \
        and "in all (2 plans)" in printed
    assert f"predicted {first.predicted_time:.1f} s by the first of 2 plans" in printed
    assert f"goto {plan.gotos[0].location:<4} (stop 1) to ({plan.gotos[0].pose[0]:5.2f}" \
        in printed


@pytest.fixture(scope="module")
def tidy_run(tmp_path_factory):
    """scenarios/tidy_home.yaml run as the README shows, with the simulated noise (and the
    playback, but not the pictures that no test here reads)."""
    out = tmp_path_factory.mktemp("tidy") / "run"
    printed, said = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(printed), contextlib.redirect_stderr(said):
        status = run_main([str(REPO / "scenarios" / "tidy_home.yaml"), "--out", str(out),
                           *outputs_off("overhead", "feasibility", "state_space")])
    return status, out, printed.getvalue() + said.getvalue()


def test_tidy_home_picks_at_one_stop_and_puts_the_apple_down_at_another(tidy_run):
    status, out, printed = tidy_run
    assert status == 0, printed
    plan = TaskMotionPlan.from_json((out / "plan.json").read_text())
    stop, stops = 0, {}
    for action in plan.actions:
        stop += type(action).__name__ == "Goto"
        stops.setdefault(type(action).__name__, []).append((stop, getattr(action, "dish", "")))
    picked = next(k for k, dish in stops["Pickup"] if dish == "apple")
    (put,) = stops["Place"]
    assert put[1] == "apple" and put[0] > picked
    # Another object is picked where the apple is: one stop holds picks of two kinds.
    assert [d for k, d in stops["Pickup"] if k == picked] == ["can_2", "apple"]
    report = json.loads((out / "report.json").read_text())
    assert (report["dishes"], report["collected"], report["placed"]) == (4, 3, 1)
    (placement,) = report["placements"]
    plate = load_scenario(REPO / "scenarios" / "tidy_home.yaml").dishes[3]
    assert plate.name == "plate" and placement["target"][:2] == plate.position
    assert placement["placed"] and placement["error"] <= 0.03 and placement["upright"]
    assert "apple stands at its place" in printed and \
        "plan ended: every object collected or placed" in printed
    # Four objects to act on: the plate stays, and the apple's place is not an object.
    assert "(4 objects to plan for)" in printed


def test_the_playback_ends_with_the_apple_on_the_plate(tidy_run):
    """The playback's recording (Meshcat's animation in playback.html, msgpack-encoded)
    ends with the apple standing on the plate's top, where the report says it stands."""
    msgpack = pytest.importorskip("msgpack")
    _, out, _ = tidy_run
    html = (out / "playback.html").read_text()
    messages = [msgpack.unpackb(base64.b64decode(data), strict_map_key=False)
                for data in re.findall(
                    r'fetch\("data:application/octet-binary;base64,([A-Za-z0-9+/=]+)"\)', html)]
    (animation,) = [m for m in messages if m.get("type") == "set_animation"]
    (apple,) = [a for a in animation["animations"] if a["path"].endswith("/apple")]
    track = next(t for t in apple["clip"]["tracks"] if t["name"] == ".position")
    first, last = track["keys"][0]["value"], track["keys"][-1]["value"]
    np.testing.assert_allclose(first, [1.75, 4.0, 0.75], atol=1e-6)  # on the coffee table
    plate_top = 0.75 + DISH_SHAPES["plate"].height
    assert math.hypot(last[0] - 4.95, last[1] - 3.75) <= 0.03 and last[2] == \
        pytest.approx(plate_top)
    report = json.loads((out / "report.json").read_text())
    np.testing.assert_allclose(last, report["placements"][0]["final"], atol=1e-9)
