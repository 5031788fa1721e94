"""Speed benchmark: ``python benchmarks/speed.py [--quick] [options]``.

The same as ``umbmark bench speed``, writing into benchmarks/results/ beside this script.
See ``umbmark bench speed --help`` and umbmark/speedbench.py for what is measured."""

import sys
from pathlib import Path

from umbmark.cli import main

if __name__ == "__main__":
    out = Path(__file__).resolve().parent / "results"
    args = sys.argv[1:]
    if "--out" not in args:
        args = ["--out", str(out)] + args
    sys.exit(main(["bench", "speed"] + args))
