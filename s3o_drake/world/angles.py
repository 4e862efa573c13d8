"""Angles: one wrap and one facing yaw for the whole project."""

import numpy as np


def wrap(angle):
    """Angles (scalar or array) wrapped into [-π, π] (π itself only by rounding).

    By floor rather than `%`: numpy's float remainder is an order of magnitude slower, and
    far slower still on NaN, which the reachability lookups carry in empty slots.
    """
    angle = np.asarray(angle)
    return angle - (2 * np.pi) * np.floor((angle + np.pi) * (1 / (2 * np.pi)))


def facing_yaw(p_from, p_to):
    """Yaw (rad) of a base at `p_from` ((2,) or (..., 2)) that faces `p_to` ((2,) or
    (..., 2)): a float for one pair, an array for many; 0 where the two coincide."""
    d = np.asarray(p_to, dtype=float)[..., :2] - np.asarray(p_from, dtype=float)[..., :2]
    yaw = np.arctan2(d[..., 1], d[..., 0])  # arctan2(0, 0) = 0
    return float(yaw) if yaw.ndim == 0 else yaw
