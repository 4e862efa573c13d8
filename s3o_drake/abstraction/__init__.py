"""S3O's symbolic state space: Voronoi cells, merging, task-level feasibility, ranking.

Steps 2-4 of S3O: `build_abstraction` runs them all; the modules hold:
  voronoi.py            free space, the Voronoi cells, Sym and adjacency
  candidates.py         partitions into connected groups: enumeration and beam search
  motion_feasibility.py Fea^m sources: heatmaps (the Drake oracle's or the FCN's)
  location_grid.py      the 5 cm location grid and its one joint-feasibility rule
  task_feasibility.py   Fea^t on the location grid
  ranking.py            Score, ranking, the top-K distribution, S3O-Random
"""

from s3o_drake.abstraction.candidates import beam_partitions, connected_partitions
from s3o_drake.abstraction.location_grid import (
    GRID_CELL,
    GridFallback,
    GridLocation,
    LocationGrid,
    joint_feasible,
    region_location,
)
from s3o_drake.abstraction.motion_feasibility import (
    HeatmapFeasibility,
    MotionFeasibility,
    as_motion_feasibility,
)
from s3o_drake.abstraction.ranking import (
    Abstraction,
    StateSpace,
    build_abstraction,
    rank,
    top_k_distribution,
)
from s3o_drake.abstraction.task_feasibility import TaskFeasibility
from s3o_drake.abstraction.voronoi import VoronoiPartition, free_space, voronoi_partition

__all__ = [
    "GRID_CELL",
    "Abstraction",
    "GridFallback",
    "GridLocation",
    "HeatmapFeasibility",
    "LocationGrid",
    "MotionFeasibility",
    "StateSpace",
    "TaskFeasibility",
    "VoronoiPartition",
    "as_motion_feasibility",
    "beam_partitions",
    "build_abstraction",
    "connected_partitions",
    "free_space",
    "joint_feasible",
    "rank",
    "region_location",
    "top_k_distribution",
    "voronoi_partition",
]
