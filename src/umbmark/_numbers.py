"""Numbers from text, as a user means them.

Python's ``float`` reads ``1_0`` as 10 (underscores group digits in Python source); in a
command-line value or a data file an underscore is a typo or a thousands separator, so it is
not a number here. Every reader of numbers typed by a person parses with :func:`strict_float`.
"""

from __future__ import annotations

__all__ = ["strict_float"]


def strict_float(text: str) -> float:
    """The number ``text`` holds (surrounding white space allowed), as ``float`` but without ``_``.

    Parameters
    ----------
    text : str
        The text.

    Returns
    -------
    float
        Possibly NaN or infinite, as ``float`` reads ``nan`` and ``inf``: the callers check.

    Raises
    ------
    ValueError
        Not a number, or one with an underscore.
    """
    if "_" in text:
        raise ValueError(f"{text!r}: '_' is not a digit")
    return float(text)
