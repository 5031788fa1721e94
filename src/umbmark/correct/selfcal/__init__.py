"""Lidar self-calibration: wheel radii, wheelbase and sensor pose from the sensor's own motion.

The method of Censi, Franchi, Marchionni, Oriolo, "Simultaneous calibration of odometry and
sensor parameters for mobile robots" (IEEE T-RO 29(2), 2013): a drive is cut into intervals
with the wheel rotations and the sensor's displacement over each
(:class:`~umbmark.model.intervals.Intervals`); the six parameters are those for which the
exact arcs of the wheels, seen from the sensor, best match the displacements::

    from umbmark.correct.selfcal import selfcal
    from umbmark.io.intervals_csv import read_intervals_csv

    res = selfcal(read_intervals_csv("intervals.csv"), wheel_diameter_m=0.15, wheelbase_m=0.34)
    res.to_dict()   # diameters, wheelbase, Ed, Eb, sensor pose, 95 % intervals, warnings

Modules:

* :mod:`~umbmark.correct.selfcal.model`: the measurement model, its Jacobian, the Fisher
  information (the Cramer-Rao bound).
* :mod:`~umbmark.correct.selfcal.closed_form`: the paper's two linear steps (the start).
* :mod:`~umbmark.correct.selfcal.estimate`: :func:`selfcal`, the maximum-likelihood fit with
  noise estimation, outlier rejection and the mirror solution resolved.
* :mod:`~umbmark.correct.selfcal.identify`: what the driving determines, plausibility.
* :mod:`~umbmark.correct.selfcal.result`: :class:`SelfcalResult` and its JSON.
* :mod:`~umbmark.correct.selfcal.kinematic`: the same for a tricycle or mecanum robot (any
  :mod:`~umbmark.model.kinematics`): :func:`kinematic_selfcal`, :class:`KinematicSelfcalResult`.

Imports numpy, :mod:`umbmark.model` and, when a calibration runs, scipy.
"""

from __future__ import annotations

from umbmark.correct.selfcal.closed_form import ClosedFormFailed, closed_form
from umbmark.correct.selfcal.estimate import mirror, selfcal
from umbmark.correct.selfcal.identify import Limits
from umbmark.correct.selfcal.kinematic import KinematicSelfcalResult, kinematic_selfcal
from umbmark.correct.selfcal.model import PARAMETERS, fisher_information, jacobian, predict, residuals
from umbmark.correct.selfcal.result import SelfcalResult

__all__ = [
    "selfcal",
    "SelfcalResult",
    "kinematic_selfcal",
    "KinematicSelfcalResult",
    "Limits",
    "PARAMETERS",
    "closed_form",
    "ClosedFormFailed",
    "mirror",
    "predict",
    "residuals",
    "jacobian",
    "fisher_information",
]
