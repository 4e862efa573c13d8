"""`python -m s3o_drake.commands`: the `s3o` console script, where it is not installed."""

import sys

from s3o_drake.commands.cli import main

if __name__ == "__main__":
    sys.exit(main())
