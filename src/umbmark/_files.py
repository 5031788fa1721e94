"""Inputs by content: a file's or a folder's SHA-256, and inputs given twice.

Imports only the standard library.
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Sequence
from pathlib import Path

__all__ = ["file_sha256", "same_inputs"]


def file_sha256(path) -> str:
    """SHA-256 of a file's bytes, or of a folder's files (sorted relative paths and contents).

    Parameters
    ----------
    path : str or Path
        A file or a folder.

    Returns
    -------
    str
        The hexadecimal digest.
    """
    p = Path(path)
    h = hashlib.sha256()
    if p.is_dir():
        for f in sorted(q for q in p.rglob("*") if q.is_file()):
            h.update(str(f.relative_to(p)).encode() + b"\0")
            with open(f, "rb") as fh:
                for chunk in iter(lambda: fh.read(1 << 20), b""):
                    h.update(chunk)
        return h.hexdigest()
    with open(p, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def _size(p: Path) -> int:
    if p.is_dir():
        return sum(q.stat().st_size for q in p.rglob("*") if q.is_file())
    return p.stat().st_size


def same_inputs(paths: Sequence[str | Path]) -> list[tuple[str, str]]:
    """The pairs of inputs that are one recording: the same file or folder by two paths, or two
    copies with the same content (hashed only where the sizes are equal).

    Parameters
    ----------
    paths : sequence of str or Path
        Files or folders that exist.

    Returns
    -------
    list of (str, str)
        Each later input with the first one it repeats, in the order given.
    """
    seen: list[tuple[str, Path, int]] = []  # (as given, path, size) of each first occurrence
    digests: dict[Path, str] = {}

    def digest(p: Path) -> str:
        if p not in digests:
            digests[p] = file_sha256(p)
        return digests[p]

    out = []
    for raw in paths:
        p = Path(raw)
        size = _size(p)
        for given, first, first_size in seen:
            if os.path.samefile(first, p) or (size == first_size and digest(first) == digest(p)):
                out.append((given, str(raw)))
                break
        else:
            seen.append((str(raw), p, size))
    return out
