"""S3O's symbolic state space: Voronoi cells, merging, task-level feasibility, ranking.

Steps 2-4 of S3O: `build_abstraction` runs them all; the modules hold:
  voronoi.py            free space, the Voronoi cells, Sym and adjacency
  candidates.py         partitions into connected groups: enumeration and beam search
  task_feasibility.py   Fea^t from any Fea^m source (heatmaps now, the FCN later)
  ranking.py            Score, ranking, the top-K distribution, S3O-Random
"""

from s3o_drake.abstraction.candidates import beam_partitions, connected_partitions
from s3o_drake.abstraction.ranking import (
    Abstraction,
    StateSpace,
    build_abstraction,
    rank,
    top_k_distribution,
)
from s3o_drake.abstraction.task_feasibility import (
    HeatmapFeasibility,
    MotionFeasibility,
    TaskFeasibility,
)
from s3o_drake.abstraction.voronoi import VoronoiPartition, free_space, voronoi_partition

__all__ = [
    "Abstraction",
    "HeatmapFeasibility",
    "MotionFeasibility",
    "StateSpace",
    "TaskFeasibility",
    "VoronoiPartition",
    "beam_partitions",
    "build_abstraction",
    "connected_partitions",
    "free_space",
    "rank",
    "top_k_distribution",
    "voronoi_partition",
]
