"""The learned Fea^m: a small fully convolutional network from overhead images to heatmaps.

The paper predicts a dish's feasibility heatmap from the ceiling camera with a VGG-16 FCN.
That network (~130 M parameters, pretrained on ImageNet) is too heavy for a CPU and nothing
can be downloaded here, so this is a small U-Net-like encoder-decoder trained from scratch
on labels from the Drake oracle (`s3o_drake.feasibility.learned.dataset`, `...train`):

- input: a crop of `CROP_CELLS` x `CROP_CELLS` cells over `CROP_SIZE` x `CROP_SIZE` metres
  centred on the dish, the oracle's own grid (row i goes north, column j east), with
  channels (`CHANNELS`): the height of the highest surface over each cell (the depth image
  back-projected to world points: a true top view, so a chair's backrest is where it
  stands, not where perspective displaces it), a mask of the cells no pixel lands in
  (occluded or outside the view), the dish's disk, the offset (dx, dy) of each cell from
  the dish (a convolution is translation-invariant; Fea^m is not: it depends on the reach
  to the centre), and the dish kind as constant one-hot planes (each kind has its grasp);
- the robot itself is in the picture at its start pose; it is no obstacle to itself, so its
  pixels are read as floor;
- architecture: three 2x downsamplings (64 -> 32 -> 16 -> 8) of two 3x3 conv + batch-norm +
  ReLU blocks each, and back up with transposed convolutions and skip connections, so the
  8 x 8 bottleneck sees the whole crop (where the reachable ring is) while the skips keep
  the 6 cm detail of obstacle edges (where the robot's footprint collides); at width 8
  (channels 8-16-32-64) ~0.12 M parameters, ~0.5 MB of weights, a few ms per crop on one
  core;
- output: one logit per cell, a sigmoid gives Fea^m in [0, 1]. Trained with binary cross
  entropy against the oracle's probabilities (soft targets): it is the likelihood of the
  oracle's Monte-Carlo samples, a proper scoring rule whose optimum is the true
  probability, and its gradient does not vanish on saturated cells as MSE through a sigmoid
  does (most cells are certainly 0: out of reach or in collision).

An object the network was not trained on is shown as the kind it is held like
(`furniture.NETWORK_KIND`: a can or an apple as a cup), and a place target as its object
standing there. Its labels held that kind's catch probability (the one factor of the reach
noise in Fea^m, `pickup_geometry.goal_probability`), so the output is rescaled to the
target's own factor: its kind's catch, or for a place the probability that the object
stands within tolerance of it. `LABEL_REACH_STD` is the reach noise of the labels.

A crop and the oracle's heatmap turn together under 90-degree rotations about the dish (the
grid is symmetric about its centre and the noise is isotropic), which training uses as
augmentation; mirror images are not used (the arm is not mirror-symmetric).
"""

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from torch import nn

from s3o_drake.feasibility.oracle import CROP_CELLS, CROP_SIZE, Heatmap
from s3o_drake.feasibility.pickup_geometry import catch_probability, goal_probability
from s3o_drake.world.builder import render_overhead
from s3o_drake.world.camera import OverheadCamera, back_project, overhead_camera
from s3o_drake.world.furniture import DISH_SHAPES, NETWORK_KIND, RESTAURANT_KINDS
from s3o_drake.world.objects import Dish
from s3o_drake.world.robot import Robot
from s3o_drake.world.scenario import Scenario

LABEL_REACH_STD = 0.01
"""The reach noise (m) of the training labels: the restaurant's (scenarios/restaurant.yaml),
whose settings the dataset's scenes keep."""
FEA_FLOOR = 0.01
"""The network's Fea^m below this is read as 0. Its sigmoid never reaches 0: on the 30-dish
tasks of scenarios/generated_scale every one of a crop's 4,096 cells read above 0, 70 % of
them below 0.01. A cell above 0 is a stop the planner weighs, and one the free-stop rule
checks for collisions (feasibility/stops.py) before the budget's search can start; a stop
that succeeds once in a hundred is never one a plan wants."""
CHANNELS = ("height", "unobserved", "dish", "dx", "dy",
            *(f"kind_{k}" for k in RESTAURANT_KINDS))


