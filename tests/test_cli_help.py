"""Every command's --help works and shows examples; shell completion comes from click."""

import os
import subprocess
import sys

import click
import pytest

from umbmark.cli import app, main


def _commands(group=app, path=()):
    for name, cmd in sorted(group.commands.items()):
        yield path + (name,), cmd
        if isinstance(cmd, click.Group):
            yield from _commands(cmd, path + (name,))


ALL = list(_commands())
# groups (e.g. `umbmark bench`) list their subcommands; the examples live in the leaf commands
LEAVES = [(p, c) for p, c in ALL if not isinstance(c, click.Group)]


def test_top_level_help_lists_every_command(capsys):
    assert main(["--help"]) == 0
    out = capsys.readouterr().out
    for name in app.commands:
        assert name in out
    for name in ("history", "report", "guide", "measure"):
        assert name in app.commands


@pytest.mark.parametrize("path", [p for p, _ in ALL], ids=[" ".join(p) for p, _ in ALL])
def test_help_works(path, capsys):
    assert main([*path, "--help"]) == 0
    assert capsys.readouterr().out.startswith(f"Usage: umbmark {' '.join(path)}")


@pytest.mark.parametrize("path", [p for p, _ in LEAVES], ids=[" ".join(p) for p, _ in LEAVES])
def test_help_has_examples(path, capsys):
    assert main([*path, "--help"]) == 0
    out = capsys.readouterr().out
    assert "Example" in out, f"umbmark {' '.join(path)} --help has no example"
    assert f"umbmark {' '.join(path)}" in out.split("Example", 1)[1]


def test_history_options_on_analyze(capsys):
    assert main(["analyze", "--help"]) == 0
    out = capsys.readouterr().out
    for opt in ("--robot", "--record", "--db"):
        assert opt in out


def test_bash_completion_script_and_answers():
    # `python -m umbmark` runs the same entry point as the console script
    r = subprocess.run([sys.executable, "-m", "umbmark", "--version"], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0 and "umbmark" in r.stdout
    env = dict(os.environ, _UMBMARK_COMPLETE="bash_complete", COMP_WORDS="umbmark hist", COMP_CWORD="1")
    r = subprocess.run(
        [sys.executable, "-c", "from umbmark.cli import main; main()"],
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert r.returncode == 0 and "plain,history" in r.stdout.split()
    env = dict(os.environ, _UMBMARK_COMPLETE="bash_source")
    r = subprocess.run(
        [sys.executable, "-c", "import sys; sys.argv[0] = 'umbmark'; from umbmark.cli import main; main()"],
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert r.returncode == 0 and "_umbmark_completion" in r.stdout and "complete -o" in r.stdout


def test_progress_is_silent_off_terminal_and_under_quiet(capsys):
    from rich.console import Console

    from umbmark.cli import progress as prog

    tty = Console(stderr=True, force_terminal=True)
    with click.Context(app, obj={"quiet": False}):
        assert prog.progress_enabled(tty)
        assert not prog.progress_enabled(Console(stderr=True, force_terminal=False))
    with click.Context(app, obj={"quiet": True}):
        assert not prog.progress_enabled(tty)
    # under pytest stderr is not a terminal: nothing is drawn, the iterable passes through
    assert list(prog.track(range(5), "counting")) == [0, 1, 2, 3, 4]
    with prog.progress("work", total=3) as advance:
        advance()
        advance(2)
    assert capsys.readouterr().err == ""


def test_progress_draws_on_a_terminal(monkeypatch):
    import io

    from rich.console import Console

    from umbmark.cli import progress as prog

    buf = io.StringIO()
    monkeypatch.setattr(prog, "_console", lambda: Console(file=buf, force_terminal=True, width=80))
    with click.Context(app, obj={"quiet": False}):
        assert list(prog.track(range(3), "counting")) == [0, 1, 2]
    assert "counting" in buf.getvalue()
