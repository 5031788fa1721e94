"""The result of a self-calibration: the six parameters in SI, their covariance and intervals.

:class:`SelfcalResult` holds what :func:`umbmark.correct.selfcal.selfcal` found;
:meth:`SelfcalResult.to_dict` is its JSON (millimetres and degrees, pinned keys). Derived
figures (diameters, ``E_d = D_R / D_L``, ``E_b = b / b_nominal``, the sensor pose in mm and
degrees) carry 95 % intervals from the covariance by the delta method.

Pure numpy: imports numpy and the other modules of this package.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from umbmark.correct.selfcal.model import PARAMETERS

__all__ = ["SelfcalResult"]


@dataclass(frozen=True)
class SelfcalResult:
    """Wheel radii, wheelbase and sensor pose estimated from intervals, with their uncertainty.

    Parameters
    ----------
    r_left_m, r_right_m : float
        Wheel radii [m].
    wheelbase_m : float
        Wheelbase b [m].
    sensor_pose : tuple of float
        The sensor's pose on the robot ``(x_m, y_m, yaw_rad)`` (x forward, y left, yaw
        counter-clockwise; yaw in (-pi, pi]).
    covariance : numpy.ndarray
        Shape (6, 6), of ``(r_L, r_R, b, x, y, yaw)`` (:data:`~umbmark.correct.selfcal.model.PARAMETERS`).
    ci95 : dict
        Parameter name (:data:`~umbmark.correct.selfcal.model.PARAMETERS`) to its 95 % interval
        ``(low, high)`` in SI units.
    intervals_used : int
        The intervals the fit used.
    intervals_rejected : tuple of int
        The indices (into the input) of the intervals rejected as outliers.
    warnings : list of str
        What limits the result (poorly determined parameters and the driving that would fix
        them, implausible values, the reader's warnings).
    nominal_wheel_diameter_m, nominal_wheelbase_m : float
        The nominal geometry the result is compared with.
    noise_sd : tuple of float
        The noise of the sensor displacements ``(dx_m, dy_m, dyaw_rad)``: the scale of each
        component estimated from the residuals (for Student t noise that of its scatter
        matrix), or the root mean square of the given covariances' standard deviations.
    t_quantile : float
        The factor from standard deviations to the 95 % half-widths (Student t of the
        blocks less one, or of the residual degrees of freedom).
    cost : float
        Half the sum of the squared whitened residuals of the used intervals.
    noise_dof : float
        The Student t degrees of freedom of the noise (``inf``: Gaussian).
    covariance_blocks : int
        The blocks of time the covariance of shared errors was computed over (0: the Fisher
        information's alone).
    wheel_jitter_s : float
        The standard deviation of the wheel data's stamps against the sensor's, estimated with
        the noise (errors in the wheel data at each end of an interval, of the size of the
        motion over that time; 0: none found, nan: not modelled).
    """

    r_left_m: float
    r_right_m: float
    wheelbase_m: float
    sensor_pose: tuple[float, float, float]
    covariance: NDArray[np.float64]
    ci95: dict[str, tuple[float, float]]
    intervals_used: int
    intervals_rejected: tuple[int, ...]
    warnings: list[str]
    nominal_wheel_diameter_m: float
    nominal_wheelbase_m: float
    noise_sd: tuple[float, float, float] = (math.nan, math.nan, math.nan)
    t_quantile: float = 1.959963984540054
    cost: float = math.nan
    noise_dof: float = math.inf
    covariance_blocks: int = 0
    wheel_jitter_s: float = math.nan

    @property
    def params(self) -> NDArray[np.float64]:
        """The six parameters as an array, in the order of the covariance."""
        return np.array([self.r_left_m, self.r_right_m, self.wheelbase_m, *self.sensor_pose], dtype=float)

    @property
    def sd(self) -> NDArray[np.float64]:
        """Standard deviations of the six parameters (square roots of the covariance's diagonal)."""
        return np.sqrt(np.maximum(np.diag(self.covariance), 0.0))

    @property
    def diameter_left_m(self) -> float:
        """Left wheel diameter ``2 r_L`` [m]."""
        return 2.0 * self.r_left_m

    @property
    def diameter_right_m(self) -> float:
        """Right wheel diameter ``2 r_R`` [m]."""
        return 2.0 * self.r_right_m

    @property
    def ed(self) -> float:
        """``E_d = D_R / D_L = r_R / r_L``."""
        return self.r_right_m / self.r_left_m

    @property
    def eb(self) -> float:
        """``E_b = b / b_nominal``."""
        return self.wheelbase_m / self.nominal_wheelbase_m

    def _interval(self, value: float, grad: NDArray[np.float64]) -> tuple[float, float]:
        half = self.t_quantile * math.sqrt(max(float(grad @ self.covariance @ grad), 0.0))
        return (value - half, value + half)

    def interval(self, name: str) -> tuple[float, float]:
        """The 95 % interval of a parameter or a derived figure, SI units.

        Parameters
        ----------
        name : str
            One of :data:`~umbmark.correct.selfcal.model.PARAMETERS`, or ``ed``, ``eb``,
            ``diameter_left_m``, ``diameter_right_m``.

        Returns
        -------
        tuple of float
            ``(low, high)``.

        Raises
        ------
        KeyError
            For another name.
        """
        if name in self.ci95:
            return self.ci95[name]
        g = np.zeros(6)
        if name == "ed":
            g[0], g[1] = -self.r_right_m / self.r_left_m**2, 1.0 / self.r_left_m
            return self._interval(self.ed, g)
        if name == "eb":
            g[2] = 1.0 / self.nominal_wheelbase_m
            return self._interval(self.eb, g)
        if name == "diameter_left_m":
            g[0] = 2.0
            return self._interval(self.diameter_left_m, g)
        if name == "diameter_right_m":
            g[1] = 2.0
            return self._interval(self.diameter_right_m, g)
        raise KeyError(name)

    def to_dict(self) -> dict:
        """The result as JSON: millimetres and degrees, with 95 % intervals.

        Returns
        -------
        dict
            ``wheel_diameter_left_mm``, ``wheel_diameter_right_mm``, ``wheelbase_mm``, ``Ed``,
            ``Eb`` and ``<each>_ci95`` (``[low, high]``); ``sensor_pose`` with ``x_mm``,
            ``y_mm``, ``yaw_deg`` and their ``_ci95``; ``intervals_used``,
            ``intervals_rejected`` (indices), ``warnings``; the nominal geometry, the noise
            of the sensor displacements (``noise_sd``: the scale of each component;
            ``noise_dof``: its Student t degrees of freedom, null for Gaussian noise),
            ``covariance_blocks`` (the blocks of time of the covariance of shared errors, 0
            for none), ``wheel_jitter_ms`` (the wheel data's stamp jitter against the
            sensor's, null when not modelled), the standard deviations and the covariance (SI, in the order of
            ``parameters``).
        """
        mm = lambda lo_hi: [lo_hi[0] * 1e3, lo_hi[1] * 1e3]  # noqa: E731
        deg = lambda lo_hi: [math.degrees(lo_hi[0]), math.degrees(lo_hi[1])]  # noqa: E731
        x, y, yaw = self.sensor_pose
        out = {
            "wheel_diameter_left_mm": self.diameter_left_m * 1e3,
            "wheel_diameter_left_mm_ci95": mm(self.interval("diameter_left_m")),
            "wheel_diameter_right_mm": self.diameter_right_m * 1e3,
            "wheel_diameter_right_mm_ci95": mm(self.interval("diameter_right_m")),
            "wheelbase_mm": self.wheelbase_m * 1e3,
            "wheelbase_mm_ci95": mm(self.ci95["wheelbase_m"]),
            "Ed": self.ed,
            "Ed_ci95": list(self.interval("ed")),
            "Eb": self.eb,
            "Eb_ci95": list(self.interval("eb")),
            "sensor_pose": {
                "x_mm": x * 1e3,
                "x_mm_ci95": mm(self.ci95["sensor_x_m"]),
                "y_mm": y * 1e3,
                "y_mm_ci95": mm(self.ci95["sensor_y_m"]),
                "yaw_deg": math.degrees(yaw),
                "yaw_deg_ci95": deg(self.ci95["sensor_yaw_rad"]),
            },
            "intervals_used": int(self.intervals_used),
            "intervals_rejected": [int(i) for i in self.intervals_rejected],
            "warnings": list(self.warnings),
            "nominal_wheel_diameter_mm": self.nominal_wheel_diameter_m * 1e3,
            "nominal_wheelbase_mm": self.nominal_wheelbase_m * 1e3,
            "noise_sd": {
                "dx_mm": self.noise_sd[0] * 1e3,
                "dy_mm": self.noise_sd[1] * 1e3,
                "dyaw_deg": math.degrees(self.noise_sd[2]),
            },
            "noise_dof": self.noise_dof if math.isfinite(self.noise_dof) else None,
            "covariance_blocks": int(self.covariance_blocks),
            "wheel_jitter_ms": self.wheel_jitter_s * 1e3 if math.isfinite(self.wheel_jitter_s) else None,
            "parameters": list(PARAMETERS),
            "sd": [float(v) for v in self.sd],
            "covariance": [[float(v) for v in row] for row in self.covariance],
        }
        return out
