"""The checks every command runs on its parsed options before it reads or writes anything.

* **Outputs never replace inputs.** :data:`PATH_ROLES` classifies every path-like parameter of
  every command: an ``input`` (a file or folder the command reads), an ``output`` file, an
  ``output_dir`` (a folder the command writes into), the history ``db`` (read and written), or
  ``name`` (not a path). Before the command runs, each output is compared with every input,
  every other output and the history database (:func:`os.path.samefile` where both exist, else
  the resolved paths); an output inside an input folder is refused too. tests/test_outputs_guard.py
  enumerates the commands and fails on a path parameter missing from the registry.
* **Sizes are sizes.** A float option in millimetres or metres (``--*-mm``, ``--*-m``) beyond
  :data:`MAX_SIZE_M` (a thousand kilometres: ``--wheel-diameter-mm 1e308``) is refused in one
  line before the command runs, except the square's side and the tape's resolution, which the
  commands check against tighter limits. NaN and infinities are left to the commands' own
  checks; a failure such a value causes deep in the numbers that those miss is reported as
  that option, in one line, not a traceback.
* **Wheels and wheelbases are a robot's.** A wheel diameter or radius, a wheelbase, wheel
  separation or mecanum ``lx + ly`` option outside what a robot can have
  (:func:`umbmark.model.geometry.unit_slip`) is refused in one line naming the likely unit slip
  (``--wheel-diameter-mm 0.15``: given in metres?) before the command reads any data, so no
  advice about the driving follows.
* **A file whose name starts with a dash** (``-x.csv``) is read by click as options: the
  error says to write ``./-x.csv`` or to put ``--`` before it.
"""

from __future__ import annotations

import math
import os
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

import click

from umbmark.errors import UmbmarkError
from umbmark.model.geometry import Quantity, unit_slip

if TYPE_CHECKING:
    from umbmark.kinds import Size

F = TypeVar("F", bound=Callable[..., Any])

__all__ = ["MAX_SIZE_M", "PATH_ROLES", "ROLES", "GuardedCommand", "GuardedGroup", "check_paths", "path_roles"]

ROLES = ("input", "output", "output_dir", "db", "name")

# command path -> parameter name -> role (see the module docstring)
PATH_ROLES: dict[str, dict[str, str]] = {
    "analyze": {"runs_file": "input", "plot_path": "output", "db": "db"},
    "bag-info": {"bag": "input"},
    "bench accuracy": {"out_dir": "output_dir"},
    "bench speed": {"out_dir": "output_dir"},
    "calibrate": {"runs_files": "input", "save_runs": "output_dir", "db": "db"},
    "convert": {"paths": "input", "out": "output", "time_offset": "name"},
    "demo": {"out_dir": "output_dir"},
    "export": {"calibration": "input", "dataset": "name", "out": "output", "db": "db", "vesc_config": "input"},
    "history": {"robot": "name", "db": "db", "plot_path": "output", "export_path": "output"},
    "drift": {"robot": "name", "db": "db", "plot_path": "output", "parameters": "name", "kind": "name"},
    "fleet": {"source": "input", "db": "db"},
    "measure": {"distances_file": "input", "out_path": "output"},
    "replay": {
        "paths": "input",
        "sensor_pose": "input",  # X,Y,YAW or a selfcal JSON
        "save": "output",
        "poses_out": "output",
        "db": "db",
        "time_offset": "name",
        "window": "name",
        "imu_topic": "name",
        "config": "input",
        "write_config": "output",
    },
    "report": {
        "runs_file": "input",
        "after_file": "input",
        "attach": "input",
        "out_path": "output",
        "db": "db",
        "method": "name",
        "robot": "name",
    },
    "reproduce": {"report_dir": "output_dir"},
    "simulate": {"out": "output"},
    "selfcal": {
        "paths": "input",
        "save": "output",
        "intervals_out": "output",
        "db": "db",
        "scan_delay": "name",
        "window": "name",
        "config": "input",
        "write_config": "output",
    },
    "validate": {
        "log": "input",
        "calibration": "input",
        "relations": "input",
        "reference": "input",
        "dataset": "name",
        "config": "input",
        "write_config": "output",
    },
}

