"""Results as append-only JSON lines: written as each job finishes, read back on resume.

Each finished job is one line, flushed and fsynced before the next is written, so a run
that is killed loses at most the line it was writing. That cut-short line is cut off when
the store is opened again (its job then runs again); every complete line is kept. A write
that fails (a full disk) takes back what it wrote of its line before it raises.
"""

import contextlib
import json
import os
from pathlib import Path


class ResultStore:
    """The rows of `path` (JSON lines), by job key; the last row of a key wins."""

    def __init__(self, path: Path, *, read_only: bool = False) -> None:
        """`read_only`: never touch the file (another process may be appending to it); a
        cut-short last line is then only skipped."""
        self.path = Path(path)
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
            if isinstance(row, dict) and "key" in row:
                self._rows[row["key"]] = row

    def rows(self) -> list[dict]:
        return list(self._rows.values())

    def finished(self, key: str) -> bool:
        """A job is finished when it has a row without an error (errors run again)."""
        row = self._rows.get(key)
        return row is not None and "error" not in row

    def get(self, key: str) -> dict | None:
        return self._rows.get(key)

    def append(self, row: dict) -> None:
        """Adds the row as one line, on disk when this returns. A write that fails (the
        disk full: OSError ENOSPC) leaves no part of the line behind, so that the next
        row does not run into it and make both unreadable; the error is raised."""
        if self.read_only:
            raise PermissionError(f"{self.path} was opened read-only")
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
