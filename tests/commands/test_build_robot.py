"""`s3o build robot NAME`: every step once, in order, each recorded with the checksums of
what it read and wrote; run again it resumes, and a changed description re-runs the steps
that read it and no others."""

import json
import shutil

import pytest

from s3o_drake.commands import build_robot
from s3o_drake.world import resources
from s3o_drake.world.resources import robot_dir


@pytest.fixture
def robot_folder(tmp_path, monkeypatch):
    folder = tmp_path / "ur5e"
    folder.mkdir()
    for name in ("robot.yaml", "mobile_manipulator.urdf"):
        shutil.copy(robot_dir("ur5e") / name, folder / name)
    monkeypatch.setattr(build_robot, "robot_dir", lambda name: tmp_path / name)
    monkeypatch.setattr(build_robot, "REPO_DIR", tmp_path)
    # The record names paths from the repository's root (`resources.repo_path`).
    monkeypatch.setattr(resources, "REPO_DIR", tmp_path)
    return folder


@pytest.fixture
def ran(monkeypatch):
    """The steps run, by name; each writes its outputs (the same bytes every time)."""
    names = []

    def run_step(step, *, so_far, checkpoint):
        names.append(step.name)
        for path in step.writes:
            if path.suffix:
                path.parent.mkdir(parents=True, exist_ok=True)
                path.write_text(step.name)
            else:
                path.mkdir(parents=True, exist_ok=True)
                (path / "part.npz").write_text(step.name)
        return build_robot.StepTime(so_far.seconds + 1.0, so_far.cpu_seconds + 2.0,
                                    so_far.runs + 1)

    monkeypatch.setattr(build_robot, "run_step", run_step)
    return names


def test_every_step_runs_once_in_order_and_is_recorded(robot_folder, ran, capsys):
    assert build_robot.main(["ur5e"]) == 0
    assert ran == ["reachability", "fcn-data", "fcn-data-dense", "fcn", "time-model",
                   "oracle-pinning"]
    manifest = json.loads((robot_folder / build_robot.MANIFEST).read_text())
    assert list(manifest["steps"]) == ran
    reach = manifest["steps"]["reachability"]
    assert reach["command"].startswith(
        "s3o build reachability --robot ur5e --out ur5e/reachability_map.npz")
    # Each step is told the robot it builds for, but the network's (it reads only data).
    assert all("--robot ur5e" in step["command"]
               for name, step in manifest["steps"].items() if name != "fcn")
    assert set(reach["reads"]) == {"ur5e/robot.yaml", "ur5e/mobile_manipulator.urdf"}
    assert all(len(v) == 64 for v in reach["writes"].values())

    # Run again: nothing to do.
    ran.clear()
    assert build_robot.main(["ur5e"]) == 0
    assert ran == []
    assert capsys.readouterr().out.count(": done, as recorded in") == 6

    # A comment, or what the description says the robot still lacks, is not what a step
    # reads: nothing runs again.
    with (robot_folder / "robot.yaml").open("a") as f:
        f.write("# changed\nmissing: its network\n")
    assert build_robot.main(["ur5e"]) == 0
    assert ran == []
    # A changed description runs again what reads it; the network reads only its data.
    description = robot_folder / "robot.yaml"
    description.write_text(description.read_text().replace("\nreach: 1.0\n", "\nreach: 0.85\n"))
    assert build_robot.main(["ur5e"]) == 0
    assert ran == ["reachability", "fcn-data", "fcn-data-dense", "time-model",
                   "oracle-pinning"]


def test_a_missing_output_runs_its_step_again_and_steps_can_be_chosen(robot_folder, ran):
    assert build_robot.main(["ur5e", "--steps", "reachability", "time-model"]) == 0
    assert ran == ["reachability", "time-model"]
    (robot_folder / "time_model.yaml").unlink()
    ran.clear()
    assert build_robot.main(["ur5e", "--steps", "time-model"]) == 0
    assert ran == ["time-model"]


