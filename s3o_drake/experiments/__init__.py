"""The benchmark over many tasks, methods and seeds (`s3o evaluate`).

jobs.py: what one run is and how a worker runs it; store.py: results as append-only JSON
lines that survive a crash; scheduler.py: a local process pool or a Dask cluster;
difficulty.py: the paper's difficulty groups; summary.py: the tables and figures.
"""