TILE = 0.25
"""Side (m) of the strips the view's points are sorted into, so that a crop reads only
the points near it (a crop sees ~15 % of the room; filtering all of them was most of the
cost of an FCN heatmap)."""


@dataclass(frozen=True)
class OverheadView:
    """What the overhead camera saw, as world points: p_W (n, 3) of every pixel with a
    return, the robot's own pixels put on the floor; sorted by strip of y (`TILE` wide),
    then by x, with `starts[k]` the first point of strip k (strip 0 begins at y_min)."""

    p_W: np.ndarray  # noqa: N815 (monogram notation)
    y_min: float
    starts: np.ndarray

    @classmethod
    def of_points(cls, p_W: np.ndarray) -> "OverheadView":
        """Sorts the points (n, 3) into strips."""
        y_min = float(p_W[:, 1].min()) if len(p_W) else 0.0
        strip = np.floor((p_W[:, 1] - y_min) / TILE).astype(np.int64)
        order = np.lexsort((p_W[:, 0], strip))
        strips = int(strip.max()) + 1 if len(p_W) else 0
        starts = np.searchsorted(strip[order], np.arange(strips + 1))
        return cls(np.ascontiguousarray(p_W[order]), y_min, starts)

    def near(self, x0: float, y0: float, x1: float, y1: float) -> np.ndarray:
        """The points in strips that meet [y0, y1) with x in [x0, x1) (a superset in y)."""
        first = max(0, int(np.floor((y0 - self.y_min) / TILE)))
        last = min(len(self.starts) - 1, int(np.floor((y1 - self.y_min) / TILE)) + 1)
        pieces = []
        for k in range(first, last):
            a, b = self.starts[k], self.starts[k + 1]
            x = self.p_W[a:b, 0]
            pieces.append(self.p_W[a + np.searchsorted(x, x0):a + np.searchsorted(x, x1)])
        return np.concatenate(pieces) if pieces else np.empty((0, 3))


def overhead_view(camera: OverheadCamera, depth: np.ndarray, label: np.ndarray,
                  robot_labels: frozenset[int]) -> OverheadView:
    """World points seen by the camera; robot pixels are re-projected onto the floor (z=0)."""
    p_W = back_project(camera, depth)
    robot = np.isin(label, list(robot_labels))
    if robot.any():
        v, u = np.nonzero(robot)
        floor_depth = camera.X_WC.translation()[2]
        f = camera.focal
        p_C = np.stack([(u - camera.width / 2 + 0.5) * floor_depth / f,
                        (v - camera.height / 2 + 0.5) * floor_depth / f,
                        np.full(len(u), floor_depth)], axis=-1)
        p_W[v, u] = p_C @ camera.X_WC.rotation().matrix().T + camera.X_WC.translation()
    p_W = p_W.reshape(-1, 3)
    return OverheadView.of_points(p_W[np.isfinite(p_W).all(axis=1)])


def view_of(scenario: Scenario) -> OverheadView:
    """Renders the scenario once and returns its overhead view."""
    _, depth, label, robot_labels = render_overhead(scenario)
    return overhead_view(overhead_camera(scenario.room, scenario.camera), depth, label,
                         robot_labels)


def crop_grid(p_WD: np.ndarray) -> tuple[float, float, float]:
    """(x0, y0, cell) of the crop centred on a dish: the oracle's heatmap grid."""
    cell = CROP_SIZE / CROP_CELLS
    return float(p_WD[0] - CROP_SIZE / 2), float(p_WD[1] - CROP_SIZE / 2), cell


