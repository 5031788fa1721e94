"""``umbmark bench``: the group of benchmarks. Subcommands live in bench_speed.py (issue 5)
and bench_accuracy.py (issue 7)."""

from __future__ import annotations

from umbmark.cli.app import app


@app.group()
def bench():
    """Benchmarks of speed and accuracy (results written to benchmarks/results/)."""
