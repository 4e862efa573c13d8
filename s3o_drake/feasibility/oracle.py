"""Fea^m(y_r, y_o): the probability that the executed pickup succeeds, from Drake.

The robot is sent to base position y_r facing the dish. Its landing carries the navigation
noise T^n, (dx, dy) ~ N(0, nav_xy_std² I) and dyaw ~ N(0, nav_yaw_std²), and the execution
decides where it then stands (`landing.pickup_poses`: stopped short of a collision, turned
to face the dish). The gripper aims at the dish's grasp point shifted horizontally by the
reach noise T^m, ξ ~ N(0, reach_std² I) (the overhead camera errs in the floor plane; the
table's height is known). The pickup succeeds when the ArmController's test passes from
there (`pickup_geometry`: grasp, pre-grasp, lift, tray, with the target moved by ξ) and the
fingers catch the dish (|ξ| within `grasp_tolerance`). Only the arm's joint-space paths
between those configurations are left out (RRT-Connect finds them; how rarely they decide
an outcome is measured, docs/feasibility.md).

Two ways to compute it:

- `probabilities`: Monte Carlo over exactly that: the reference. `MC_SAMPLES` = 100
  landings per position keep its standard error sqrt(p (1 - p) / n) at most 0.05 (at
  p = 0.5).
- `heatmap`, `room_heatmap`: the same expectation without sampling error, for grids. Once
  the base has turned to face the dish, where it picks depends only on where it landed in
  the plane: S(x) = the pickup succeeds from the pickup pose of a landing at x (facing the
  dish; stopped short on the line to the dish when x collides). Then
  Fea^m(y) = P(caught) (E_e[S(y + e)] + P(B) S(y)), S blurred by the landing noise's
  Gaussian, B the landings with no free pose straight back, which are approached from y
  and land between the two (counted as picking as y does). The reach
  noise widens the blur (a target off by ξ is, to the arm, a base off by -ξ), and
  P(caught) = 1 - exp(-tol² / 2 reach_std²) (the norm of ξ is Rayleigh); for a place
  target, P(placed within tolerance) takes its place (`pickup_geometry.goal_probability`).
  S is evaluated on a grid `FINE_CELL` or finer whose every k-th point is a heatmap cell's
  centre, halved where S changes between neighbouring points, and blurred with
  `scipy.ndimage.gaussian_filter`. What this leaves out (the drive's heading
  taken along the line to the dish, a yaw within `TURN_TOLERANCE` of facing taken as
  facing) is measured against `probabilities` by `s3o bench oracle-pinning`.
"""

import math
from dataclasses import dataclass

import numpy as np
from scipy.ndimage import binary_dilation, gaussian_filter

from s3o_drake.feasibility.check import FeasibilityChecker
from s3o_drake.feasibility.landing import pickup_poses, stop_short
from s3o_drake.feasibility.oracle_cache import cached_array
from s3o_drake.feasibility.pickup_geometry import (
    goal_probability,
    pickup_feasible_many,
    place_error_stds,
)
from s3o_drake.world.angles import facing_yaw
from s3o_drake.world.goals import placed_object
from s3o_drake.world.gripper import grasp_tolerance
from s3o_drake.world.placing import PLACE_TOLERANCE
from s3o_drake.world.settings import Uncertainty

CROP_SIZE = 4.0
CROP_CELLS = 64
#: Monte-Carlo landings per position (see the module docstring).
MC_SAMPLES = 100
#: The grid on which S is evaluated starts at least this fine (m): the heatmaps' 6.25 cm
#: cells as they are, halved once where S changes between neighbours (`REFINEMENTS`).
#: Against the same halved once more (1.6 cm where S changes), on 3 dishes of task_002,
#: heatmap values differ by 0.005 on average where either is above 0.02 (95th percentile
#: 0.03); without the halving by 0.012 (0.04), and by up to 0.15 next to thin features.
FINE_CELL = 0.07
#: Halvings of that grid where S changes between neighbouring points.
REFINEMENTS = 1
#: The blur's kernel reaches this many standard deviations (its tails beyond weigh < 1e-3).
TRUNCATE = 3.5
#: No base further than this (m) from a dish reaches it: the arm's reach from the base's
#: centre (about 1.35 m with a side grasp) and a margin.
REACH_LIMIT = 1.5