def crop_inputs(view: OverheadView, p_WD: np.ndarray, kind: str) -> np.ndarray:
    """The network's input (len(CHANNELS), CROP_CELLS, CROP_CELLS) for a dish at p_WD."""
    n = CROP_CELLS
    x0, y0, cell = crop_grid(p_WD)
    p = view.near(x0, y0, x0 + CROP_SIZE, y0 + CROP_SIZE)
    j = np.floor((p[:, 0] - x0) / cell)
    i = np.floor((p[:, 1] - y0) / cell)
    inside = (i >= 0) & (i < n) & (j >= 0) & (j < n)
    index = (i[inside] * n + j[inside]).astype(np.int64)
    height = np.full(n * n, -np.inf)
    np.maximum.at(height, index, p[inside, 2])
    unobserved = ~np.isfinite(height)
    height[unobserved] = 0.0
    centres = (np.arange(n) + 0.5) * cell - CROP_SIZE / 2
    dx, dy = np.meshgrid(centres, centres)  # dy grows with the row index: north
    radius = DISH_SHAPES[NETWORK_KIND[kind]].radius
    dish = (np.hypot(dx, dy) <= max(radius, cell / 2)).astype(float)
    kinds = [np.full((n, n), float(NETWORK_KIND[kind] == k)) for k in RESTAURANT_KINDS]
    planes = [np.clip(height, 0.0, None).reshape(n, n), unobserved.reshape(n, n).astype(float),
              dish, dx, dy, *kinds]
    return np.stack(planes).astype(np.float32)


def _block(c_in: int, c_out: int) -> nn.Sequential:
    return nn.Sequential(
        nn.Conv2d(c_in, c_out, 3, padding=1, bias=False), nn.BatchNorm2d(c_out), nn.ReLU(True),
        nn.Conv2d(c_out, c_out, 3, padding=1, bias=False), nn.BatchNorm2d(c_out), nn.ReLU(True))


class FeasibilityUNet(nn.Module):
    """Encoder-decoder with skips: (B, in_channels, 64, 64) -> logits (B, 64, 64)."""

    def __init__(self, in_channels: int = len(CHANNELS), width: int = 8, levels: int = 3):
        super().__init__()
        self.config = {"in_channels": in_channels, "width": width, "levels": levels}
        widths = [width * 2**k for k in range(levels + 1)]
        self.down = nn.ModuleList([_block(in_channels, widths[0])])
        self.down.extend(_block(widths[k], widths[k + 1]) for k in range(levels))
        self.up = nn.ModuleList(nn.ConvTranspose2d(widths[k + 1], widths[k], 2, stride=2)
                                for k in reversed(range(levels)))
        self.merge = nn.ModuleList(_block(2 * widths[k], widths[k])
                                   for k in reversed(range(levels)))
        self.head = nn.Conv2d(widths[0], 1, 1)
        # Most cells of a crop are infeasible (out of reach or in collision): starting near
        # their probability (sigmoid(-2) ~ 0.12) spares the first epochs learning just that.
        nn.init.constant_(self.head.bias, -2.0)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        skips = []
        for k, block in enumerate(self.down):
            x = block(x if k == 0 else nn.functional.max_pool2d(x, 2))
            skips.append(x)
        skips.pop()
        for up, merge in zip(self.up, self.merge, strict=True):
            x = merge(torch.cat([up(x), skips.pop()], dim=1))
        return self.head(x)[:, 0]


