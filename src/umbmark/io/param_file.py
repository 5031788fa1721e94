"""A ROS parameter file of the robot's own software with some of its values changed, every other
line kept (F1TENTH's and MuSHR's ``vesc.yaml`` with its gains calibrated).

A parameter file is YAML: ROS 2's ``NODE: ros__parameters: {...}`` (``NODE`` a node's name or a
wildcard such as ``/**``, inside namespaces too) or ROS 1's mapping of names to values (MuSHR's
``vesc.yaml``: the gains at the top, the driver's own in ``vesc_driver``). Its
**blocks** are the mappings that hold parameters (:func:`parameter_blocks`); every block that
holds one of the values asked for must hold them all, each a number.

The new file is the old one with each changed value's text replaced in its line (the key, the
comments, the order and every other line as they were) and a comment on top saying what changed;
it is parsed again and compared with what it must hold. Where the values cannot be found in their
lines one by one (a key written twice in a block's flow mapping, quoted keys), the file is written
anew from its data (every key and value kept, the comments not) and the comment on top says so.

Imports pyyaml (when a file is edited) and :mod:`umbmark.errors`.
"""

from __future__ import annotations

import copy
import math
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from umbmark.errors import InputError

__all__ = ["ParameterEdit", "parameter_blocks", "edit_parameter_file", "number_text"]

_ROS2 = "ros__parameters"


@dataclass(frozen=True)
class ParameterEdit:
    """One value changed in a parameter file.

    Attributes
    ----------
    block : str
        The block it is in (``/**``, ``vesc_to_odom_node``; ``""`` for a ROS 1 file).
    key : str
    old, new : float
    """

    block: str
    key: str
    old: float
    new: float


def parameter_blocks(data: Any) -> list[tuple[str, dict]]:
    """The mappings of a parameter file that hold parameters, in the file's order, with their names.

    Parameters
    ----------
    data : any
        The file's YAML.

    Returns
    -------
    list of (str, dict)
        ROS 2: each ``ros__parameters`` mapping with the path of its node (``/**``,
        ``ns/node``); a file without any (ROS 1): the whole mapping (named ``""``) and every
        mapping in it (named by its namespace, ``vesc_driver``).
    """
    ros2: list[tuple[str, dict]] = []
    every: list[tuple[str, dict]] = []

    def walk(d: dict, path: tuple[str, ...]) -> None:
        every.append(("/".join(path), d))
        for k, v in d.items():
            if k == _ROS2 and isinstance(v, dict):
                ros2.append(("/".join(path), v))
            elif isinstance(v, dict):
                walk(v, (*path, str(k)))

    if isinstance(data, dict):
        walk(data, ())
    return ros2 or every


def number_text(v: float) -> str:
    """A float as a parameter file writes it: nine significant digits, a decimal point always (a
    ROS 2 double stays a double), never an exponent."""
    text = np.format_float_positional(float(v), precision=9, unique=False, fractional=False, trim="0")
    return text if "." in text else text + ".0"


def _key_line(key: str) -> re.Pattern[str]:
    return re.compile(rf"(?:^|(?<=[\s{{,]))({re.escape(key)})(\s*:\s*)([^\s,#}}\]]+)")


def _code_end(line: str) -> int:
    """Where a line's comment starts (its length without one): a ``#`` at its start or after a blank."""
    m = re.search(r"(?:^|\s)#", line)
    return len(line) if m is None else m.start()


def _replace_in_lines(text: str, edits: Sequence[ParameterEdit]) -> str | None:
    """The text with each edit's value replaced in its line, the edits of a key in the order of the
    file's blocks; None when a key's lines are not one per block that holds it."""
    lines = text.splitlines(keepends=True)
    for key in dict.fromkeys(e.key for e in edits):
        mine = [e for e in edits if e.key == key]
        pat = _key_line(key)
        spots = [(i, m) for i, line in enumerate(lines) for m in pat.finditer(line[: _code_end(line)])]
        if len(spots) != len(mine):
            return None
        for (i, m), e in sorted(zip(spots, mine), key=lambda s: (s[0][0], -s[0][1].start())):
            line = lines[i]
            lines[i] = line[: m.start(3)] + number_text(e.new) + line[m.end(3) :]
    return "".join(lines)


