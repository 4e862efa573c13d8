"""Every command of the project, each a thin `main` over library calls; `python -m
s3o_drake.commands.<name> --help` explains one. The library never imports from here.

  run, evaluate, generate, calibration, diagrams    the user's commands
  dataset, train, build_reachability, derive_times  make what ships in models/
  *_benchmark, oracle_pinning, compare_feasibility,
  reachability_agreement                            measurements (figures in docs/)
"""
