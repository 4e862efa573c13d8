"""Results as append-only JSON lines: written as each job finishes, read back on resume.

Each finished job is one line, flushed and fsynced before the next is written, so a run
that is killed loses at most the line it was writing. That cut-short line is cut off when
the store is opened again (its job then runs again); every complete line is kept. A write
that fails (a full disk) takes back what it wrote of its line before it raises.

Every row written says its layout's version (`schema`), the code that made it (`code`), the
versions of the packages that compute with it (`packages`), the processor it ran on
(`machine`) and the robot it ran (`robot`): studies and benchmarks resume across commits and
machines, and a reader must be able to tell the rows apart. The same code with other
versions of numpy or Drake can differ in the last digits of a cost, and the motion search
can then choose another plan; so can the same code and packages on another processor, whose
vector instructions numpy and the linear algebra pick their kernels by (seen here: 1 of 40
runs collected a dish fewer). Rows written before the schema
was recorded have none and read as they are; rows without a robot are the UR5e's, the only
robot there was. A store opened to write is for one robot's rows (`ResultStore(robot=...)`).
"""

import contextlib
import functools
import importlib.metadata
import json
import os
import platform
import subprocess
from collections.abc import Callable, Mapping
from pathlib import Path

from s3o_drake.world.resources import DEFAULT_ROBOT, PACKAGE_NAME, REPO_DIR

SCHEMA = 1
"""The version of the rows' layout that `append` writes as each row's "schema". Rows
without it (written before it was recorded) are version 0: their fields are a subset of
version 1's, so they read alike."""


class OtherRobotRowsError(ValueError):
    """A store opened to write holds rows of a robot other than the one it is for."""


def robot_of(row: Mapping) -> str:
    """The robot a row ran (rows from before robots were recorded: the UR5e)."""
    return str(row.get("robot", DEFAULT_ROBOT))


def schema_of(row: Mapping) -> int:
    """The layout version a row was written with (0: before it was recorded)."""
    return int(row.get("schema", 0))


