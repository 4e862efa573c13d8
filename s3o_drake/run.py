"""`python -m s3o_drake.run`: the run command, kept at its first address. It is
s3o_drake/commands/run_scenario.py; `python -m s3o_drake.run --help` explains it."""

import sys

from s3o_drake.commands.run_scenario import main

if __name__ == "__main__":
    sys.exit(main())
