"""Shared command-line plumbing: one-line errors with exit status 2."""

import argparse
import sys
from typing import NoReturn

EXIT_BAD_INPUT = 2


class ArgumentParser(argparse.ArgumentParser):
    """An argparse parser whose errors are one line on stderr and exit status 2."""

    def error(self, message: str) -> NoReturn:
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {message} (see --help)\n")


def fail(message: str) -> NoReturn:
    """Reports bad input as one line on stderr and exits with status 2."""
    print(f"error: {message}", file=sys.stderr)
    sys.exit(EXIT_BAD_INPUT)


def doc_formatter() -> type[argparse.HelpFormatter]:
    """Keeps the module docstring's line breaks in --help."""
    return argparse.RawDescriptionHelpFormatter