@dataclass(frozen=True)
class Heatmap:
    """Fea^m of one dish on a grid of base positions.

    values[i, j] is the probability at the cell centre
    (x0 + (j + 0.5) * cell, y0 + (i + 0.5) * cell): rows go north (+y), columns east (+x).
    """

    dish: str
    values: np.ndarray
    x0: float
    y0: float
    cell: float

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """(x_min, x_max, y_min, y_max) of the grid, for plotting."""
        rows, cols = self.values.shape
        return (self.x0, self.x0 + cols * self.cell, self.y0, self.y0 + rows * self.cell)

    def centers(self) -> np.ndarray:
        """Cell centres, shape (rows, cols, 2)."""
        rows, cols = self.values.shape
        xs = self.x0 + (np.arange(cols) + 0.5) * self.cell
        ys = self.y0 + (np.arange(rows) + 0.5) * self.cell
        return np.stack(np.meshgrid(xs, ys), axis=-1)

    def values_at(self, points: np.ndarray) -> np.ndarray:
        """The probability of the cell holding each point of `points` (n, 2): (n,), 0
        outside the grid."""
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        j = np.floor((points[:, 0] - self.x0) / self.cell).astype(int)
        i = np.floor((points[:, 1] - self.y0) / self.cell).astype(int)
        rows, cols = self.values.shape
        inside = (i >= 0) & (i < rows) & (j >= 0) & (j < cols)
        out = np.zeros(len(points))
        out[inside] = self.values[i[inside], j[inside]]
        return out

    def value_at(self, p: np.ndarray) -> float:
        """The probability of the cell holding the point p (0 outside the grid)."""
        j = math.floor((p[0] - self.x0) / self.cell)
        i = math.floor((p[1] - self.y0) / self.cell)
        rows, cols = self.values.shape
        return float(self.values[i, j]) if 0 <= i < rows and 0 <= j < cols else 0.0


