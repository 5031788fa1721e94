"""Where the history is, and what may be shown of it: the default file
(:func:`default_db_path`), a file or a database URL given or in ``UMBMARK_DB``
(:func:`resolve_db`, :func:`resolve_db_path`, :func:`is_url`), an address that is neither refused
without repeating it (:func:`check_db_address`), and a URL's password and secret query values
masked in messages and records (:func:`display_db`, :func:`mask_secrets`).

Part of the history's shared code (:mod:`umbmark.history.base`, which re-exports these names).
Imports only the standard library and :mod:`umbmark.errors` (and SQLAlchemy's URL parser, when
installed, to show a URL).
"""

from __future__ import annotations

import os
import re
import sys
from pathlib import Path
from typing import Any

from umbmark.errors import InputError

__all__ = [
    "ENV_VAR",
    "default_db_path",
    "is_url",
    "check_db_address",
    "resolve_db",
    "display_db",
    "mask_secrets",
    "resolve_db_path",
]

ENV_VAR = "UMBMARK_DB"


def default_db_path() -> Path:
    """The per-user default location (without looking at ``UMBMARK_DB``).

    Returns
    -------
    Path
        ``$XDG_DATA_HOME/umbmark/history.sqlite`` (``~/.local/share`` by default),
        ``%LOCALAPPDATA%\\umbmark\\history.sqlite`` on Windows,
        ``~/Library/Application Support/umbmark/history.sqlite`` on macOS.
    """
    if sys.platform == "win32":
        base = Path(os.environ.get("LOCALAPPDATA") or Path.home() / "AppData" / "Local")
    elif sys.platform == "darwin":
        base = Path.home() / "Library" / "Application Support"
    else:
        xdg = os.environ.get("XDG_DATA_HOME")
        base = Path(xdg) if xdg and Path(xdg).is_absolute() else Path.home() / ".local" / "share"
    return base / "umbmark" / "history.sqlite"


def is_url(db: object) -> bool:
    """True for an SQLAlchemy database URL (``postgresql+psycopg://...``, ``sqlite:///...``).

    Parameters
    ----------
    db : object
        A database file, URL or anything else.

    Returns
    -------
    bool
    """
    return isinstance(db, str) and "://" in db


# a libpq connection string (``host=... user=... password=...``): not a file name, not a URL
_KEY_VALUE = re.compile(
    r"(^|\s)(host|hostaddr|port|dbname|user|password|passfile|sslmode|service|connect_timeout)\s*=", re.IGNORECASE
)


def check_db_address(db: str | Path) -> None:
    """Refuse a history address that is neither a file nor a URL, without repeating it.

    Parameters
    ----------
    db : str or Path
        The ``db`` given.

    Raises
    ------
    InputError
        A libpq key=value connection string (``host=h user=u password=p``), or a file name that
        holds ``password=``: taken as a file name it would create that file and print the
        password in every message.
    """
    s = str(db)
    if is_url(s):
        scheme, rest = s.split("://", 1)
        if scheme.lower().startswith("sqlite") and re.search(
            r"(^|&)(password|passwd|pwd)=", rest.partition("?")[2], re.I
        ):
            raise InputError(
                "an SQLite history has no password (the file is not encrypted): give the URL without it, and "
                "keep the file where only its users can read it; nothing was created"
            )
        return
    if re.match(r"^[^/@\s]*:[^/@\s]*@", s):
        raise InputError(
            "the history database looks like a URL without its scheme (USER:PASSWORD@HOST/DB): write "
            "postgresql+psycopg://USER@HOST/DB, the password in $PGPASSWORD or ~/.pgpass; nothing was created "
            "(the value is not repeated here: it holds a password)"
        )
    if _KEY_VALUE.search(s) or "password=" in s.lower():
        raise InputError(
            "the history database is a file or a URL (postgresql+psycopg://USER@HOST/DB, the password in "
            "$PGPASSWORD or ~/.pgpass), not a key=value connection string; nothing was created (the value "
            "is not repeated here: it holds a password or connection settings)"
        )


def resolve_db(db: str | Path | None = None) -> str | Path:
    """Where the history is: ``db`` if given, else ``$UMBMARK_DB``, else :func:`default_db_path`.

    Parameters
    ----------
    db : str or Path, optional
        A database file or URL.

    Returns
    -------
    str or Path
        A URL stays a string; a file becomes a :class:`Path` (``~`` expanded).
    """
    db = db or os.environ.get(ENV_VAR) or None
    if db is None:
        return default_db_path()
    check_db_address(db)
    if is_url(str(db)):
        return str(db)
    return Path(db).expanduser()


