"""``--config FILE`` and ``--write-config FILE`` for the commands with many options (``selfcal``,
``replay``, ``validate``).

A configuration file is YAML: a section per command, its keys the command's options as the flags
name them without the leading dashes (``odom-topic`` or ``odom_topic``), its values as they
would be typed::

    # umbmark options: umbmark selfcal BAG --config robot.yaml
    selfcal:
      odom-topic: /odom
      wheel-diameter-mm: 200
      wheelbase-mm: 400
      keyframe-mm: 300
    replay:
      joints: left_wheel_joint,right_wheel_joint

The keys are the options of the command's typed configuration (:mod:`umbmark.cli.command_config`:
``selfcal``'s and ``replay``'s, whose defaults the options show); a repeatable option's values
are written and read as one line, ``skip-check: stamp_order,wheel_units``.

The file gives the options' defaults: an option given on the command line wins. A section
named like no command that reads a configuration, a section given twice and an option given
twice are refused naming the lines (YAML would keep the last and drop the rest without a word);
the file is read no further than :data:`MAX_CONFIG_BYTES`. Its values go
through the same checks as the flags' (a number with ``_`` in it, a size in the other unit, a
path that an output would replace), and from there into the library's configuration types
(:class:`umbmark.io.wheels.WheelSource`, :class:`umbmark.io.load.LogOptions`,
:class:`umbmark.realrobot.selfcal.IntervalOptions`). Arguments (the bags, the logs) stay on the
command line. ``--write-config FILE`` writes the options given (on the command line or by
``--config``) as such a file and runs nothing.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any, TypeVar

import click

from umbmark.cli.command_config import Section
from umbmark.cli.guard import SKIPPED_CHECKS

__all__ = ["config_options", "read_config", "config_text", "option_of"]

F = TypeVar("F", bound=Callable[..., Any])

_OWN = ("config", "write_config")


def _options_of(command: click.Command) -> dict[str, click.Option]:
    """The command's options by name, but for the configuration's own."""
    return {p.name: p for p in command.params if isinstance(p, click.Option) and p.name and p.name not in _OWN}


# a configuration is a few lines of YAML; a longer file is not one (read no further)
MAX_CONFIG_BYTES = 1 << 20


def read_config(path: str, command: click.Command, section: str, sections: tuple[str, ...] = ()) -> dict[str, Any]:
    """The options of ``section`` in the configuration file ``path``, by parameter name, as
    strings (booleans for flags).

    Parameters
    ----------
    path : str
        The file.
    command : click.Command
        The command whose options the section holds.
    section : str
        The command's name.
    sections : tuple of str
        Every section a configuration may hold (the commands with ``--config``); empty: not checked.

    Raises
    ------
    click.BadParameter
        An unreadable file (or one longer than :data:`MAX_CONFIG_BYTES`), not YAML, no mapping of
        commands, a section given twice or named like no command, a key given twice or that is no
        option of the command (file and line named), a value that is not a scalar or a number with ``_``.
    """
    import yaml

    from umbmark.io._text import read_text

    def bad(message: str, line: int | None = None) -> click.BadParameter:
        where = f"{path}: line {line}: " if line else f"{path}: "
        return click.BadParameter(where + message, param_hint="--config")

    from umbmark.errors import InputError

    try:
        text = read_text(path, max_bytes=MAX_CONFIG_BYTES)
        root = yaml.compose(text, Loader=yaml.BaseLoader)  # every scalar a string: no 1_0 read as 10
    except InputError as e:
        raise bad(e.message) from None
    except OSError as e:
        raise bad(f"cannot read: {e.strerror or e}") from None
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        raise bad(f"not YAML ({getattr(e, 'problem', None) or e})", None if mark is None else mark.line + 1) from None
    if root is None:
        return {}
    if not isinstance(root, yaml.MappingNode):
        raise bad("a configuration is a mapping of commands to their options (selfcal: ...)", root.start_mark.line + 1)
    _check_sections(root, sections, bad)
    options = _options_of(command)
    by_flag = {k.replace("_", "-"): k for k in options}
    out: dict[str, Any] = {}
    first_line: dict[str, int] = {}
    for key_node, value_node in root.value:
        if key_node.value != section:
            continue
        if not isinstance(value_node, yaml.MappingNode):
            raise bad(f"the options of {section} are a mapping (option: value)", value_node.start_mark.line + 1)
        for k, v in value_node.value:
            line = k.start_mark.line + 1
            name = by_flag.get(str(k.value).strip().lstrip("-").replace("_", "-"))
            if name is None:
                raise bad(f"no option --{str(k.value).lstrip('-')} of umbmark {section}", line)
            flag = f"--{name.replace('_', '-')}"
            if name in first_line:
                raise bad(f"{flag} given twice (lines {first_line[name]} and {line}): give each option once", line)
            first_line[name] = line
            if not isinstance(v, yaml.ScalarNode):
                raise bad(f"{flag} takes one value, not a list or a mapping", line)
            p, value = options[name], str(v.value)
            if isinstance(p.type, (click.types.FloatParamType, click.types.IntParamType)) and "_" in value:
                raise bad(f"{flag}: {value!r} is not a number: '_' is not a digit", line)
            if p.is_flag and value.lower() not in ("true", "false", "yes", "no", "on", "off", "1", "0"):
                raise bad(f"{flag} is a flag: true or false, not {value!r}", line)
            if p.is_flag:
                out[name] = value.lower() in ("true", "yes", "on", "1")
            else:  # a repeatable option's values as --write-config writes them: a,b
                out[name] = tuple(v.strip() for v in value.split(",")) if p.multiple else value
    return out


def _check_sections(root: Any, sections: tuple[str, ...], bad: Callable[..., click.BadParameter]) -> None:
    """Each section once, and each named like a command that reads a configuration."""
    import difflib

    seen: dict[str, int] = {}
    for key_node, _ in root.value:
        name, line = str(key_node.value), key_node.start_mark.line + 1
        if sections and name not in sections:
            near = difflib.get_close_matches(name, sections, n=1)
            hint = f" ({near[0]}?)" if near else ""
            raise bad(f"no command {name!r}{hint}: the sections are {', '.join(sections)}", line)
        if name in seen:
            raise bad(f"two {name}: sections (lines {seen[name]} and {line}): give each command's options in one", line)
        seen[name] = line


def config_text(section: str, values: dict[str, Any]) -> str:
    """A configuration file holding ``values`` (parameter name -> value) for ``section``."""
    import yaml

    flags = {k.replace("_", "-"): v for k, v in values.items()}
    body = yaml.safe_dump({section: flags}, sort_keys=False, default_flow_style=False)
    return f"# umbmark options: umbmark {section} ... --config FILE (the command line wins)\n{body}"


def _load(ctx: click.Context, param: click.Parameter, value: str | None) -> str | None:
    """The eager ``--config``: its options become the command's defaults."""
    if value is not None:
        assert ctx.command is not None
        section = ctx.command.name or ""
        root = ctx.find_root().command
        commands = getattr(root, "commands", {})
        sections = tuple(sorted(n for n, c in commands.items() if any(p.name == "config" for p in c.params)))
        ctx.default_map = {**(ctx.default_map or {}), **read_config(value, ctx.command, section, sections)}
    return value


