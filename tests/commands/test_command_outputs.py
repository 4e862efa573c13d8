"""The commands that make what ships in models/ write under out/ unless --out names the
shipped file."""

import types

import pytest

from s3o_drake.commands import build_reachability, derive_times, train
from s3o_drake.world.robot import load_robot


@pytest.mark.parametrize(("command", "argv", "default"), [
    (train, ["--data", "x"], "out/fcn"),
    (derive_times, [], "out/time_model.yaml"),
    (build_reachability, ["build"], "out/reachability_map.npz"),
])
def test_the_default_output_is_under_out(command, argv, default, capsys):
    with pytest.raises(SystemExit) as info:
        command.main([*argv, "--help"])
    assert info.value.code == 0
    text = " ".join(capsys.readouterr().out.split())
    assert f"(default {default};" in text and "--out models/" in text


def test_build_writes_under_out_and_leaves_the_shipped_map(tmp_path, monkeypatch, capsys):
    from s3o_drake.feasibility.reachability import build as reachability_build

    fake = types.SimpleNamespace(to_bytes=lambda: b"map",
                                 settings={"nodes": 1, "configurations": 1, "build_seconds": 0})
    monkeypatch.setattr(reachability_build, "build_map", lambda **kwargs: fake)
    monkeypatch.chdir(tmp_path)
    shipped_map = load_robot("ur5e").files.reachability_map
    shipped = shipped_map.stat().st_mtime_ns
    assert build_reachability.main(["build", "--quiet"]) == 0
    assert (tmp_path / "out" / "reachability_map.npz").read_bytes() == b"map"
    assert shipped_map.stat().st_mtime_ns == shipped


def test_a_bad_out_is_one_line_and_writes_nothing(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "file").write_text("")
    with pytest.raises(SystemExit) as info:
        build_reachability.main(["build", "--out", "file/map.npz"])
    assert info.value.code == 2
    assert capsys.readouterr().err.count("\n") == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file"]


def test_a_time_model_without_the_robots_network_is_refused_first(tmp_path, monkeypatch,
                                                                   capsys):
    """Its measured runs plan with the robot's network: a robot still being built is told
    which step makes it, in one line, before any pickup is planned and with nothing
    written."""
    from s3o_drake.world.robot import RobotFiles

    monkeypatch.setattr(RobotFiles, "fcn_weights", property(lambda files: tmp_path / "fcn.pt"))
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as info:
        derive_times.main(["--robot", "panda"])
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("error: --robot: 'panda' has no ")
    assert "s3o build robot panda --steps fcn-data fcn" in err
    assert sorted(tmp_path.iterdir()) == []
