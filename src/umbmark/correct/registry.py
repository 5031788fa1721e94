"""The registry of correction methods: one typed interface per kind of data.

* Square methods (:class:`SquareMethod`, in :data:`METHODS`): a calibration from UMBmark
  square runs, ``fn(runs, side_m, wheelbase_m, prior=None, **options)`` returning a
  :class:`~umbmark.correct.result.CorrectionResult`. Called through :func:`correct_runs`;
  registered with :func:`register`. ``bf`` and ``exact``.
* Path methods (:class:`PathMethod`, in :data:`PATH_METHODS`): a wheel geometry from logs of
  any path with ground truth, ``fn(datasets, **options)`` returning a :class:`PathResult`.
  Called through :func:`correct_paths`; registered with :func:`register_path`. ``lsq``.

The modules that define the methods register them when imported; importing
:mod:`umbmark.correct` imports them all.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any, Protocol, TypeVar

from umbmark.errors import InputError

if TYPE_CHECKING:
    from umbmark.correct.result import CorrectionResult
    from umbmark.model.dataset import Dataset, WheelGeometry
    from umbmark.model.geometry import Calibration
    from umbmark.model.runs import RunsTable

__all__ = [
    "SquareMethod",
    "PathMethod",
    "PathResult",
    "METHODS",
    "PATH_METHODS",
    "register",
    "register_path",
    "correct_runs",
    "correct_paths",
]


class SquareMethod(Protocol):
    """A correction method for UMBmark square runs."""

    def __call__(
        self,
        runs: RunsTable,
        side_m: float,
        wheelbase_m: float,
        prior: Calibration | None = None,
        **options: Any,
    ) -> CorrectionResult:
        """Estimate a calibration.

        Parameters
        ----------
        runs : RunsTable
            The square runs (SI units).
        side_m : float
            Side of the square [m].
        wheelbase_m : float
            The wheelbase the odometry used during the runs [m].
        prior : Calibration or None
            The correction factors the robot ran with (``None``: none).
        **options
            The method's own keyword options.

        Returns
        -------
        CorrectionResult
            The calibration estimate.
        """
        ...


class PathResult(Protocol):
    """What a path method returns: the fitted geometry, the nominal one, and its figures."""

    @property
    def geometry(self) -> WheelGeometry:
        """The fitted wheel geometry."""
        ...

    @property
    def nominal(self) -> WheelGeometry:
        """The nominal geometry the fit is relative to."""
        ...

    def to_dict(self) -> dict[str, Any]:
        """The figures of the fit, JSON-ready."""
        ...


class PathMethod(Protocol):
    """A calibration method for logs of any path with ground truth."""

    def __call__(self, datasets: Dataset | Sequence[Dataset], **options: Any) -> PathResult:
        """Fit a geometry.

        Parameters
        ----------
        datasets : Dataset or sequence of Dataset
            Logs of the same robot, fitted jointly.
        **options
            The method's own keyword options.

        Returns
        -------
        PathResult
            The fitted geometry and figures.
        """
        ...


METHODS: dict[str, SquareMethod] = {}
PATH_METHODS: dict[str, PathMethod] = {}

S = TypeVar("S", bound=SquareMethod)
P = TypeVar("P", bound=PathMethod)


def register(name: str) -> Callable[[S], S]:
    """Decorator: register a square method under ``name``.

    Parameters
    ----------
    name : str
        The method's name (``method=`` of :func:`correct_runs`).

    Returns
    -------
    callable
        The decorator; it returns the function unchanged.
    """

    def deco(fn: S) -> S:
        METHODS[name] = fn
        return fn

    return deco


def register_path(name: str) -> Callable[[P], P]:
    """Decorator: register a path method under ``name``.

    Parameters
    ----------
    name : str
        The method's name (``method=`` of :func:`correct_paths`).

    Returns
    -------
    callable
        The decorator; it returns the function unchanged.
    """

    def deco(fn: P) -> P:
        PATH_METHODS[name] = fn
        return fn

    return deco


def _lookup(table: dict[str, Any], method: str) -> Any:
    try:
        return table[method]
    except KeyError:
        raise InputError(f"unknown method {method!r} (choose from {', '.join(sorted(table))})") from None


def correct_runs(
    method: str,
    runs: RunsTable,
    side_m: float,
    wheelbase_m: float,
    prior: Calibration | None = None,
    **options: Any,
) -> CorrectionResult:
    """Estimate a calibration from square runs with the named method.

    Parameters
    ----------
    method : str
        A registered square method (:data:`METHODS`): ``bf``, ``exact``.
    runs : RunsTable
        The square runs (SI units).
    side_m : float
        Side of the square [m].
    wheelbase_m : float
        The wheelbase the odometry used during the runs [m].
    prior : Calibration or None
        The correction factors the robot ran with (``None``: none).
    **options
        The method's keyword options.

    Returns
    -------
    CorrectionResult
        The calibration estimate.

    Raises
    ------
    InputError
        Unknown method, or invalid input or options.
    """
    fn: SquareMethod = _lookup(METHODS, method)
    return fn(runs, side_m, wheelbase_m, prior, **options)


def correct_paths(method: str, datasets: Dataset | Sequence[Dataset], **options: Any) -> PathResult:
    """Fit a geometry to logs of any path with the named path method.

    Parameters
    ----------
    method : str
        A registered path method (:data:`PATH_METHODS`): ``lsq``.
    datasets : Dataset or sequence of Dataset
        Logs of the same robot, fitted jointly.
    **options
        The method's keyword options.

    Returns
    -------
    PathResult
        The fitted geometry and figures.

    Raises
    ------
    InputError
        Unknown method, or invalid input or options.
    """
    fn: PathMethod = _lookup(PATH_METHODS, method)
    return fn(datasets, **options)