def config_options(f: Callable[..., Any]) -> Callable[..., Any]:
    """Add ``--config FILE`` and ``--write-config FILE`` (see the module docstring) to a command."""

    @functools.wraps(f)
    def run(*args: Any, config: str | None = None, write_config: str | None = None, **kwargs: Any) -> Any:
        if write_config is None:
            return f(*args, **kwargs)
        from umbmark.io.atomic import atomic_write

        ctx = click.get_current_context()
        values = {**ctx.params, "skip_check": ctx.meta.get(SKIPPED_CHECKS, ())}  # those applied around the command too
        given = {
            k: _plain(v)
            for k, v in values.items()
            if k in _options_of(ctx.command)
            and ctx.get_parameter_source(k)
            in (click.core.ParameterSource.COMMANDLINE, click.core.ParameterSource.DEFAULT_MAP)
        }
        db = given.get("db")
        if isinstance(db, str):
            from umbmark.history.base import display_db

            if display_db(db) != db:
                raise click.BadParameter(
                    f"--db {display_db(db)} holds a password, which a config file does not keep: give the URL "
                    "without it (a PostgreSQL password in $PGPASSWORD or ~/.pgpass); nothing was written",
                    ctx=ctx,
                    param_hint="'--write-config'",
                )
        atomic_write(write_config, config_text(ctx.command.name or "", given))
        click.echo(f"wrote the options of umbmark {ctx.command.name} to {write_config} ({len(given)} given)", err=True)
        return None

    run = click.option(
        "--write-config",
        type=click.Path(dir_okay=False),
        default=None,
        metavar="FILE",
        help="Write the options given (here or by --config) to a configuration file (YAML) and run nothing.",
    )(run)
    return click.option(
        "--config",
        type=click.Path(dir_okay=False),
        default=None,
        metavar="FILE",
        is_eager=True,
        callback=_load,
        help="Read options from a configuration file (YAML, a section per command, keys as the flags without "
        "the dashes); options given here win.",
    )(run)


def option_of(config: type[Section]) -> Callable[..., Callable[[F], F]]:
    """``click.option`` with the option's default taken from ``config`` (a typed configuration of
    :mod:`umbmark.cli.command_config`) by the option's parameter name: no option declares a
    default of its own.

    Raises
    ------
    KeyError
        An option that ``config`` has not (when the command is built).
    TypeError
        A default given besides.
    """

    def option(*decls: str, **attrs: Any) -> Callable[[F], F]:
        if "default" in attrs:
            raise TypeError(f"{decls[0]}: the default is the configuration's ({config.__name__})")
        name = click.Option(decls).name
        assert name is not None
        return click.option(*decls, default=config.default(name), **attrs)

    return option


def _plain(v: Any) -> Any:
    """A parsed option's value as YAML writes it plainly."""
    if isinstance(v, tuple):
        return ",".join(str(x) for x in v)
    return v
