"""Strict JSON for umbmark's outputs: NaN and infinities become null, numpy values become
plain Python numbers and lists, paths become strings."""

from __future__ import annotations

import json
import math
from pathlib import PurePath

__all__ = ["jsonable", "dumps"]


def jsonable(o):
    """``o`` with every value JSON can hold as such (see the module docstring)."""
    if isinstance(o, float):
        return float(o) if math.isfinite(o) else None
    if isinstance(o, dict):
        return {str(k): jsonable(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [jsonable(v) for v in o]
    if hasattr(o, "tolist") and callable(o.tolist):  # numpy arrays and scalars
        return jsonable(o.tolist())
    if isinstance(o, PurePath):
        return str(o)
    return o


def dumps(o, **kw) -> str:
    """``json.dumps`` of :func:`jsonable` ``(o)``, refusing anything that is not strict JSON."""
    return json.dumps(jsonable(o), allow_nan=False, **kw)
