#!/usr/bin/env python3
"""Start-up time of the command line: ``umbmark --help`` and ``umbmark --version`` against
``python -c "import numpy"``, measured in the same run.

    python benchmarks/startup.py                          # 15 runs each, into ./umbmark-bench-startup/
    python benchmarks/startup.py --out benchmarks/results

Each command runs in a fresh process (output discarded); the three commands take turns, after
one warm-up run each, and the median wall-clock time of each is compared with numpy's import.
Writes startup.json and startup.md into --out (created if missing) and prints the ratios. Exit
status 1 when ``umbmark --help`` takes more than --limit times numpy's import (default 2.5).
"""

from __future__ import annotations

import argparse
import os
import shlex
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))  # _common.py, also when this file is loaded by path
from _common import add_out, add_repeat, command, machine, machine_text, write_results  # noqa: E402

LIMIT = 2.5


def umbmark_command() -> list[str]:
    """The ``umbmark`` console script installed beside this Python, else ``python -m umbmark``."""
    here = Path(sys.executable).parent / ("umbmark.exe" if os.name == "nt" else "umbmark")
    found = str(here) if here.exists() else shutil.which("umbmark")
    return [found] if found else [sys.executable, "-m", "umbmark"]


def commands() -> dict[str, list[str]]:
    """Name -> argument vector of each timed command."""
    cli = umbmark_command()
    return {
        "help": cli + ["--help"],
        "version": cli + ["--version"],
        "numpy": [sys.executable, "-c", "import numpy"],
    }


def time_once(argv: list[str]) -> float:
    """Wall-clock seconds of one run of ``argv`` (output discarded; a failure raises)."""
    t0 = time.perf_counter()
    subprocess.run(argv, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True)
    return time.perf_counter() - t0


def measure(repeat: int) -> dict:
    """Time every command ``repeat`` times (taking turns, after one warm-up run each)."""
    cmds = commands()
    for argv in cmds.values():
        time_once(argv)
    times: dict[str, list[float]] = {name: [] for name in cmds}
    for _ in range(repeat):
        for name, argv in cmds.items():
            times[name].append(time_once(argv))
    return {
        name: {"argv": cmds[name], "median_s": statistics.median(t), "min_s": min(t), "times_s": t}
        for name, t in times.items()
    }


def markdown(res: dict) -> str:
    """The results as a Markdown page (written beside the JSON)."""
    m = res["machine"]
    c = res["commands"]
    lines = [
        "# Start-up time of the command line",
        "",
        machine_text(m),
        "",
        f"Command: `{res['command']}`. Each command in a fresh process, {res['repeat']} runs each taking "
        "turns after one warm-up run; median and fastest wall-clock time.",
        "",
        "| command | median [ms] | fastest [ms] | median / numpy import |",
        "|---|---|---|---|",
    ]
    for name in ("help", "version", "numpy"):
        argv = c[name]["argv"]
        shown = shlex.join([Path(argv[0]).name, *argv[1:]])
        ratio = res["ratios"].get(f"{name}_over_numpy", 1.0)
        lines.append(f"| `{shown}` | {c[name]['median_s'] * 1e3:.0f} | {c[name]['min_s'] * 1e3:.0f} | {ratio:.2f} |")
    verdict = "within" if res["ok"] else "above"
    lines += [
        "",
        f"`umbmark --help` takes {res['ratios']['help_over_numpy']:.2f} x the import of numpy: {verdict} the "
        f"limit of {res['limit']:g} x.",
    ]
    return "\n".join(lines) + "\n"


def parser() -> argparse.ArgumentParser:
    """The command-line options of this script."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_repeat(p, 15, "timed runs of each command")
    p.add_argument("--limit", type=float, default=LIMIT, help="largest --help / numpy ratio that passes")
    add_out(p, "startup")
    return p


def main(argv=None) -> int:
    """Measure, write startup.json and startup.md, print the ratios; 1 when --help is too slow."""
    a = parser().parse_args(argv)
    cmds = measure(a.repeat)
    numpy_s = cmds["numpy"]["median_s"]
    ratios = {f"{k}_over_numpy": cmds[k]["median_s"] / numpy_s for k in ("help", "version")}
    res = {
        "machine": machine(numpy=False),
        "command": command("startup", argv),
        "repeat": a.repeat,
        "commands": cmds,
        "ratios": ratios,
        "limit": a.limit,
        "ok": ratios["help_over_numpy"] <= a.limit,
    }
    paths = write_results(a.out, "startup", res, markdown(res))
    for k, v in ratios.items():
        print(f"{k}: {v:.2f} (limit {a.limit:g} for help)")
    print("written:", ", ".join(map(str, paths)))
    return 0 if res["ok"] else 1


if __name__ == "__main__":
    sys.exit(main())
