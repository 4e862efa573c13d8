"""Every command of the project, each a thin `main` over library calls, run as a subcommand
of the `s3o` console script (cli.py: `s3o --help` lists them; docs/commands.md explains
them). The library never imports from here.

  s3o run, generate, evaluate, calibrate,     the user's commands
      failure-price, diagrams
  s3o build reachability|time-model|...       make what ships in models/
  s3o bench planning|execution|...            measurements (figures in docs/)
"""
