"""numba, the optional compiler of the hot loops, imported on first use and then remembered.

Importing this module imports nothing: ``import umbmark`` stays light. The modules with compiled
kernels (:mod:`umbmark.model.batch`, :mod:`umbmark.model.sensors`,
:mod:`umbmark.realrobot.scanmatch`) ask :func:`numba_module` when they first compile.
"""

from __future__ import annotations

from types import ModuleType

__all__ = ["numba_module", "have_numba", "ENGINES", "check_engine"]

ENGINES = ("auto", "numba", "numpy")
"""The engines of the compiled loops: ``numba`` (compiled), ``numpy`` (vectorised), ``auto``
(numba where it is installed)."""

_MODULE: list[ModuleType | None] = []  # empty until the first question


def numba_module() -> ModuleType | None:
    """The numba module, or None where it is not installed (imported on the first call).

    Returns
    -------
    module or None
    """
    if not _MODULE:
        try:  # optional dependency
            import numba
        except ImportError:  # pragma: no cover - depends on the environment
            _MODULE.append(None)
        else:
            _MODULE.append(numba)
    return _MODULE[0]


def have_numba() -> bool:
    """Whether numba is installed (imports it on the first call).

    Returns
    -------
    bool
    """
    return numba_module() is not None


def check_engine(engine: str) -> None:
    """Refuse an engine not in :data:`ENGINES`.

    Raises
    ------
    umbmark.errors.InputError
        An unknown engine.
    """
    if engine not in ENGINES:
        from umbmark.errors import InputError

        raise InputError(f"unknown engine {engine!r} (choose from {', '.join(ENGINES)})")