# a size option beyond this (a thousand kilometres) is not the size of a robot, a wheel or a test track
MAX_SIZE_M = 1e6
# size options the commands check against their own, tighter, limits (with their own messages)
_OWN_SIZE_CHECKS = ("side_mm", "resolution_mm")
# the words that make a size option a wheel's size or the wheelbase (checked by unit_slip); a
# kind's own sizes (a mecanum robot's lx + ly) are found by their option (umbmark.kinds)
_GEOMETRY_WORDS = {
    "diameter": ("diameter",),
    "radius": ("radius",),
    "wheelbase": ("wheelbase", "separation"),
}


def path_roles(command_path: str) -> dict[str, str]:
    """The roles of a command's path parameters (see :data:`PATH_ROLES`).

    Parameters
    ----------
    command_path : str
        The command's name after ``umbmark`` (``"replay"``, ``"bench speed"``).

    Returns
    -------
    dict
        Parameter name -> role; empty for a command without path parameters.
    """
    return PATH_ROLES.get(command_path, {})


def _values(v: object) -> list[str]:
    if v is None:
        return []
    if isinstance(v, (list, tuple)):
        return [str(x) for x in v if x is not None and str(x) not in ("", "-")]
    s = str(v)
    return [] if s in ("", "-") else [s]


def _same(a: str, b: str) -> bool:
    """True when the paths name one file (hard and symbolic links included)."""
    try:
        return os.path.samefile(a, b)
    except OSError:
        pass
    try:
        return Path(a).resolve() == Path(b).resolve()
    except (OSError, RuntimeError):
        return os.path.abspath(a) == os.path.abspath(b)


def _inside(path: str, folder: str) -> bool:
    try:
        p, f = Path(path).resolve(), Path(folder).resolve()
    except (OSError, RuntimeError):
        return False
    return f in p.parents


def _special(path: str) -> bool:
    """A device or pipe (``/dev/stdout``): written into, never replaced."""
    try:
        return os.path.exists(path) and not os.path.isfile(path) and not os.path.isdir(path)
    except OSError:
        return False


def _db_file(value: str | None, outputs: list[str]) -> str | None:
    """The history database file a command uses (``--db``, else ``$UMBMARK_DB``, else the
    default file; None for a database URL). The default is looked up only when an output is
    called like it (the lookup imports the history package)."""
    v = value or os.environ.get("UMBMARK_DB") or None
    if v is None:
        if not any(Path(o).name == "history.sqlite" for o in outputs):
            return None
        from umbmark.history.base import default_db_path

        return str(default_db_path())
    v = str(v)
    if v.startswith("sqlite:///"):
        return v[len("sqlite:///") :] or None
    if "://" in v or v.startswith("sqlite:"):
        return None  # another database server, or SQLite in memory
    return os.path.expanduser(v)


def check_paths(command_path: str, params: dict, flags: dict[str, str] | None = None) -> None:
    """Refuse a command line whose outputs would replace an input, the history or each other.

    Parameters
    ----------
    command_path : str
        The command's name after ``umbmark``.
    params : dict
        Its parsed parameters (click's ``ctx.params``).
    flags : dict, optional
        Parameter name -> how to name it in the message (``--out``); default: the name.

    Raises
    ------
    click.UsageError
        An output that is an input, the history database, another output, or inside an input
        folder.
    """
    roles = path_roles(command_path)
    flags = flags or {}

    def name(k: str) -> str:
        return flags.get(k, k)

    inputs = [(k, v) for k, r in roles.items() if r == "input" for v in _values(params.get(k))]
    outputs = [(k, v) for k, r in roles.items() if r == "output" for v in _values(params.get(k))]
    outputs = [(k, v) for k, v in outputs if not _special(v)]
    out_dirs = [(k, v) for k, r in roles.items() if r == "output_dir" for v in _values(params.get(k))]
    if not outputs and not out_dirs:
        return
    for k, out in outputs:
        for ki, inp in inputs:
            if _same(out, inp):
                raise click.UsageError(
                    f"{name(k)} {out} is the input {inp} ({name(ki)}): writing it would replace the input; "
                    "choose another file"
                )
            if os.path.isdir(inp) and _inside(out, inp):
                raise click.UsageError(
                    f"{name(k)} {out} is inside the input folder {inp} ({name(ki)}): write it outside the folder"
                )
    for i, (k, out) in enumerate(outputs):
        for k2, out2 in outputs[i + 1 :]:
            if _same(out, out2):
                raise click.UsageError(f"{name(k)} and {name(k2)} are the same file {out}: give each its own file")
    for k, d in out_dirs:
        for ki, inp in inputs:
            if _same(d, inp):
                raise click.UsageError(f"{name(k)} {d} is the input {inp} ({name(ki)}): choose another folder")
    dbs = [k for k, r in roles.items() if r == "db"]
    if dbs and outputs:
        db = _db_file(params.get(dbs[0]), [out for _, out in outputs])
        if db is not None:
            for k, out in outputs:
                if _same(out, db):
                    raise click.UsageError(
                        f"{name(k)} {out} is the history database ({name(dbs[0])}): writing it would replace "
                        "every record; choose another file"
                    )