@dataclass
class FcnFeasibility:
    """A network trained on `robot`'s labels, with its input normalisation: crops in, Fea^m
    heatmaps out."""

    model: FeasibilityUNet
    mean: np.ndarray
    std: np.ndarray
    robot: Robot

    @classmethod
    def load(cls, path: Path, *, robot: Robot) -> "FcnFeasibility":
        """Reads a checkpoint written by `s3o_drake.feasibility.learned.training`, trained
        for `robot`."""
        checkpoint = torch.load(Path(path), map_location="cpu", weights_only=True)
        model = FeasibilityUNet(**checkpoint["config"])
        model.load_state_dict(checkpoint["state_dict"])
        # Channels-last runs this network's small convolutions ~1.6x faster on a CPU.
        model.eval().to(memory_format=torch.channels_last)
        return cls(model, np.asarray(checkpoint["mean"], dtype=np.float32),
                   np.asarray(checkpoint["std"], dtype=np.float32), robot)

    @classmethod
    def shared(cls, path: Path | None = None, *, robot: Robot) -> "FcnFeasibility":
        """`load(path, robot=robot)`, read once per process: the weights never change while
        it runs. The default is the robot's shipped network, `robot.files.fcn_weights` (see
        models/ur5e/fcn/README.md for the commands that made the UR5e's)."""
        path = robot.files.fcn_weights if path is None else path
        key = (robot.name, str(Path(path).resolve()))
        if key not in _SHARED:
            _SHARED[key] = cls.load(path, robot=robot)
        return _SHARED[key]

    def predict(self, inputs: np.ndarray) -> np.ndarray:
        """Fea^m (B, 64, 64) in [0, 1] for a batch of crops (B, C, 64, 64)."""
        x = (np.asarray(inputs, dtype=np.float32) - self.mean[:, None, None]) \
            / self.std[:, None, None]
        with torch.inference_mode():
            x = torch.from_numpy(x).contiguous(memory_format=torch.channels_last)
            return torch.sigmoid(self.model(x)).numpy().astype(float)

    def heatmaps(self, view: OverheadView, dishes: list[Dish]) -> list[Heatmap]:
        """Heatmaps of the dishes (seen at their positions) in one batch, in their order;
        the geometry is the oracle's crop: CROP_SIZE metres, CROP_CELLS cells, centred."""
        if not dishes:
            return []
        inputs = np.stack([crop_inputs(view, np.asarray(d.position[:2]), d.kind)
                           for d in dishes])
        values = self.predict(inputs)
        return [Heatmap(d.name, _floored(_own_factor(d, v, self.robot)),
                        *crop_grid(np.asarray(d.position[:2])))
                for d, v in zip(dishes, values, strict=True)]

    def heatmap(self, view: OverheadView, dish: Dish) -> Heatmap:
        """The heatmap of one dish."""
        return self.heatmaps(view, [dish])[0]


def _own_factor(dish: Dish, values: np.ndarray, robot: Robot) -> np.ndarray:
    """The network's heatmap with the factor of the reach noise it learned for the kind it
    is shown as replaced by the target's own (see the module docstring). The network's
    estimate of the blurred success, values over the learned factor, is at most 1: a
    trained kind's pick is the network's heatmap capped at its catch probability."""
    learned = catch_probability(NETWORK_KIND[dish.kind], LABEL_REACH_STD, robot=robot)
    own = goal_probability(dish.name, dish.kind, LABEL_REACH_STD, robot=robot)
    return np.minimum(values / learned, 1.0) * own


def _floored(values: np.ndarray) -> np.ndarray:
    """`values` with Fea^m below FEA_FLOOR set to 0."""
    return np.where(values < FEA_FLOOR, 0.0, values)


_SHARED: dict[tuple[str, str], FcnFeasibility] = {}


def use_one_thread() -> None:
    """Sets torch to one intra-op thread. A batch of crops takes milliseconds on one core,
    while torch's default pool (a thread per core) competes with Drake's own threads for
    the simulation that follows: with it the execution benchmark ran 8.9x real time instead
    of 10.7x."""
    torch.set_num_threads(1)


def scenario_heatmaps(scenario: Scenario, dishes: list[Dish] | None = None, *,
                      weights: Path | None = None) -> list[Heatmap]:
    """FCN heatmaps of the dishes (default: all the scenario's) from one overhead render of
    the scenario: the chairs come only from the camera's images, never from their poses.
    `weights`: the scenario's robot's shipped network by default."""
    view = view_of(scenario)
    return FcnFeasibility.shared(weights, robot=scenario.contents.robot).heatmaps(
        view, list(scenario.dishes) if dishes is None else dishes)


def auroc(scores: np.ndarray, positive: np.ndarray) -> float:
    """Area under the ROC curve by the Mann-Whitney rank statistic (ties get mean ranks);
    nan when one class is empty."""
    from scipy.stats import rankdata

    scores = np.asarray(scores, dtype=float).ravel()
    positive = np.asarray(positive, dtype=bool).ravel()
    n_pos, n_neg = int(positive.sum()), int((~positive).sum())
    if n_pos == 0 or n_neg == 0:
        return math.nan
    ranks = rankdata(scores)
    return float((ranks[positive].sum() - n_pos * (n_pos + 1) / 2) / (n_pos * n_neg))