class FeasibilityOracle:
    """Fea^m from the Drake check of the executed pickup, with the scenario's noise model."""

    def __init__(self, checker: FeasibilityChecker, noise: Uncertainty):
        self.checker = checker
        self.noise = noise

    # --------------------------------------------------------------------- the success test
    def success(self, bases: np.ndarray, dish: str,
                reach_offsets: np.ndarray | None = None) -> np.ndarray:
        """Whether the ArmController's pickup test passes from base poses (n, 3), the grasp
        target moved by `reach_offsets` (n, 2 or 3): bool (n,). The fingers' catch is not
        part of it (`grasp_tolerance`)."""
        return pickup_feasible_many(self.checker.scene, self.checker, bases, dish,
                                    reach_offsets)

    def landing_success(self, landings: np.ndarray, dish: str) -> np.ndarray:
        """S(x) of the module docstring for landing positions (n, 2): bool (n,)."""
        return self._landings(landings, dish)[0]

    def _landings(self, landings: np.ndarray, dish: str) -> tuple[np.ndarray, np.ndarray]:
        """S(x) for landing positions (n, 2), and whether each found a free pose straight
        back along its heading: bool (n,) each."""
        landings = np.asarray(landings, dtype=float).reshape(-1, 2)
        p_dish, _ = self.checker.scene.dish_p_WD(dish)
        targets = np.column_stack([landings, facing_yaw(landings, p_dish)])
        # Stepping back against a heading that faces the dish keeps it facing the dish.
        poses, landed = stop_short(self.checker.base_free, targets)
        ok = np.zeros(len(landings), dtype=bool)
        ok[landed] = self.success(poses[landed], dish)
        return ok, landed

    # ------------------------------------------------------------------------ Monte Carlo
    def probabilities(self, positions: np.ndarray, dish: str, *, rng: np.random.Generator,
                      samples: int = MC_SAMPLES) -> np.ndarray:
        """Fea^m for each base position (n, 2), by Monte Carlo over the executed landing
        and reach (see the module docstring). The noise is drawn all at once, first."""
        positions = np.asarray(positions, dtype=float).reshape(-1, 2)
        n = len(positions)
        nav = rng.normal(0.0, 1.0, (n, samples, 3)) * [
            self.noise.nav_xy_std, self.noise.nav_xy_std, self.noise.nav_yaw_std]
        reach = rng.normal(0.0, self.noise.reach_std, (n, samples, 2))
        p_dish, _ = self.checker.scene.dish_p_WD(dish)
        nominal = np.repeat(positions, samples, axis=0)
        poses, landed = pickup_poses(self.checker.base_free, nominal, p_dish,
                                     nav.reshape(-1, 3))
        reach = reach.reshape(-1, 2)
        kind = self.checker.scene.dishes[dish].kind
        if placed_object(dish) is None:
            tolerance = grasp_tolerance(kind, robot=self.checker.scene.robot)
            ok = landed & (np.linalg.norm(reach, axis=1) <= tolerance)
        else:  # put down where the reach aims, off by the object's offset in the hand too
            # The in-hand offset along the axes of `place_error_stds` (the disc is round:
            # which horizontal axes they are does not matter).
            stds = np.array(place_error_stds(kind, self.noise.reach_std,
                                             robot=self.checker.scene.robot))
            in_hand = rng.normal(0.0, 1.0, reach.shape) * np.sqrt(
                np.maximum(stds**2 - self.noise.reach_std**2, 0.0))
            ok = landed & (np.linalg.norm(reach + in_hand, axis=1) <= PLACE_TOLERANCE)
        ok[ok] = self.success(poses[ok], dish, reach[ok])
        return ok.reshape(n, samples).mean(axis=1)

    def probability(self, position: np.ndarray, dish: str, *, rng: np.random.Generator,
                    samples: int = MC_SAMPLES) -> float:
        """Fea^m(y_r, y_o) for one base position, by Monte Carlo."""
        return float(self.probabilities(position, dish, rng=rng, samples=samples)[0])

    # -------------------------------------------------------------------------- heatmaps
    def expectation(self, dish: str, xs: np.ndarray, ys: np.ndarray, *,
                    fine_cell: float = FINE_CELL) -> np.ndarray:
        """Fea^m at the grid of centres xs (cols,) x ys (rows,), evenly spaced by the same
        step: (rows, cols), by the blur of the module docstring, S evaluated on a grid
        `fine_cell` or finer (coarser costs less and is less exact). Kept on disk when
        `S3O_CACHE` names a folder (`oracle_cache`)."""
        xs, ys = np.asarray(xs, dtype=float), np.asarray(ys, dtype=float)
        return cached_array(
            lambda: ("expectation", *self.checker.identity(), self.noise, dish, xs, ys,
                     fine_cell),
            lambda: self._expectation(dish, xs, ys, fine_cell), robot=self.checker.scene.robot)

    def _expectation(self, dish: str, xs: np.ndarray, ys: np.ndarray,
                     fine_cell: float) -> np.ndarray:
        cell = float(xs[1] - xs[0]) if len(xs) > 1 else float(ys[1] - ys[0])
        k = max(1, math.ceil(cell / fine_cell - 1e-9))
        h = cell / k
        sigma = math.hypot(self.noise.nav_xy_std, self.noise.reach_std)
        margin = math.ceil(TRUNCATE * sigma / h)
        fine_x = xs[0] + h * np.arange(-margin, (len(xs) - 1) * k + margin + 1)
        fine_y = ys[0] + h * np.arange(-margin, (len(ys) - 1) * k + margin + 1)
        p_dish, _ = self.checker.scene.dish_p_WD(dish)
        S, landed = self._success_grid(dish, p_dish, fine_x, fine_y)
        for _ in range(REFINEMENTS):
            fine_x, fine_y, S, landed = self._refined(dish, p_dish, fine_x, fine_y, S, landed)
            h, margin, k = h / 2, 2 * margin, 2 * k
        at = S[margin::k, margin::k][:len(ys), :len(xs)]  # S at the centres themselves
        if sigma > 0:
            # A landing with no free pose straight back is approached from the stop it was
            # sent to (`landing.stop_short`) and lands between the two: it is counted as
            # picking as the stop itself does, with the chance of such a landing.
            # Only where the blur carries it to a centre that picks (at > 0) does a blocked
            # landing count: the kernel's reach, as scipy truncates it, around those.
            reach = int(TRUNCATE * sigma / h + 0.5)
            picks = np.zeros(S.shape, dtype=bool)
            picks[margin::k, margin::k][:len(ys), :len(xs)] = at > 0
            needed = binary_dilation(picks, np.ones((2 * reach + 1, 2 * reach + 1), bool))
            cut = self._blocked_grid(p_dish, fine_x, fine_y, needed, landed)
            S = gaussian_filter(S, sigma / h, mode="constant", cval=0.0, truncate=TRUNCATE)
            cut = gaussian_filter(cut, sigma / h, mode="constant", cval=0.0,
                                  truncate=TRUNCATE)
            values = S[margin::k, margin::k][:len(ys), :len(xs)] + \
                cut[margin::k, margin::k][:len(ys), :len(xs)] * at
        else:
            values = at
        kind = self.checker.scene.dishes[dish].kind
        return np.clip(values, 0.0, 1.0) * goal_probability(
            dish, kind, self.noise.reach_std, robot=self.checker.scene.robot)

    def _success_grid(self, dish: str, p_dish: np.ndarray, xs: np.ndarray,
                      ys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """S (the landing's success, 0 or 1) at the grid points xs x ys: (rows, cols); and
        whether the landing found a free pose straight back (1 or 0; NaN where too far from
        the dish to be asked)."""
        P = np.stack(np.meshgrid(xs, ys), axis=-1)
        near = np.linalg.norm(P - p_dish, axis=-1) <= REACH_LIMIT
        S = np.zeros(P.shape[:2])
        landed = np.full(P.shape[:2], np.nan)
        S[near], landed[near] = self._landings(P[near], dish)
        return S, landed

    def _blocked_grid(self, p_dish: np.ndarray, xs: np.ndarray, ys: np.ndarray,
                      needed: np.ndarray, landed: np.ndarray) -> np.ndarray:
        """1 at the grid points xs x ys where a landing facing the dish finds no free pose
        straight back along its heading, else 0: (rows, cols); where `needed` (rows, cols)
        says, 0 elsewhere. `landed` holds what S's evaluation found already (NaN where it
        did not ask): the same drives, so only the others are driven here."""
        P = np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)
        known = landed.reshape(-1)
        near = (np.linalg.norm(P - p_dish, axis=1) <= REACH_LIMIT) & needed.reshape(-1)
        blocked = np.zeros(len(P))
        have = near & ~np.isnan(known)
        blocked[have] = 1.0 - known[have]
        ask = near & np.isnan(known)
        targets = np.column_stack([P[ask], facing_yaw(P[ask], p_dish)])
        _, found = stop_short(self.checker.base_free, targets)
        blocked[ask] = ~found
        return blocked.reshape(len(ys), len(xs))

    def _refined(self, dish: str, p_dish: np.ndarray, xs: np.ndarray, ys: np.ndarray,
                 S: np.ndarray, landed: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """S on the grid of half the spacing: a new point between grid points that agree
        takes their value, one between points that differ is evaluated; and `landed`
        (`_success_grid`) where known."""
        rows, cols = S.shape
        fine = np.full((2 * rows - 1, 2 * cols - 1), np.nan)
        fine[::2, ::2] = S
        fine_landed = np.full(fine.shape, np.nan)
        fine_landed[::2, ::2] = landed
        fine_x = np.linspace(xs[0], xs[-1], 2 * cols - 1)
        fine_y = np.linspace(ys[0], ys[-1], 2 * rows - 1)
        # The parents of each new point: its 2 (on a grid line) or 4 (in a square) neighbours.
        lo = np.full(fine.shape, np.inf)
        hi = np.full(fine.shape, -np.inf)
        for di in (-1, 0, 1):
            for dj in (-1, 0, 1):
                shifted = np.full(fine.shape, np.nan)
                shifted[max(di, 0):fine.shape[0] + min(di, 0),
                        max(dj, 0):fine.shape[1] + min(dj, 0)] = \
                    fine[max(-di, 0):fine.shape[0] + min(-di, 0),
                         max(-dj, 0):fine.shape[1] + min(-dj, 0)]
                lo = np.fmin(lo, shifted)
                hi = np.fmax(hi, shifted)
        new = np.isnan(fine)
        agree = new & (lo == hi)
        fine[agree] = lo[agree]
        ask = np.argwhere(new & ~agree)
        if len(ask):
            P = np.column_stack([fine_x[ask[:, 1]], fine_y[ask[:, 0]]])
            near = np.linalg.norm(P - p_dish, axis=1) <= REACH_LIMIT
            values = np.zeros(len(P))
            found = np.full(len(P), np.nan)
            values[near], found[near] = self._landings(P[near], dish)
            fine[ask[:, 0], ask[:, 1]] = values
            fine_landed[ask[:, 0], ask[:, 1]] = found
        return fine_x, fine_y, fine, fine_landed

    def heatmap(self, dish: str, *, size: float = CROP_SIZE, cells: int = CROP_CELLS,
                center: np.ndarray | None = None, fine_cell: float = FINE_CELL) -> Heatmap:
        """Fea^m on a cells x cells grid of side `size` (m), centred on the dish by default
        (`fine_cell`: `expectation`'s)."""
        if center is None:
            center, _ = self.checker.scene.dish_p_WD(dish)
        cell = size / cells
        x0, y0 = float(center[0] - size / 2), float(center[1] - size / 2)
        centres = (np.arange(cells) + 0.5) * cell
        return Heatmap(dish, self.expectation(dish, x0 + centres, y0 + centres,
                                              fine_cell=fine_cell), x0, y0, cell)

    def room_heatmap(self, dish: str, *, cell: float = 0.05) -> Heatmap:
        """Fea^m over the whole room at `cell` resolution (m)."""
        x_min, y_min, x_max, y_max = self.checker.scene.contents.room.bounds
        cols = math.ceil((x_max - x_min) / cell)
        rows = math.ceil((y_max - y_min) / cell)
        xs = x_min + (np.arange(cols) + 0.5) * cell
        ys = y_min + (np.arange(rows) + 0.5) * cell
        return Heatmap(dish, self.expectation(dish, xs, ys), x_min, y_min, cell)