def test_an_unknown_robot_is_one_line_and_status_2(robot_folder, ran, capsys):
    with pytest.raises(SystemExit) as info:
        build_robot.main(["r2d2"])
    assert info.value.code == 2
    assert ran == [] and capsys.readouterr().err.count("\n") == 1


def test_a_second_build_of_the_same_robot_is_refused_in_one_line(robot_folder, ran, capsys):
    with build_robot.only_build("ur5e"), pytest.raises(SystemExit) as info:
        build_robot.main(["ur5e"])
    assert info.value.code == 2
    assert ran == [] and "another build of this robot is running" in capsys.readouterr().err
    # Once the first ends, the build runs.
    assert build_robot.main(["ur5e"]) == 0 and ran


def test_a_build_resumed_on_other_workers_keeps_its_finished_steps(robot_folder, ran,
                                                                     monkeypatch):
    # The workers say how fast a step runs, not what it makes: a build resumed on one
    # worker must not make the map again that two made.
    assert build_robot.main(["ur5e", "--steps", "reachability", "--workers", "2"]) == 0
    assert ran == ["reachability"]
    ran.clear()
    assert build_robot.main(["ur5e", "--steps", "reachability", "--workers", "1"]) == 0
    assert ran == []
    # Anything else in its command still makes it again.
    plan_steps = build_robot.plan_steps
    monkeypatch.setattr(build_robot, "plan_steps", lambda name, *, workers: [
        build_robot.Step(s.name, (*s.argv, "--resolution", "0.05"), s.reads, s.writes)
        for s in plan_steps(name, workers=workers)])
    assert build_robot.main(["ur5e", "--steps", "reachability"]) == 0
    assert ran == ["reachability"]


def test_a_step_cut_off_counts_its_time_on_when_the_build_runs_again(robot_folder, ran,
                                                                     monkeypatch, tmp_path):
    # The data step is cut off (the machine shut down) after its first checkpoint: its
    # time so far is on disk, and the build run again adds it to the step's record.
    finished = build_robot.run_step

    def cut_off(step, *, so_far, checkpoint):
        if step.name != "fcn-data":
            return finished(step, so_far=so_far, checkpoint=checkpoint)
        checkpoint(build_robot.StepTime(so_far.seconds + 600.0, so_far.cpu_seconds + 1100.0,
                                        so_far.runs + 1))
        raise KeyboardInterrupt

    monkeypatch.setattr(build_robot, "run_step", cut_off)
    with pytest.raises(KeyboardInterrupt):
        build_robot.main(["ur5e"])
    monkeypatch.setattr(build_robot, "run_step", finished)
    assert build_robot.main(["ur5e"]) == 0
    steps = json.loads((robot_folder / build_robot.MANIFEST).read_text())["steps"]
    assert (steps["fcn-data"]["seconds"], steps["fcn-data"]["cpu_seconds"],
            steps["fcn-data"]["runs"]) == (601.0, 1102.0, 2)
    assert (steps["reachability"]["seconds"], steps["reachability"]["runs"]) == (1.0, 1)
    # Once a step is recorded, its time so far is gone.
    assert json.loads((tmp_path / "out" / "ur5e" / build_robot.TIME_SO_FAR).read_text()) == {}


def test_a_step_s_process_is_timed_with_the_cpu_of_what_it_starts(tmp_path, monkeypatch):
    monkeypatch.setattr(build_robot, "CHECKPOINT", 0.05)
    seen = []
    step = build_robot.Step("help", ("build", "robot", "--help"), (), ())
    spent = build_robot.run_step(step, so_far=build_robot.StepTime(10.0, 20.0, 1),
                                 checkpoint=seen.append)
    assert spent.runs == 2 and spent.seconds > 10.0 and spent.cpu_seconds > 20.0
    # While it ran, its time so far was handed on, never more than at its end.
    assert seen and all(t.runs == 2 and t.seconds <= spent.seconds for t in seen)
