"""Every command's --help works and shows examples; shell completion comes from click; the
start of the command line (its option constants, the start-up benchmark) and where the
benchmarks write by default."""

import os
import subprocess
import sys
from pathlib import Path

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


def test_option_constants_match_the_library():
    """The choices and defaults the options show, written out in umbmark.cli.app so that building
    the command line imports no numerical module, are the library's."""
    import importlib

    from umbmark.correct import METHODS
    from umbmark.io.load import LOG_FORMATS
    from umbmark.model.geometry import LABMATE
    from umbmark.model.simulate import NOISE_PRESETS
    from umbmark.studies import reproduce

    cli_app = importlib.import_module("umbmark.cli.app")  # the package's `app` attribute is the group
    assert cli_app.METHOD_CHOICES == tuple(sorted(METHODS))
    assert cli_app.NOISE_CHOICES == tuple(sorted(NOISE_PRESETS))
    assert cli_app.LOG_FORMAT_CHOICES == tuple(LOG_FORMATS)
    assert cli_app.LABMATE_WHEEL_DIAMETER_MM == LABMATE.wheel_diameter_m * 1e3
    assert cli_app.LABMATE_WHEELBASE_MM == LABMATE.wheelbase_m * 1e3
    assert cli_app.REPRODUCE_TAPE_LAYER_MM * 1e-3 == reproduce.TAPE_LAYER_M
    assert cli_app.REPRODUCE_VARIATION == reproduce.ROBOT_VARIATION


def _script(name: str):
    import importlib.util

    from conftest import REPO

    spec = importlib.util.spec_from_file_location(f"bench_script_{name}", REPO / "benchmarks" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_benchmarks_write_into_a_new_folder_here_by_default(tmp_path, monkeypatch):
    """``umbmark bench accuracy|speed`` and the benchmarks/*.py scripts write into a new folder
    of the current directory unless --out says otherwise; never into the repository's results."""
    from conftest import REPO

    results = (REPO / "benchmarks" / "results").resolve()
    monkeypatch.chdir(tmp_path)
    defaults = {}
    for name in ("accuracy", "speed"):
        cmd = app.commands["bench"].commands[name]
        (param,) = [p for p in cmd.params if p.name == "out_dir"]
        defaults[f"bench {name}"] = Path(param.default)
    for name in ("accuracy", "startup", "noise_preset", "reproduce_sampling", "scan_registration", "selfcal_bag"):
        defaults[name] = Path(_script(name).parser().parse_args([]).out)
    for what, default in defaults.items():
        where = default.resolve()
        assert not default.is_absolute(), what
        assert where.is_relative_to(tmp_path) and where != tmp_path, what
        assert not where.is_relative_to(results), what
        assert where.relative_to(tmp_path).parts[0].startswith("umbmark-bench-"), what
    # benchmarks/speed.py is `umbmark bench speed` and passes no --out of its own
    assert "--out" not in (REPO / "benchmarks" / "speed.py").read_text().split('"""', 2)[2]
    # an explicit --out is taken as given
    assert _script("accuracy").parser().parse_args(["--out", "benchmarks/results"]).out == "benchmarks/results"
    assert main(["bench", "accuracy", "--help"]) == 0


def test_startup_benchmark_writes_its_results(tmp_path):
    """benchmarks/startup.py with few repetitions into a temporary folder (no timing is asserted)."""
    import json

    from conftest import REPO

    out = tmp_path / "startup"
    r = subprocess.run(
        [sys.executable, str(REPO / "benchmarks" / "startup.py"), "--repeat", "2", "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert r.returncode in (0, 1), r.stderr
    res = json.loads((out / "startup.json").read_text())
    assert set(res["commands"]) == {"help", "version", "numpy"}
    for c in res["commands"].values():
        assert len(c["times_s"]) == 2 and c["median_s"] > 0 and c["min_s"] <= c["median_s"]
    assert res["commands"]["help"]["argv"][-1] == "--help"
    assert res["commands"]["numpy"]["argv"][1:] == ["-c", "import numpy"]
    ratio = res["ratios"]["help_over_numpy"]
    assert ratio == res["commands"]["help"]["median_s"] / res["commands"]["numpy"]["median_s"]
    assert res["limit"] == 2.5 and res["ok"] == (ratio <= 2.5) and r.returncode == (0 if res["ok"] else 1)
    for k in ("cpu_model", "cores_available", "python"):
        assert k in res["machine"]
    md = (out / "startup.md").read_text()
    assert res["machine"]["cpu_model"] in md and res["machine"]["python"] in md and "--repeat 2" in md
    assert f"{ratio:.2f}" in md
