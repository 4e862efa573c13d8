"""The `s3o` console script: one command whose --help lists every subcommand without
importing them, dispatch to a subcommand's module, unknown commands refused in one line,
and the shared options meaning one thing in every command."""

import ast
import json
import os
import re
import subprocess
import sys
import types
from pathlib import Path

import pytest

from s3o_drake.commands import cli

REPO = Path(__file__).resolve().parents[2]
HEAVY = {"pydrake", "torch", "matplotlib", "shapely", "scipy", "clingo", "cv2"}


def _s3o(*args: str, importtime: bool = False) -> subprocess.CompletedProcess:
    """`s3o ARGS` as the installed script runs it (python -m s3o_drake.commands: the same
    main, without needing a reinstall)."""
    env = dict(os.environ, COLUMNS="100",
               PYTHONPATH=str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    flags = ["-X", "importtime"] if importtime else []
    return subprocess.run([sys.executable, *flags, "-m", "s3o_drake.commands", *args],
                          capture_output=True, text=True, env=env, cwd=REPO, timeout=120)


def _imported(importtime_log: str) -> set[str]:
    """Modules named in `python -X importtime`'s log."""
    return {line.rsplit("|", 1)[1].strip() for line in importtime_log.splitlines()
            if line.startswith("import time:") and "|" in line}


def test_the_console_script_is_s3o():
    pyproject = (REPO / "pyproject.toml").read_text()
    scripts = pyproject.split("[project.scripts]\n", 1)[1].split("\n\n", 1)[0]
    assert re.findall(r'^(\S+) = "(.+)"$', scripts, re.MULTILINE) == [
        ("s3o", "s3o_drake.commands.cli:main")]


def test_help_lists_every_command_and_imports_no_command_module():
    """Measured with `time`: 0.07 to 0.13 s on the project's 2-core machine with a study
    running beside it (Python alone takes 0.04 s). Not timed here, which is flaky on shared
    machines: what keeps it fast is that no command module is imported (some load Drake
    or torch at work), nor anything heavy."""
    result = _s3o("--help", importtime=True)
    assert result.returncode == 0, result.stderr[-2000:]
    lines = result.stdout.splitlines()
    for command in cli.COMMANDS:
        word = command.name.split()[-1]
        assert any(line.split()[:1] == [word] and command.summary in line for line in lines), \
            command.name
    assert max(map(len, lines)) <= 100
    imported = _imported(result.stderr)
    assert not {name.split(".")[0] for name in imported} & HEAVY
    commands = {name for name in imported if name.startswith("s3o_drake.commands.")}
    assert commands <= {"s3o_drake.commands.cli", "s3o_drake.commands.common",
                        "s3o_drake.commands.__main__"}


def test_each_summary_is_its_module_docstrings_first_line():
    """The table names each module's purpose without importing it; the two stay one."""
    for command in cli.COMMANDS:
        path = REPO / (command.module.replace(".", "/") + ".py")
        doc = ast.get_docstring(ast.parse(path.read_text()))
        assert doc.splitlines()[0] == command.summary, command.name


def test_every_command_help_fits_a_screen_and_names_its_s3o_form():
    """At most 40 lines of at most 100 columns; the long explanations are in
    docs/commands.md, a section per command."""
    script = (
        "import contextlib, io, importlib, json\n"
        "from s3o_drake.commands.cli import COMMANDS\n"
        "helps = {}\n"
        "for c in COMMANDS:\n"
        "    out = io.StringIO()\n"
        "    with contextlib.redirect_stdout(out), contextlib.suppress(SystemExit):\n"
        "        importlib.import_module(c.module).main(['--help'])\n"
        "    helps[c.name] = out.getvalue()\n"
        "print(json.dumps(helps))\n")
    env = dict(os.environ, COLUMNS="100", PYTHONPATH=str(REPO))
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                            env=env, cwd=REPO, timeout=300)
    assert result.returncode == 0, result.stderr[-2000:]
    docs = (REPO / "docs" / "commands.md").read_text()
    for name, text in json.loads(result.stdout).items():
        lines = text.splitlines()
        assert lines[0].startswith(f"usage: s3o {name} "), name
        assert len(lines) <= 40 and max(map(len, lines)) <= 100, (name, len(lines))
        assert f"\n## s3o {name}\n" in docs and f'section "s3o {name}"' in text


