"""The poses file: odometry poses along a run as CSV (SI units).

Columns ``sample, time_s, x_m, y_m, theta_rad`` (a header row, then one row per pose, ten
significant digits): the sample index in the log, its time from the run's start, and the pose
in the run's start frame.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from umbmark.io.atomic import atomic_path

__all__ = ["POSE_COLUMNS", "write_poses_csv"]

POSE_COLUMNS = ("sample", "time_s", "x_m", "y_m", "theta_rad")


def write_poses_csv(
    path: str | Path, sample: ArrayLike, t_s: ArrayLike, x_m: ArrayLike, y_m: ArrayLike, theta_rad: ArrayLike
) -> None:
    """Write poses to a CSV file, atomically.

    Parameters
    ----------
    path : str or Path
        The file to write.
    sample : array_like of int
        Sample indices.
    t_s : array_like
        Times [s].
    x_m, y_m, theta_rad : array_like
        Poses [m, m, rad].
    """
    with atomic_path(path) as tmp:
        np.savetxt(
            tmp,
            np.column_stack([sample, t_s, x_m, y_m, theta_rad]),
            delimiter=",",
            header=",".join(POSE_COLUMNS),
            comments="",
            fmt="%.10g",
        )
