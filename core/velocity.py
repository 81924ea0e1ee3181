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
