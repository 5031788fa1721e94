"""Write output files whole or not at all."""

from __future__ import annotations

import errno
import os
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from umbmark.errors import InputError
from umbmark.jsonutil import dumps

__all__ = ["atomic_write", "atomic_path", "remove_stale_temporaries", "write_json"]


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


# the errors of a write that the system reports without a file name (at a write or a close)
_WRITE_ERRNOS = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EIO, errno.EROFS})

# the temporary file of a write to NAME is .NAME.umbmark-tmp.PID.RANDOM.SUFFIX beside it
_TEMP_TAG = ".umbmark-tmp."


def _temp_prefix(path: Path) -> str:
    return f".{path.name}{_TEMP_TAG}"


def _alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OSError):
        return True  # another user's process, or no way to tell: keep its file
    return True


def remove_stale_temporaries(path: str | Path) -> list[Path]:
    """Remove the temporary files that writers of ``path`` killed on this machine left beside it.

    A write makes ``.NAME.umbmark-tmp.PID.RANDOM.SUFFIX`` beside ``NAME`` and renames it over
    ``NAME`` when done; a writer killed before (SIGKILL, power loss) leaves it. Those of a
    process that no longer runs are removed; those of a running process (another write of the
    same file at the same moment) are kept.

    Parameters
    ----------
    path : str or Path
        The file written.

    Returns
    -------
    list of Path
        The files removed.
    """
    path = Path(path)
    parent = path.parent if str(path.parent) else Path(".")
    prefix = _temp_prefix(path)
    removed: list[Path] = []
    try:
        entries = list(os.scandir(parent))
    except OSError:
        return removed
    for e in entries:
        if not e.name.startswith(prefix):
            continue
        pid_text = e.name[len(prefix) :].split(".", 1)[0]
        if not pid_text.isdigit() or _alive(int(pid_text)):
            continue
        try:
            if e.is_file(follow_symlinks=False):
                os.unlink(e.path)
                removed.append(Path(e.path))
        except OSError:
            pass
    return removed


@contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """A temporary path beside ``path`` that replaces ``path`` only if the block succeeds.

    A symbolic link is written through (its target is replaced, the link stays); a special
    file that exists (``/dev/stdout``, a named pipe) gets the finished content written into it.
    The temporary files killed writers of ``path`` left are removed first (see
    :func:`remove_stale_temporaries`).

    Parameters
    ----------
    path : str or Path
        The file to write.

    Yields
    ------
    Path
        The temporary file to write to.

    Raises
    ------
    InputError
        No file name, a folder, or a folder that does not exist.
    """
    if not str(path):
        raise InputError("cannot write '': no file name given")
    path = Path(path)
    if path.is_dir():
        raise InputError(f"cannot write {path}: it is a folder")
    if path.exists() and not path.is_file():
        with _special(path) as scratch:
            yield scratch
        return
    if path.is_symlink():
        path = Path(os.path.realpath(path))
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise InputError(f"cannot write {path}: folder {parent} does not exist")
    remove_stale_temporaries(path)
    try:
        fd, tmp = tempfile.mkstemp(
            prefix=_temp_prefix(path) + f"{os.getpid()}.", suffix=path.suffix or ".tmp", dir=parent
        )
    except OSError as e:  # the user's file, not the temporary one beside it
        raise InputError(f"cannot write {path}: {e.strerror or e} (folder {parent})") from None
    os.close(fd)
    os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes 0600; give the file ordinary permissions
    try:
        yield Path(tmp)
        try:
            os.replace(tmp, path)
        except OSError as e:
            raise InputError(f"cannot write {path}: {e.strerror or e}") from None
    except BaseException as e:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        if isinstance(e, OSError) and (
            str(e.filename) == str(tmp) or (e.filename is None and e.errno in _WRITE_ERRNOS)
        ):  # the user's file, not the temporary's name, nor no name at all (a full disk)
            raise InputError(f"cannot write {path}: {e.strerror or e}") from None
        raise


@contextmanager
def _special(path: Path) -> Iterator[Path]:
    """The content is made in a temporary file, then written into ``path`` (a device or pipe:
    it cannot be renamed over, and a failed write, e.g. /dev/full, is an OSError)."""
    scratch = Path(tempfile.gettempdir()) / path.name
    remove_stale_temporaries(scratch)
    fd, tmp = tempfile.mkstemp(prefix=_temp_prefix(scratch) + f"{os.getpid()}.", suffix=path.suffix or ".tmp")
    os.close(fd)
    try:
        yield Path(tmp)
        try:
            with open(tmp, "rb") as src, open(path, "wb") as dst:
                while chunk := src.read(1 << 20):
                    dst.write(chunk)
        except OSError as e:
            raise OSError(e.errno, e.strerror, str(path)) from None
    finally:
        os.unlink(tmp)


def atomic_write(path: str | Path, text: str | bytes) -> None:
    """Write a file whole or not at all (a temporary file beside it, then renamed over it).

    Parameters
    ----------
    path : str or Path
        The file to write (see :func:`atomic_path` for links and special files).
    text : str or bytes
        The content (text is written as UTF-8).

    Raises
    ------
    InputError
        No file name, a folder, or a folder that does not exist.
    """
    with atomic_path(path) as tmp:
        if isinstance(text, bytes):
            tmp.write_bytes(text)
        else:
            tmp.write_text(text, encoding="utf-8")


def write_json(path: str | Path, obj: object) -> None:
    """Write a JSON document (indented by two spaces, one final newline), atomically.

    Parameters
    ----------
    path : str or Path
        The file to write.
    obj
        A JSON-ready object (NaN and infinities are written as null: see :func:`umbmark.jsonutil.dumps`).
    """
    atomic_write(path, dumps(obj, indent=2) + "\n")
