"""Speed benchmark: ``python benchmarks/speed.py [--quick] [options]``.

The same as ``umbmark bench speed``: writes speed.json and speed.md into --out (default: a new
folder ./umbmark-bench-speed; ``--out benchmarks/results`` for the results kept in the
repository). See ``umbmark bench speed --help`` and umbmark/studies/speed.py for what is measured."""

import sys

from umbmark.cli import main

if __name__ == "__main__":
    sys.exit(main(["bench", "speed"] + sys.argv[1:]))
