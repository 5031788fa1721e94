"""Library errors. The library raises; the CLI turns these into one-line messages (exit 2)."""

from __future__ import annotations


class UmbmarkError(Exception):
    """Base class of every error umbmark reports to a user."""


class InputError(UmbmarkError, ValueError):
    """Bad input: a file, a value or a geometry the computation cannot accept.

    ``source`` (a file name) and ``line`` (1-based) locate the problem when it is in a file;
    ``data`` are the strings of the user's data the message quotes (robot names, paths), which a
    front end prints as stored.
    """

    def __init__(self, message: str, source: str | None = None, line: int | None = None, data=()):
        self.message = message
        self.source = source
        self.line = line
        self.data = tuple(str(d) for d in data)
        super().__init__(str(self))

    def __str__(self) -> str:
        where = ""
        if self.source is not None:
            where = f"{self.source}:{self.line}: " if self.line is not None else f"{self.source}: "
        return where + self.message


class CorrectionUndefined(InputError):
    """The correction formulas have no answer for these inputs (e.g. |sin(beta/2)| * b >= L)."""
