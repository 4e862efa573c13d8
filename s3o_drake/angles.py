"""Angles: one wrap for the whole project."""

import numpy as np


def wrap(angle):
    """Angles (scalar or array) wrapped into [-π, π] (π itself only by rounding).

    By floor rather than `%`: numpy's float remainder is an order of magnitude slower, and
    far slower still on NaN, which the reachability lookups carry in empty slots.
    """
    angle = np.asarray(angle)
    return angle - (2 * np.pi) * np.floor((angle + np.pi) * (1 / (2 * np.pi)))