# query parameters of a database URL whose values are masked in messages and records
_SECRET_KEY = re.compile(r"pass|pwd|secret|token|key|auth|cred|sig", re.IGNORECASE)
_URL_IN_TEXT = re.compile(r"[A-Za-z][A-Za-z0-9+.-]*://[^\s'\"<>]+")


def _split_userinfo(rest: str) -> tuple[str | None, str | None, str]:
    """``user``, ``password`` and the remainder (host, path, query) of a URL after ``://``.

    The credentials end at the last ``@`` before the host: ``user:p@ss@host`` has the password
    ``p@ss``, and a ``?`` before any path is part of the password (``user:p?ss@host/db``), while
    an ``@`` in the query (``?user=a@b.org``) or in a path without a ``:`` before it is not a
    credential."""
    q = rest.find("?")
    at = rest.rfind("@", 0, q if q >= 0 else len(rest))
    if q >= 0 and "@" in rest[q:]:
        if "=" not in rest[q + 1 : rest.rfind("@")]:
            in_authority = True  # no query parameter before the last "@": the "?" is in the password
        elif at >= 0:
            in_authority = "/" not in rest[at + 1 : q]  # no path yet: the "?" is in the password
        else:
            head = rest[:q]
            in_authority = (
                ":" in head
                and not head.startswith("[")
                and "/" not in head.split(":", 1)[0]
                and re.match(r"[^:]*:\d+/", head) is None  # host:port/db?...: a real query
            )
        if in_authority:
            at = rest.rfind("@")
    if at < 0:
        return None, None, rest
    info = rest[:at]
    user, colon, pw = info.partition(":")
    if "/" in user:
        return None, None, rest  # a path with an "@" in it, not a user name
    return user, (pw if colon else None), rest[at + 1 :]


def _mask_query(query: str) -> str:
    parts = []
    for item in query.split("&"):
        k, eq, v = item.partition("=")
        parts.append(f"{k}=***" if eq and _SECRET_KEY.search(k) else item)
    return "&".join(parts)


def display_db(db: str | Path) -> str:
    """A database file or URL for messages and records: a URL's password and any query
    parameter named like one (``password``, ``passwd``, ``pwd``, ``secret``, ``token``, ...)
    are masked as ``***``.

    The URL is read with SQLAlchemy's parser (``make_url(...).render_as_string(hide_password=True)``)
    when SQLAlchemy is installed; the credentials are split off first at the last ``@`` before
    the host, so a password holding ``@`` (``user:p@ss@host``) is masked whole.

    Parameters
    ----------
    db : str or Path
        The database.

    Returns
    -------
    str
    """
    s = str(db)
    if "://" not in s:
        return s
    scheme, rest = s.split("://", 1)
    user, pw, tail = _split_userinfo(rest)
    where, qm, query = tail.partition("?")
    masked_query = _mask_query(query) if qm else ""
    info = "" if user is None else (user + (":***" if pw is not None else "") + "@")
    fallback = f"{scheme}://{info}{where}{qm}{masked_query}"
    if pw is None:
        return fallback  # nothing to mask but the query: the URL as it was written
    try:
        from sqlalchemy.engine import make_url
    except ImportError:
        return fallback
    try:
        u = make_url(f"{scheme}://{'' if user is None else user + (':x' if pw is not None else '') + '@'}{where}")
        text = u.render_as_string(hide_password=True)
    except Exception:  # noqa: BLE001  not a URL SQLAlchemy reads: the masked text as it is
        return fallback
    return text + (qm + masked_query if qm else "")


def mask_secrets(text: str) -> str:
    """Every URL in a text as :func:`display_db` shows it (passwords and secret query values
    masked).

    Parameters
    ----------
    text : str
        Any message.

    Returns
    -------
    str
    """
    s = str(text)
    if "://" not in s:
        return s

    def one(m: re.Match[str]) -> str:
        url = m.group(0)
        core = url.rstrip(".,:;)]}")
        return display_db(core) + url[len(core) :]

    return _URL_IN_TEXT.sub(one, s)


def _mask_obj(o: Any) -> Any:
    """``o`` with :func:`mask_secrets` applied to every string in it (dicts, lists)."""
    if isinstance(o, str):
        return mask_secrets(o) if "://" in o else o
    if isinstance(o, dict):
        return {k: _mask_obj(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [_mask_obj(v) for v in o]
    return o


def resolve_db_path(db: str | Path | None = None) -> Path:
    """Like :func:`resolve_db`, for a database file (not a URL).

    Parameters
    ----------
    db : str or Path, optional
        A database file.

    Returns
    -------
    Path

    Raises
    ------
    InputError
        If the database is a URL.
    """
    r = resolve_db(db)
    if isinstance(r, str):
        raise InputError(f"{display_db(r)!r} is a database URL, not a file")
    return r
