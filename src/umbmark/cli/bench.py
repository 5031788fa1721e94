"""``umbmark bench``: the group of benchmarks (``accuracy`` and ``speed``, in their own modules)."""

from __future__ import annotations

from umbmark.cli.app import app

__all__ = ["bench", "BENCH_ACCURACY_OUT", "BENCH_SPEED_OUT"]

# default result folders: new folders in the current directory (never the repository's own results)
BENCH_ACCURACY_OUT = "umbmark-bench-accuracy"
BENCH_SPEED_OUT = "umbmark-bench-speed"


@app.group()
def bench() -> None:
    """Benchmarks of speed and accuracy (results written into --out, by default a new folder here)."""
