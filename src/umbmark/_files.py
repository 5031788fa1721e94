"""Inputs by content: a file's or a folder's SHA-256, and inputs given twice.

Imports the standard library and :mod:`umbmark.errors`.
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Callable, Sequence
from pathlib import Path

from umbmark.errors import InputError

__all__ = ["check_distinct_inputs", "file_sha256", "inputs_sha256", "same_inputs"]

# the digests of the files and folders hashed in this process, by path and each file's size and
# modification time: a command that checks a recording against the history before it runs and
# records it after hashes it once
_DIGESTS: dict[tuple[str, tuple[tuple[str, int, int], ...]], str] = {}


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
    files = sorted(q for q in p.rglob("*") if q.is_file()) if p.is_dir() else [p]
    stats = tuple((str(f), f.stat().st_size, f.stat().st_mtime_ns) for f in files)
    key = (str(p.resolve()), stats)
    if key not in _DIGESTS:
        _DIGESTS[key] = _sha256(p)
    return _DIGESTS[key]


def inputs_sha256(paths: Sequence[str | Path], file_hash: Callable[[str], str] | None = None) -> str:
    """The content hash of the inputs of one result: one input's :func:`file_sha256`, or for
    several the SHA-256 of their hashes (one a line, in the order given).

    Parameters
    ----------
    paths : sequence of str or Path
        Files or folders that exist (at least one).
    file_hash : callable, optional
        The hash of one input (default :func:`file_sha256`).

    Returns
    -------
    str
        The hexadecimal digest.
    """
    shas = [(file_hash or file_sha256)(str(p)) for p in paths]
    if len(shas) == 1:
        return shas[0]
    return hashlib.sha256("\n".join(shas).encode()).hexdigest()


def _sha256(p: Path) -> str:
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


def check_distinct_inputs(paths: Sequence[str | Path]) -> None:
    """Refuse one recording given twice (the same bag by two paths, or two copies): pooled, its
    data would count twice and the 95 % intervals come out too narrow (``selfcal``, ``replay``).

    Parameters
    ----------
    paths : sequence of str or Path
        The inputs (files or folders that exist).

    Raises
    ------
    InputError
        Naming the first repeated input and the one it repeats.
    """
    same = same_inputs(paths)
    if same:
        first, again = same[0]
        raise InputError(
            f"{again} is the same recording as {first} (the same content): give each recording once (given "
            "twice, its data would count twice and the 95 % intervals come out too narrow)"
        )
