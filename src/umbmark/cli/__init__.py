"""Command-line interface: thin (parse, call the library, print). Errors become one line on
stderr with exit status 2; no traceback for bad input."""

from __future__ import annotations

import errno
import io
import os
import re
import secrets
import shutil
import signal
import sys
import tempfile
import threading
from collections.abc import Callable, Sequence
from pathlib import Path
from types import FrameType
from typing import Any

import click

# Each module registers its subcommands on ``app``.
from umbmark.cli import (
    bag_info,  # noqa: F401,E402  bag-info
    bench,  # noqa: F401,E402  bench (group)
    bench_accuracy,  # noqa: F401,E402  bench accuracy
    bench_speed,  # noqa: F401,E402  bench speed
    calibrate,  # noqa: F401,E402  calibrate
    convert,  # noqa: F401,E402  convert
    core,  # noqa: F401,E402  simulate, analyze, demo
    drift,  # noqa: F401,E402  drift
    export,  # noqa: F401,E402  export
    field,  # noqa: F401,E402  guide, measure
    fleet,  # noqa: F401,E402  fleet
    history,  # noqa: F401,E402  history
    replay,  # noqa: F401,E402  replay
    report,  # noqa: F401,E402  report
    reproduce,  # noqa: F401,E402  reproduce
    selfcal,  # noqa: F401,E402  selfcal
    validate,  # noqa: F401,E402  validate
)
from umbmark.cli.app import app, cli_message, keep_as_given
from umbmark.errors import UmbmarkError

__all__ = ["app", "main"]


_LONG_DIGITS = re.compile(r"\d{40,}")


def _one_line(text: str) -> str:
    """The message on one line; a number of thousands of digits echoed from the input shown by
    its first digits and its length."""
    text = _LONG_DIGITS.sub(lambda m: f"{m.group(0)[:12]}...({len(m.group(0))} digits)", str(text))
    return " ".join(text.split())


def _os_error(e: OSError, process: bool) -> str:
    """The one line of a system error: the file it names, else the standard output a write
    without a file name goes to (a full disk behind ``> out.json``); ``process``: the console
    script, whose standard output is then closed."""
    why = _one_line(e.strerror or str(e))
    if getattr(e, "filename", None):
        return f"cannot access {e.filename}: {why}"
    if e.errno in (errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EIO, errno.EBADF):
        if process:
            _silence_stdout()
        return f"cannot write the standard output: {why}"
    return f"system error: {why}"


class _ClosedStream(io.TextIOBase):
    """The standard output or error of a process started with it closed (``>&-``): Python leaves
    ``sys.stdout`` None; writing to this one raises the error a closed file gives, reported in
    one line like a full disk's (a command that prints nothing runs as usual)."""

    def __init__(self, name: str) -> None:
        super().__init__()
        self.name = name

    def writable(self) -> bool:
        return True

    def write(self, s: str) -> int:
        if s:
            raise OSError(errno.EBADF, "it is closed (>&-): give it a file, or /dev/null")
        return 0


def _open_streams() -> None:
    """Stand-ins for a closed standard output (see :class:`_ClosedStream`) and error (where no
    message can go: dropped)."""
    if sys.stdout is None:
        sys.stdout = _ClosedStream("standard output")
    if sys.stderr is None:
        sys.stderr = io.StringIO()


def _silence_stdout() -> None:
    """Drop what is left in the standard output's buffer (it cannot be written: the interpreter
    would report it again at exit)."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError, AttributeError):
        pass


def _printable_streams() -> None:
    """Standard output and error that print any text: a character the terminal's encoding lacks
    (a robot named in Unicode under ``PYTHONIOENCODING=ascii`` or ``LANG=C``) is written as its
    ``\\x``/``\\u`` escape instead of failing."""
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.reconfigure(errors="backslashreplace")  # type: ignore[union-attr]
        except (AttributeError, ValueError, OSError):
            pass


def _matplotlib_cache() -> Path:
    """The folder matplotlib keeps its font cache in when ``MPLCONFIGDIR`` is not set."""
    if sys.platform.startswith(("linux", "freebsd")):
        return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "matplotlib"
    return Path.home() / ".matplotlib"


def _private_matplotlib_dir() -> str | None:
    """Point ``MPLCONFIGDIR`` at a folder of this run's own (made by matplotlib only if it plots,
    removed at the end) unless the user chose one or matplotlib's cache exists already: a plot
    creates no cache outside the outputs (its font scan, about half a second, is done again at
    each plotting run). The folder, or None."""
    if os.environ.get("MPLCONFIGDIR"):
        return None
    try:
        if _matplotlib_cache().exists():
            return None
    except (RuntimeError, OSError):  # no home folder
        pass
    folder = os.path.join(tempfile.gettempdir(), f"umbmark-matplotlib-{os.getpid()}-{secrets.token_hex(4)}")
    os.environ["MPLCONFIGDIR"] = folder
    return folder


def _drop_private_dir(folder: str | None) -> None:
    if folder is None:
        return
    if os.environ.get("MPLCONFIGDIR") == folder:
        del os.environ["MPLCONFIGDIR"]
    shutil.rmtree(folder, ignore_errors=True)


class _Terminated(BaseException):
    """SIGTERM: unwinds like Ctrl-C, so every write in progress removes its temporary file."""


def _on_sigterm(signum: int, frame: FrameType | None) -> None:
    raise _Terminated()


def _catch_sigterm() -> Callable[[int, FrameType | None], Any] | int | None:
    """Install the SIGTERM handler (main thread only); the handler it replaces, or None."""
    if threading.current_thread() is not threading.main_thread():
        return None
    try:
        return signal.signal(signal.SIGTERM, _on_sigterm)
    except (ValueError, OSError):
        return None


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``umbmark`` console script.

    Parameters
    ----------
    argv : list of str, optional
        The arguments (default: ``sys.argv[1:]``, and the process exits with the status).

    Returns
    -------
    int
        The exit status: 0, 1 (aborted), 2 (an error, reported in one line on stderr) or 143
        (terminated by SIGTERM; the temporary files of the writes in progress removed).
    """
    args = sys.argv[1:] if argv is None else list(argv)
    prog = "umbmark"
    keep_as_given(args, reset=True)
    _open_streams()
    _printable_streams()
    previous = _catch_sigterm()
    mpl_dir = _private_matplotlib_dir()
    try:
        rv = app.main(args=args, prog_name=prog, standalone_mode=False)
        code = rv if isinstance(rv, int) else 0
        sys.stdout.flush()  # a full disk or a closed pipe behind stdout: reported here
    except click.exceptions.Exit as e:
        code = e.exit_code
    except click.exceptions.Abort:
        sys.stderr.write(f"{prog}: aborted\n")
        code = 1
    except _Terminated:
        sys.stderr.write(f"{prog}: terminated (SIGTERM); no output file was left half-written\n")
        code = 143
    except click.exceptions.ClickException as e:
        ctx = getattr(e, "ctx", None)
        where = ctx.command_path if ctx is not None else prog
        sys.stderr.write(f"{where}: error: {_one_line(e.format_message())}\n")
        code = 2
    except UmbmarkError as e:
        keep_as_given([str(getattr(e, "source", None) or ""), *getattr(e, "data", ())])
        sys.stderr.write(f"{prog}: error: {_one_line(cli_message(str(e)))}\n")
        code = 2
    except OSError as e:
        if isinstance(e, BrokenPipeError):
            return 0
        sys.stderr.write(f"{prog}: error: {_os_error(e, argv is None)}\n")
        code = 2
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)
        _drop_private_dir(mpl_dir)
    if argv is None:
        sys.exit(code)
    return code
