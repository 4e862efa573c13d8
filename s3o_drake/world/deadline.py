"""A deadline on a clock: how a time budget reaches every stage that must keep it.

A budget in seconds becomes one `Deadline` when the work starts; each stage asks it whether
it has `passed` and how much time `remaining` it leaves, so one clock decides for all of
them. The clock is `time.monotonic` unless the caller gives another, so that a test can
drive a clock of its own and a budget cuts the same work on any machine. A clock must read
alike in every process that the work forks (the planner's search workers inherit the
deadline): one held in shared memory does; this process's CPU time (`time.process_time`)
only where the work stays in this process.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

Clock = Callable[[], float]
"""Seconds on some clock, increasing: `time.monotonic` or a stand-in."""


@dataclass(frozen=True)
class Deadline:
    """The moment `at`, in seconds on `clock`."""

    at: float
    clock: Clock = time.monotonic

    @classmethod
    def after(cls, seconds: float, clock: Clock = time.monotonic) -> Deadline:
        """The deadline `seconds` from now on `clock`."""
        return cls(clock() + seconds, clock)

    def now(self) -> float:
        """The clock's reading: what a stage paces itself by."""
        return self.clock()

    def remaining(self) -> float:
        """Seconds left, negative once it has passed."""
        return self.at - self.clock()

    def passed(self) -> bool:
        return self.clock() >= self.at

    def sooner(self, seconds: float) -> Deadline:
        """This deadline `seconds` earlier, on the same clock."""
        return Deadline(self.at - seconds, self.clock)
