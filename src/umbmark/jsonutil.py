"""Strict JSON for umbmark's outputs: NaN and infinities become null, numpy values become
plain Python numbers and lists, paths become strings."""

from __future__ import annotations

import base64
import json
import math
from pathlib import PurePath

import numpy as np

__all__ = ["jsonable", "dumps", "encode_array", "decode_array"]


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


def encode_array(a, dtype: str) -> dict:
    """A numeric array as compact JSON: ``{"dtype", "shape", "base64"}``.

    The values are cast to ``dtype`` (a numpy type string such as ``"<f4"`` or ``"<i2"``,
    little-endian) and their bytes written in base64; :func:`decode_array` reads them back.

    Parameters
    ----------
    a : array_like
        The values.
    dtype : str
        The stored type.

    Returns
    -------
    dict
    """
    arr = np.ascontiguousarray(np.asarray(a), dtype=np.dtype(dtype))
    return {"dtype": dtype, "shape": list(arr.shape), "base64": base64.b64encode(arr.tobytes()).decode("ascii")}


def decode_array(d) -> np.ndarray:
    """The array of :func:`encode_array`.

    Parameters
    ----------
    d : dict
        ``{"dtype", "shape", "base64"}``.

    Returns
    -------
    numpy.ndarray

    Raises
    ------
    ValueError
        If ``d`` is not such an object, or its bytes do not fill its shape.
    """
    if not isinstance(d, dict) or not {"dtype", "shape", "base64"} <= d.keys():
        raise ValueError("not an encoded array (dtype, shape, base64)")
    dtype = np.dtype(str(d["dtype"]))
    if dtype.kind not in "iufb":
        raise ValueError(f"not a numeric type: {d['dtype']!r}")
    shape = tuple(int(n) for n in d["shape"])
    raw = base64.b64decode(str(d["base64"]), validate=True)
    if len(raw) != dtype.itemsize * math.prod(shape):
        raise ValueError(f"{len(raw)} bytes do not fill shape {shape} of {dtype.str}")
    return np.frombuffer(raw, dtype=dtype).reshape(shape).copy()