def test_a_subcommand_runs_its_module_with_the_arguments_after_its_name(
        tmp_path, monkeypatch, capsys):
    from s3o_drake.feasibility.reachability import build as reachability_build

    fake = types.SimpleNamespace(to_bytes=lambda: b"map",
                                 settings={"nodes": 1, "configurations": 1, "build_seconds": 0})
    monkeypatch.setattr(reachability_build, "build_map", lambda **kwargs: fake)
    out = tmp_path / "map.npz"
    assert cli.main(["build", "reachability", "--out", str(out), "--quiet"]) == 0
    assert out.read_bytes() == b"map"
    assert f"wrote {out}" in capsys.readouterr().out
    with pytest.raises(SystemExit) as info:
        cli.main(["bench", "planning", "--help"])
    assert info.value.code == 0
    assert capsys.readouterr().out.startswith("usage: s3o bench planning ")


def test_a_group_lists_its_commands():
    result = _s3o("bench", "--help")
    assert result.returncode == 0
    assert all(f"  {c.name.split()[1]} " in result.stdout
               for c in cli.COMMANDS if c.name.startswith("bench "))


@pytest.mark.parametrize(("argv", "says"), [
    ([], "a command is required"),
    (["nope"], "unknown command 'nope' (choose from run, generate,"),
    (["bench", "nope"], "unknown command 'nope' (choose from planning,"),
    (["bench"], "a NAME is required"),
    (["calibration"], "it is now `s3o calibrate`"),  # a module's name: its command's
    (["planning_benchmark"], "it is now `s3o bench planning`"),
])
def test_an_unknown_command_is_one_line_and_status_2(argv, says):
    result = _s3o(*argv)
    assert result.returncode == 2 and result.stdout == ""
    assert result.stderr.count("\n") == 1 and says in result.stderr, result.stderr


TASK_COMMANDS = (["bench", "planning"], ["bench", "time"], ["evaluate", "--out", "x"])
SEED_COMMANDS = (["bench", "planning"], ["bench", "compare-feasibility"], ["generate"])


@pytest.mark.parametrize(("commands", "argv", "message"), [
    (TASK_COMMANDS, ["--count", "0"], "argument --count: must be at least 1, got 0"),
    (TASK_COMMANDS, ["--tasks", "nowhere"], "--tasks: no such folder or file nowhere"),
    (TASK_COMMANDS, ["--tasks", "10"],
     "--tasks: no such folder or file 10 (the first 10 tasks: --count 10)"),
    (SEED_COMMANDS, ["--seed", "-1"], "argument --seed: must be at least 0, got -1"),
])
def test_a_shared_option_means_the_same_in_every_command(commands, argv, message, tmp_path):
    """The task selection and the seed are parsed by one function: the same value is
    refused with the same words by the benchmarks, the study and the generator."""
    for command in commands:
        result = subprocess.run(
            [sys.executable, "-m", "s3o_drake.commands", *command, *argv],
            capture_output=True, text=True, cwd=tmp_path, timeout=120,
            env=dict(os.environ, PYTHONPATH=str(REPO)))
        assert result.returncode == 2 and result.stderr.count("\n") == 1, result.stderr
        said = result.stderr.split("error: ", 1)[1].rstrip("\n").removesuffix(" (see --help)")
        assert said == message, (command, said)
        assert not any(tmp_path.iterdir())  # nothing written


def test_tasks_and_count_choose_the_same_files_in_every_command(tmp_path):
    """--tasks takes files and folders (every *.yaml, by name), --count the first N of them:
    the same list whichever command parses them."""
    from s3o_drake.commands.common import command_parser
    from s3o_drake.commands.options import add_tasks, task_paths

    folder = tmp_path / "tasks"
    folder.mkdir()
    for name in ("b", "a", "c"):
        (folder / f"{name}.yaml").write_text("")
    extra = tmp_path / "z.yaml"
    extra.write_text("")
    chosen = []
    for count in (None, 10):  # the command's own default count does not apply to --count
        parser = command_parser("bench x", None)
        add_tasks(parser, count=count)
        args = parser.parse_args(["--tasks", str(folder), str(extra), "--count", "3"])
        chosen.append([p.name for p in task_paths(args)])
    assert chosen == [["a.yaml", "b.yaml", "c.yaml"]] * 2
