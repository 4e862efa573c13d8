"""How the program says a count or a name to a person (one rule for every message)."""

from __future__ import annotations


def counted(n: int, noun: str, plural: str | None = None) -> str:
    """`n` and the noun in its number: "1 stop", "2 stops", "0 dishes" (`plural` where
    adding an s is wrong)."""
    return f"{n} {noun if n == 1 else plural or noun + 's'}"