@functools.cache
def code_version() -> str:
    """The code a row was made with: the commit of the checkout the package runs from (12
    hex digits; "+changes" when its s3o_drake/ differs from it, untracked files included),
    else the package's version. Studies and soaks run for days and resume across commits;
    each row says which code made it. The one code version: every row the store writes
    carries it."""
    def git(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run(["git", "-C", str(REPO_DIR), *args], capture_output=True,
                              text=True, timeout=30, check=False)
    try:
        head = git("rev-parse", "--short=12", "HEAD")
        if head.returncode == 0:
            status = git("status", "--porcelain", "--", PACKAGE_NAME)
            changed = status.returncode != 0 or bool(status.stdout.strip())
            return head.stdout.strip() + ("+changes" if changed else "")
    except (OSError, subprocess.SubprocessError):
        pass
    try:
        return f"{PACKAGE_NAME} {importlib.metadata.version(PACKAGE_NAME)}"
    except importlib.metadata.PackageNotFoundError:  # run from a copy, neither git nor pip
        return f"{PACKAGE_NAME} (unknown version)"


COMPUTING_PACKAGES = ("drake", "numpy", "scipy", "torch", "cma", "shapely", "clingo", "ompl")
"""The installed packages whose arithmetic a run's figures depend on."""


@functools.cache
def packages_version() -> str:
    """The versions of COMPUTING_PACKAGES installed here ("drake 1.51.1, numpy 2.4.6, ...";
    "not installed" for one that is not): what `code_version` leaves out."""
    def version(name: str) -> str:
        try:
            return importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            return "not installed"
    return ", ".join(f"{name} {version(name)}" for name in COMPUTING_PACKAGES)


SIMD_FLAGS = ("sse4_2", "avx", "avx2", "fma", "avx512f", "avx512dq", "avx512bw", "avx512vl",
              "avx512_vnni", "avx512_bf16", "amx_tile", "asimd", "sve")
"""Processor features that decide which kernels numpy and BLAS run (x86-64 and Arm)."""


@functools.cache
def machine_version() -> str:
    """The processor this process runs on: its architecture, its model name and the vector
    instructions of SIMD_FLAGS it has ("x86_64, AMD EPYC, avx avx2 fma ..."), read from
    /proc/cpuinfo where there is one."""
    model, flags = platform.processor() or "unknown processor", set()
    with contextlib.suppress(OSError):
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            key, _, value = line.partition(":")
            key = key.strip()
            if key == "model name":
                model = value.strip()
            elif key in ("flags", "Features"):
                flags = set(value.split())
            if model != "unknown processor" and flags:
                break
    present = " ".join(f for f in SIMD_FLAGS if f in flags)
    return f"{platform.machine()}, {model}, {present or 'no listed vector flags'}"


class ResultStore:
    """The rows of `path` (JSON lines), by job key; the last row of a key wins."""

    def __init__(self, path: Path, *, robot: str = DEFAULT_ROBOT, read_only: bool = False,
                 key: Callable[[dict], str] | None = None) -> None:
        """`robot`: the robot whose runs the rows are (`append` stamps it); a store opened
        to write that holds another robot's rows is refused (OtherRobotRowsError): one
        folder, one robot. `read_only`: never touch the file (another process may be
        appending to it); a cut-short last line is then only skipped. `key`: the key of a
        row written without one (a benchmark's file from before it used the store); rows it
        cannot key (KeyError) are not read."""
        self.path = Path(path)
        self.robot = robot
        self.read_only = read_only
        self._rows: dict[str, dict] = {}
        if not self.path.exists():
            return
        data = self.path.read_bytes()
        end = data.rfind(b"\n") + 1
        if end < len(data) and not read_only:  # cut short by a crash: drop it, keep the rest
            with self.path.open("r+b") as f:
                f.truncate(end)
        for line in data[:end].splitlines():
            try:
                row = json.loads(line)
            except json.JSONDecodeError:
                continue
            if not isinstance(row, dict):
                continue
            if "key" not in row and key is not None:
                with contextlib.suppress(KeyError, TypeError):
                    row = {"key": key(row), **row}
            if "key" in row:
                self._rows[row["key"]] = row
        others = {robot_of(r) for r in self._rows.values()} - {robot}
        if others and not read_only:
            raise OtherRobotRowsError(
                f"{self.path}: holds runs of robot {', '.join(sorted(others))}, not of "
                f"{robot!r}: write to another folder")

    def rows(self) -> list[dict]:
        return list(self._rows.values())

    def finished(self, key: str) -> bool:
        """A job is finished when it has a row without an error (errors run again)."""
        row = self._rows.get(key)
        return row is not None and "error" not in row

    def get(self, key: str) -> dict | None:
        return self._rows.get(key)

    def append(self, row: dict) -> dict:
        """Adds the row as one line, on disk when this returns, stamped with the layout's
        version, the code, the packages' versions, the machine and the robot (a row that
        already names
        its own, copied from another store, keeps them); returns the row as written. A write
        that fails (the disk full: OSError ENOSPC) leaves no part of the line behind, so
        that the next row does not run into it and make both unreadable; the error is
        raised."""
        if self.read_only:
            raise PermissionError(f"{self.path} was opened read-only")
        row = {"schema": SCHEMA, "code": code_version(), "packages": packages_version(),
               "machine": machine_version(), "robot": self.robot, **row}
        data = (json.dumps(row, sort_keys=True) + "\n").encode()
        fd = os.open(self.path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o666)
        try:
            size = os.fstat(fd).st_size
            try:
                written = 0
                while written < len(data):  # os.write may write less than asked
                    written += os.write(fd, data[written:])
                os.fsync(fd)
            except OSError as e:
                with contextlib.suppress(OSError):  # truncating frees space; best effort
                    os.ftruncate(fd, size)
                raise OSError(e.errno, e.strerror, str(self.path)) from e  # names the file
        finally:
            os.close(fd)
        self._rows[row["key"]] = row
        return row