def _absurd_sizes(command: click.Command, params: dict) -> list[tuple[click.Parameter, float]]:
    """The size options (``--*-mm``, ``--*-m``) whose value is not finite or beyond :data:`MAX_SIZE_M`."""
    out: list[tuple[click.Parameter, float]] = []
    for p in command.params:
        if not isinstance(p, click.Option) or not isinstance(p.type, click.types.FloatParamType) or not p.name:
            continue
        scale = 1e-3 if p.name.endswith("_mm") else 1.0 if p.name.endswith("_m") else None
        if scale is None:
            continue
        out += [(p, v) for v in _values_num(params.get(p.name)) if not math.isfinite(v) or abs(v) * scale > MAX_SIZE_M]
    return out


def _slip(p: click.Parameter, v: float) -> str | None:
    """Why a wheel size or wheelbase option cannot be a robot's (a unit slip), or None."""
    name = p.name or ""
    unit = "mm" if name.endswith("_mm") else "m" if name.endswith("_m") else None
    kind: str | Quantity | None = next((s.quantity for s in _kind_sizes() if s.option == name), None)
    if kind is None:
        kind = next((k for k, words in _GEOMETRY_WORDS.items() if any(w in name for w in words)), None)
    if unit is None or kind is None:
        return None
    return unit_slip(kind, v * (1e-3 if unit == "mm" else 1.0), unit)


def _kind_sizes() -> list[Size]:
    """Every kind's nominal sizes (:attr:`umbmark.kinds.Kind.sizes`)."""
    from umbmark.kinds import KINDS

    return [s for k in KINDS.values() for s in k.sizes]


def _size_message(p: click.Parameter, v: float) -> str:
    unit = "mm" if (p.name or "").endswith("_mm") else "m"
    return f"must be a finite size below {MAX_SIZE_M * (1e3 if unit == 'mm' else 1.0):g} {unit}, got {v!r}"


def _values_num(v: Any) -> list[float]:
    if v is None:
        return []
    if isinstance(v, (list, tuple)):
        return [float(x) for x in v if x is not None]
    return [float(v)]


def _flag_names(command: click.Command) -> dict[str, str]:
    out = {}
    for p in command.params:
        if isinstance(p, click.Option):
            out[p.name or ""] = max(p.opts, key=len)
        else:
            out[p.name or ""] = p.human_readable_name
    return out


MAX_NUMBER_CHARS = 64
"""A number given to an option longer than this is refused without being echoed whole."""


def _refuse_underscored_numbers(command: click.Command, args: list[str], ctx: click.Context) -> None:
    """Refuse ``--speed 1_0``: Python reads it as 10, a user meant something else (a typo, a
    thousands separator)."""
    numeric: dict[str, click.Option] = {}
    for q in command.params:
        if isinstance(q, click.Option) and isinstance(q.type, (click.types.FloatParamType, click.types.IntParamType)):
            for o in q.opts:
                numeric[o] = q
    for i, a in enumerate(args):
        if a == "--":
            return
        opt, eq, value = a.partition("=")
        p = numeric.get(opt)
        if p is None:
            continue
        n = max(p.nargs, 1)
        values = [value] if eq else args[i + 1 : i + 1 + n]
        for v in values:
            if len(v) > MAX_NUMBER_CHARS:
                raise click.BadParameter(
                    f"{v[:12]!r}... ({len(v)} {'digits' if v.isdigit() else 'characters'}) is no number a robot's "
                    "option takes",
                    ctx=ctx,
                    param=p,
                )
            if "_" in v:
                raise click.BadParameter(
                    f"{v!r} is not a number: '_' is not a digit (write the number without it)",
                    ctx=ctx,
                    param=p,
                )


