"""The oracle's maps kept on disk, between processes and runs (opt-in).

A Fea^m map from the Drake oracle costs seconds per dish, and it is a pure function of what
it is made of: the plant's contents, the obstacles' footprints, the noise model, the
checker's settings and reachability map, the grid, and the code and model files that
compute it. With the environment variable `S3O_CACHE` naming a folder,
`FeasibilityOracle.expectation` keeps each map there under a digest of all of these, and
any process that asks for the same map again reads it: a study's difficulty and a check of
the same tasks, a benchmark run again, the planners of `s3o bench limit` on one task, the
test processes. Unset (the default), nothing is kept.

The digest covers every source file of the package and the furniture's and the map's
robot's model files (`code_digest(robot)`), so a map made by other code is never read:
editing the oracle, the kinematics or the robot's URDF starts an empty cache in effect.
Files are written whole or not at all; a folder may be shared by processes running at once
(a map that several ask for at once is computed by one of them while the others wait), and
deleted at any time.
"""

from __future__ import annotations

import contextlib
import fcntl
import functools
import hashlib
import os
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path

import numpy as np

from s3o_drake.world.resources import MODELS_DIR
from s3o_drake.world.robot import Robot

CACHE_VARIABLE = "S3O_CACHE"
"""The environment variable that names the cache's folder."""

_PACKAGE_DIR = Path(__file__).resolve().parents[1]
_SOURCE_SUFFIXES = (".py", ".lp", ".yaml")


@contextlib.contextmanager
def bypassed() -> Iterator[None]:
    """Within, every map is computed and none is read or kept (the processes started
    within too): for a benchmark that times the oracle."""
    saved = os.environ.pop(CACHE_VARIABLE, None)
    try:
        yield
    finally:
        if saved is not None:
            os.environ[CACHE_VARIABLE] = saved


def cache_folder() -> Path | None:
    """The folder `S3O_CACHE` names, or None when it is unset or empty."""
    folder = os.environ.get(CACHE_VARIABLE, "")
    return Path(folder) if folder else None


@functools.cache
def code_digest(robot: Robot) -> str:
    """SHA-256 over the package's source files, the furniture's model files and `robot`'s
    files (its description, model and reachability map, in its folder; not the network's
    weights in its subfolder), their paths and bytes: what computes a map besides its
    arguments. Once per robot and process."""
    files = [p for p in _PACKAGE_DIR.rglob("*") if p.suffix in _SOURCE_SUFFIXES]
    files += [*(MODELS_DIR / "furniture").rglob("*"), *robot.files.folder.glob("*")]
    digest = hashlib.sha256()
    for path in sorted(p for p in files if p.is_file()):
        digest.update(path.as_posix().encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


def key_digest(parts: Iterable[object], *, robot: Robot) -> str:
    """A digest of `parts` and the code (with `robot`'s files): arrays by dtype, shape and
    bytes, bytes as they are, anything else by its repr (dataclasses of numbers repr
    exactly)."""
    digest = hashlib.sha256(code_digest(robot).encode())
    for part in parts:
        if isinstance(part, np.ndarray):
            digest.update(f"{part.dtype.str}{part.shape}".encode())
            digest.update(np.ascontiguousarray(part).tobytes())
        elif isinstance(part, bytes):
            digest.update(part)
        else:
            digest.update(repr(part).encode())
        digest.update(b"\x1f")  # a separator: ("ab", "c") and ("a", "bc") differ
    return digest.hexdigest()


def cached_array(parts: Callable[[], Iterable[object]],
                 compute: Callable[[], np.ndarray], *, robot: Robot) -> np.ndarray:
    """`compute()` for `robot`, read from the cache folder when a process stored it under
    the same `parts()` (called only when a folder is set) and code and stored there
    otherwise."""
    folder = cache_folder()
    if folder is None:
        return compute()
    path = folder / f"{key_digest(parts(), robot=robot)}.npy"
    stored = _read(path)
    if stored is not None:
        return stored
    with _computing(path):
        # Another process may have stored it while this one waited for the lock.
        stored = _read(path)
        if stored is not None:
            return stored
        values = compute()
        try:
            temporary = path.with_name(f".{path.name}.{os.getpid()}.tmp")
            with open(temporary, "wb") as f:
                np.save(f, values, allow_pickle=False)
            temporary.replace(path)
        except OSError:  # a cache that cannot be written costs time, never a result
            pass
    return values


def _read(path: Path) -> np.ndarray | None:
    try:
        return np.load(path, allow_pickle=False)
    except (OSError, ValueError):  # absent, or cut short by a full disk: computed again
        return None


@contextlib.contextmanager
def _computing(path: Path) -> Iterator[None]:
    """Holds a lock on the map `path` while it is computed: processes that ask for the same
    map at once (a study's difficulty beside a check of the same tasks, two test processes)
    compute it once, the others wait and read it. A POSIX record lock: released when its
    process ends however it ends, and not inherited by the processes it forks (a search's
    workers outliving the computation would otherwise keep it). Without one (a folder that
    cannot be written, a file system without locks) each process computes its own."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        lock = open(path.with_name(f".{path.stem}.lock"), "a")  # noqa: SIM115
    except OSError:
        yield
        return
    with lock:
        with contextlib.suppress(OSError):
            fcntl.lockf(lock, fcntl.LOCK_EX)
        yield  # closing the file releases the lock
