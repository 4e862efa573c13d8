"""The commands answer --help and bad arguments before the heavy imports: the arguments are
parsed first, and Drake, torch, OpenCV, matplotlib, shapely, scipy and clingo are imported
only after."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from s3o_drake.commands import cli

REPO = Path(__file__).resolve().parents[2]
HEAVY = ("pydrake", "torch", "cv2", "matplotlib", "shapely", "scipy", "clingo")
# Every command, by the module that `python -m` runs (its first address; `s3o NAME` runs
# the same main): the card's, and each of the `s3o` command table.
COMMANDS = ["s3o_drake.run"] + [command.module for command in cli.COMMANDS]


def _python(*args: str) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return subprocess.run([sys.executable, *args], capture_output=True, text=True, env=env,
                          cwd=REPO, timeout=600)


STARTS = r"""
import json, os, runpy, sys, tempfile, traceback

# Not heavy, and most commands load it before parsing: loaded once here, not in each start.
import numpy

heavy, starts = set(json.loads(sys.argv[1])), json.loads(sys.argv[2])
assert not heavy & {name.split(".")[0] for name in sys.modules}, "the starter is heavy"


def run(module, argv):
    # As `python -m module argv` runs in a fresh interpreter: its exit status.
    sys.argv = [module, *argv]
    try:
        runpy.run_module(module, run_name="__main__", alter_sys=True)
    except SystemExit as e:
        if e.code is None or isinstance(e.code, int):
            return e.code or 0
        print(e.code, file=sys.stderr)
    except BaseException:
        traceback.print_exc()
    else:
        return 0
    return 1


results = []
for module, argv in starts:
    files = [tempfile.TemporaryFile() for _ in range(3)]  # stdout, stderr, the imports
    sys.stdout.flush()
    pid = os.fork()
    if pid == 0:
        status = 1
        try:
            os.dup2(files[0].fileno(), 1)
            os.dup2(files[1].fileno(), 2)
            status = run(module, argv)
            sys.stdout.flush()
            sys.stderr.flush()
            loaded = sorted(heavy & {name.split(".")[0] for name in sys.modules})
            os.write(files[2].fileno(), json.dumps(loaded).encode())
        finally:
            os._exit(status & 0xFF)
    _, wait = os.waitpid(pid, 0)
    out, err, loaded = [(f.seek(0), f.read().decode(errors="replace"), f.close())[1]
                        for f in files]
    results.append([os.waitstatus_to_exitcode(wait), out, err,
                    json.loads(loaded or '["(not reported)"]')])
print(json.dumps(results))
"""
"""Starts each command in a process forked from one interpreter that has loaded nothing
heavy: what `python -m MODULE ARGS` prints, its exit status and the heavy packages loaded
when it exits, without an interpreter's start-up for each."""


@pytest.fixture(scope="module")
def started() -> dict[tuple[str, str], tuple[int, str, str, list[str]]]:
    """Each command started with --help and with a bad argument: (exit status, stdout,
    stderr, the heavy packages it imported)."""
    starts = [(module, [arg]) for module in COMMANDS for arg in ("--help", "--no-such-option")]
    result = _python("-c", STARTS, json.dumps(HEAVY), json.dumps(starts))
    assert result.returncode == 0, result.stderr[-2000:]
    return {(module, argv[0]): tuple(answer) for (module, argv), answer in
            zip(starts, json.loads(result.stdout.splitlines()[-1]), strict=True)}


@pytest.mark.parametrize("module", COMMANDS)
def test_help_imports_nothing_heavy(started, module):
    status, out, err, heavy = started[module, "--help"]
    assert status == 0, err[-2000:]
    assert "usage:" in out
    assert not heavy, f"{module} --help imported {heavy} before parsing its arguments"


@pytest.mark.parametrize("module", COMMANDS)
def test_a_bad_argument_is_one_line_and_status_2_before_heavy_imports(started, module):
    status, _, err, heavy = started[module, "--no-such-option"]
    assert status == 2, err[-2000:]
    lines = err.splitlines()
    assert len(lines) == 1 and "error:" in lines[0]
    assert not heavy


def test_run_help_is_the_module_docstring(started):
    from s3o_drake.commands import run_scenario as run

    _, out, _, _ = started["s3o_drake.run", "--help"]
    assert run.__doc__.splitlines()[0] in out
