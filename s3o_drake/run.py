"""`python -m s3o_drake.run scenario.yaml`: the run command at its first address (the
project's card names it); `s3o run` is the same command."""

import sys

from s3o_drake.commands.run_scenario import main

if __name__ == "__main__":
    sys.exit(main(prog="python -m s3o_drake.run"))