def edit_parameter_file(
    text: str,
    source: str,
    keys: Sequence[str],
    compute: Callable[[Mapping[str, float]], Mapping[str, float]],
    what: str,
    header: str,
) -> tuple[str, list[ParameterEdit]]:
    """A parameter file with the values of ``keys`` changed in every block that holds them.

    Parameters
    ----------
    text : str
        The file's text.
    source : str
        Its name, for messages.
    keys : sequence of str
        The values in use each block that holds one of them must hold (numbers).
    compute : callable
        ``compute(in_use)`` -> the new values (some of ``keys``) from a block's values in use; it
        raises :class:`~umbmark.errors.InputError` naming a value it cannot use.
    what : str
        What the file is, for the message of a file without the keys.
    header : str
        The comment's words on top of the new file (what changed them).

    Returns
    -------
    tuple
        ``(new_text, edits)``.

    Raises
    ------
    InputError
        Not YAML or not a mapping; no block with the keys; a block without one of them or with one
        that is not a number; what ``compute`` refuses (the block named).
    """
    import yaml

    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        line = None if mark is None else mark.line + 1
        raise InputError(f"not a YAML parameter file: {getattr(e, 'problem', None) or e}", source, line) from None
    blocks = [(name, b) for name, b in parameter_blocks(data) if any(k in b for k in keys)]
    if not blocks:
        raise InputError(f"no {', '.join(keys)} in its parameters: not {what}", source)
    new_data = copy.deepcopy(data)
    new_blocks = dict(parameter_blocks(new_data))
    edits: list[ParameterEdit] = []
    for name, block in blocks:
        where = f" ({name}'s parameters)" if name else ""
        in_use = {}
        for k in keys:
            v = block.get(k)
            if k not in block:
                raise InputError(f"`{k}` missing{where}: the value in use is needed", source)
            number = _number(v)
            if number is None:
                raise InputError(f"`{k}`{where} must be a number, got {v!r}", source)
            in_use[k] = number
        try:
            new = compute(in_use)
        except InputError as err:
            raise InputError(f"{err.message}{where}", source) from None
        for k, v in new.items():
            edits.append(ParameterEdit(name, k, in_use[k], float(v)))
            new_blocks[name][k] = float(v)
    lines = [f"# {header}"] + [
        f"#   {e.key}{f' ({e.block})' if e.block else ''}: {number_text(e.old)} -> {number_text(e.new)}" for e in edits
    ]
    kept = _replace_in_lines(text, edits)
    if kept is not None and _same(yaml.safe_load(kept), new_data):
        return "\n".join(lines) + "\n" + kept, edits
    lines.append(f"# written anew from {source}'s values (its comments could not be kept)")
    dumped = yaml.safe_dump(new_data, sort_keys=False, default_flow_style=False, allow_unicode=True)
    return "\n".join(lines) + "\n" + dumped, edits


_FLOAT = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")


def _number(v: Any) -> float | None:
    """A parameter's value as a finite number (a float YAML 1.1 reads as text, ``4.6e3``, too), else None."""
    if isinstance(v, str) and _FLOAT.fullmatch(v.strip()):
        v = float(v)
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        return None
    return float(v)


def _same(a: Any, b: Any) -> bool:
    """Equal data, floats to the digits :func:`number_text` writes."""
    if isinstance(a, dict) and isinstance(b, dict):
        return list(a) == list(b) and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    if isinstance(a, float) and isinstance(b, float):
        return a == b or abs(a - b) <= 1e-8 * max(abs(a), abs(b))
    return type(a) is type(b) and a == b
