"""Progress bars of the long commands: drawn on a terminal's stderr only; nothing under --quiet
or off a terminal; --json output stays pure JSON; stdout is never sent through the bar's stream."""

from __future__ import annotations

import io
import json
from pathlib import Path

import pytest
from rich.console import Console

from umbmark.cli import main
from umbmark.cli import progress as prog


@pytest.fixture
def tty(monkeypatch):
    """stderr is a terminal (a buffer we can read)."""
    buf = io.StringIO()
    monkeypatch.setattr(prog, "_console", lambda: Console(file=buf, force_terminal=True, width=100))
    return buf


COMMANDS = {
    "reproduce": ["reproduce", "--seeds", "2", "--no-pitfall", "--workers", "1"],
    "calibrate": ["calibrate", "--noise", "none", "--ed", "1.01", "--eb", "1.05"],
    "accuracy": ["bench", "accuracy", "--quick", "--robots", "1", "--workers", "1"],
    "speed": ["bench", "speed", "--quick", "--replay-sizes", "1000", "--robots", "1", "--workers", "1"],
    "replay": [
        "replay",
        str(Path(__file__).resolve().parents[1] / "data" / "optiodom" / "square" / "230620202144"),
        "--method",
        "bf",
    ],
}
DRAWN = {
    "reproduce": "simulating 2 seeds",
    "calibrate": "simulating up to",
    "accuracy": "accuracy benchmark",
    "speed": "speed benchmark",
    "replay": "reading logs",
}
WRITES = ("accuracy", "speed")  # take --out


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_bar_on_a_terminal_json_stays_pure(name, tty, tmp_path, capsys):
    extra = ["--out", str(tmp_path)] if name in WRITES else []
    assert main(COMMANDS[name] + extra + ["--json"]) == 0
    out = capsys.readouterr()
    json.loads(out.out)  # stdout: exactly one JSON object
    assert out.err == ""
    assert DRAWN[name] in tty.getvalue()  # the bar went to the (terminal) stderr console


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_quiet_draws_nothing(name, tty, tmp_path, capsys):
    extra = ["--out", str(tmp_path)] if name in WRITES else []
    assert main(["--quiet"] + COMMANDS[name] + extra) == 0
    out = capsys.readouterr()
    assert out.out == "" and out.err == "" and tty.getvalue() == ""


def test_off_a_terminal_only_the_normal_output(capsys):
    # under pytest stderr is not a terminal: the human output is the same as without any bar
    assert main(COMMANDS["calibrate"]) == 0
    out = capsys.readouterr()
    assert out.err == "" and "final calibration" in out.out


def test_stdout_printed_during_a_bar_stays_on_stdout(tty, capsys):
    # stdout is a pipe here (captured): lines printed while the bar runs are not redirected into
    # the bar's stderr console
    from click import Context

    from umbmark.cli.app import app

    with Context(app, obj={"quiet": False}):
        with prog.progress("work", total=2) as advance:
            print("a line for stdout")
            advance(2)
    assert "a line for stdout" in capsys.readouterr().out
    assert "a line for stdout" not in tty.getvalue() and "work" in tty.getvalue()