class GuardedCommand(click.Command):
    """A command that runs :func:`check_paths` before its callback, reports a failure an absurd
    size option causes as that option (see the module docstring), and names
    the ``./`` and ``--`` ways of giving a file whose name starts with a dash."""

    def parse_args(self, ctx: click.Context, args: list[str]) -> list[str]:
        given = list(args)  # the parser consumes ``args``
        _refuse_underscored_numbers(self, given, ctx)
        try:
            return super().parse_args(ctx, args)
        except click.NoSuchOption as e:
            known = {o for p in self.params for o in getattr(p, "opts", []) + getattr(p, "secondary_opts", [])}
            for a in given:
                if a == "--":
                    break
                if a.startswith("-") and a != "-" and a.split("=")[0] not in known and a.startswith(e.option_name):
                    if "." in a or "/" in a or os.path.exists(a):
                        raise click.UsageError(
                            f"no such option {a}: to give a file whose name starts with '-', "
                            f"write ./{a} (or put -- before the file names)",
                            ctx=ctx,
                        ) from None
            raise

    def invoke(self, ctx: click.Context) -> Any:
        absurd = self.check_params(ctx)
        skip = ctx.params.pop("skip_check", None) or ()
        ctx.meta[SKIPPED_CHECKS] = tuple(skip)  # for --write-config, which the command's callback runs
        from umbmark._check import skipping_checks

        with skipping_checks(skip):
            if not absurd:
                return super().invoke(ctx)
            return self._invoke_absurd(ctx, absurd)

    def check_params(self, ctx: click.Context) -> list[tuple[click.Parameter, float]]:
        """The checks of the parsed options before the command runs (paths, the history's
        address, sizes no robot has); returns the sizes beyond :data:`MAX_SIZE_M` that the
        command checks itself."""
        path = ctx.command_path.split(" ", 1)[1] if " " in ctx.command_path else ctx.command_path
        try:
            check_paths(path, ctx.params, _flag_names(self))
        except click.UsageError as e:
            e.ctx = ctx
            raise
        for k, role in path_roles(path).items():
            if role == "db" and ctx.params.get(k):
                from umbmark.history.base import check_db_address

                check_db_address(ctx.params[k])
        absurd = _absurd_sizes(self, ctx.params)
        for p, v in absurd:
            if math.isfinite(v) and p.name not in _OWN_SIZE_CHECKS:
                raise click.BadParameter(_size_message(p, v), ctx=ctx, param=p)
        for p in self.params:
            if isinstance(p, click.Option) and isinstance(p.type, click.types.FloatParamType) and p.name:
                for v in _values_num(ctx.params.get(p.name)):
                    slip = _slip(p, v)
                    if slip is not None:
                        raise click.BadParameter(slip, ctx=ctx, param=p)
        return absurd

    def _invoke_absurd(self, ctx: click.Context, absurd: list[tuple[click.Parameter, float]]) -> Any:
        # a size no robot has: the command's own checks speak first; what they do not catch
        # (an overflow deep in the numbers) is reported as that size, in one line
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                rv = super().invoke(ctx)
            except (click.exceptions.ClickException, click.exceptions.Exit, click.exceptions.Abort):
                raise
            except (UmbmarkError, OSError):
                raise
            except Exception:
                p, v = absurd[0]
                raise click.BadParameter(_size_message(p, v), ctx=ctx, param=p) from None
        for w in caught:
            warnings.showwarning(w.message, w.category, w.filename, w.lineno)
        return rv


class GuardedGroup(click.Group):
    """A group whose commands (and subgroups) are :class:`GuardedCommand` s."""

    command_class = GuardedCommand
    group_class = type  # subgroups are GuardedGroups too


SKIPPED_CHECKS = "umbmark.skip_check"
"""The key of :attr:`click.Context.meta` that holds the ``--skip-check`` values given (the command's
callback does not receive them: they are applied around it)."""


def skip_check_option(f: F) -> F:
    """Add ``--skip-check CHECK`` (repeatable) to a command that reads recordings: the named
    plausibility checks (:data:`umbmark._check.CHECKS`) let the data through
    (:class:`GuardedCommand` applies it around the command)."""
    from umbmark._check import CHECKS

    return click.option(
        "--skip-check",
        "skip_check",
        multiple=True,
        type=click.Choice(sorted(CHECKS)),
        metavar="CHECK",
        help="Let the data through a plausibility check that refuses this recording (its message names the "
        f"check), if you know the recording is right; repeatable. Checks: {', '.join(sorted(CHECKS))}.",
    )(f)
