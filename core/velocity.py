"""A velocity from timed positions: the least-squares slope, which a jittery sighting moves far less than a
difference of the first and last would."""

from __future__ import annotations

import numpy as np


def least_squares_velocity(samples: np.ndarray) -> tuple[float, float]:
    """(vx, vy) in units per second for rows of (t, x, y); needs two or more distinct times."""
    t = samples[:, 0] - samples[:, 0].mean()
    vx = float(t @ (samples[:, 1] - samples[:, 1].mean()) / (t @ t))
    vy = float(t @ (samples[:, 2] - samples[:, 2].mean()) / (t @ t))
    return vx, vy


def velocity_standard_error(samples: np.ndarray) -> float:
    """The least-squares slope's standard error (units per second, x and y pooled) for rows of (t, x, y): the
    scatter of the positions about the fitted line over the spread of their times; needs three or more rows.

    A slope smaller than about twice this is the positions' noise, not a motion."""
    t = samples[:, 0] - samples[:, 0].mean()
    tt = float(t @ t)
    rss = 0.0
    for col in (1, 2):
        y = samples[:, col] - samples[:, col].mean()
        rss += float(y @ y) - float(t @ y) ** 2 / tt
    return float(np.sqrt(max(rss, 0.0) / (2 * (len(samples) - 2)) / tt))
