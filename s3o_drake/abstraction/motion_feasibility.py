"""Motion-level feasibility Fea^m as the abstraction and the planner read it.

Anything with `values(dish, points) -> Fea^m` per point satisfies `MotionFeasibility`;
`HeatmapFeasibility` serves it from `Heatmap` grids (the Drake oracle's and the FCN's: both
produce Heatmaps), with vectorised lookups.
"""

from collections.abc import Mapping, Sequence
from typing import Protocol, runtime_checkable

import numpy as np

from s3o_drake.feasibility.oracle import Heatmap


@runtime_checkable
class MotionFeasibility(Protocol):
    """A source of Fea^m(y, o): the Drake oracle's heatmaps or the learned model."""

    def values(self, dish: str, points: np.ndarray) -> np.ndarray:
        """Fea^m at each base position of `points` (m, 2) for `dish`, in [0, 1]."""
        ...


class HeatmapFeasibility:
    """Fea^m read from one Heatmap per dish (0 outside a heatmap's grid)."""

    def __init__(self, heatmaps: Mapping[str, Heatmap] | Sequence[Heatmap]):
        if isinstance(heatmaps, Mapping):
            self.heatmaps = dict(heatmaps)
        else:
            self.heatmaps = {h.dish: h for h in heatmaps}

    def values(self, dish: str, points: np.ndarray) -> np.ndarray:
        heatmap = self.heatmaps.get(dish)
        if heatmap is None:
            return np.zeros(len(np.asarray(points, dtype=float).reshape(-1, 2)))
        return heatmap.values_at(points)


def as_motion_feasibility(source) -> MotionFeasibility:
    """Accepts a MotionFeasibility, a mapping dish -> Heatmap, or a list of Heatmaps."""
    # A dict has a `values` attribute too: check for heatmap containers first.
    if isinstance(source, (Mapping, list, tuple)):
        return HeatmapFeasibility(source)
    if isinstance(source, MotionFeasibility):
        return source
    raise TypeError(f"not a Fea^m source: {type(source).__name__}")


def heatmap_tuple(source) -> tuple[Heatmap, ...]:
    """The Heatmaps of a list, tuple or mapping of them; () for any other Fea^m source."""
    if isinstance(source, Mapping):
        return tuple(source.values())
    return tuple(source) if isinstance(source, (list, tuple)) else ()
