"""What the benchmark scripts of this folder share: the machine they run on, their results
folder and the writing of their results.

The scripts import it as ``_common`` (this folder is the first entry of ``sys.path`` when a
script runs as ``python benchmarks/x.py``; a script loaded by path adds the folder itself).
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

from umbmark.jsonutil import dumps

__all__ = [
    "default_out",
    "add_out",
    "machine",
    "machine_text",
    "command",
    "write_json",
    "write_results",
    "pin_one_core",
]


def default_out(name: str) -> str:
    """The results folder a benchmark writes into unless ``--out`` says otherwise.

    Parameters
    ----------
    name : str
        The benchmark's name, e.g. ``"raycast"``.

    Returns
    -------
    str
        ``umbmark-bench-<name>``: a new folder of the current directory.
    """
    return f"umbmark-bench-{name}"


def add_out(
    p: argparse.ArgumentParser, name: str, *, file: str | None = None, what: str = "results folder", type=Path
) -> None:
    """Add ``--out`` to a benchmark's options, by default :func:`default_out` ``(name)``.

    Parameters
    ----------
    p : argparse.ArgumentParser
        The script's options.
    name : str
        The benchmark's name.
    file : str, optional
        The one file the benchmark writes: ``--out`` is then that file, by default inside
        the folder of :func:`default_out`.
    what : str
        What ``--out`` is, as its help says.
    type : callable
        The type of the option's value (``Path``, or ``str`` where the value goes on as given).
    """
    default = Path(default_out(name))
    if file is not None:
        default = default / file
    p.add_argument("--out", type=type, default=type(default), help=f"{what} (default ./{default})")


def add_repeat(p: argparse.ArgumentParser, default: int, what: str) -> None:
    """Add ``--repeat`` (at least 1; otherwise argparse's one-line error and exit status 2).

    Parameters
    ----------
    p : argparse.ArgumentParser
        The script's options.
    default : int
        The runs by default.
    what : str
        What is repeated, as its help says (``timed runs of each case``).
    """

    def at_least_one(text: str) -> int:
        n = int(text)
        if n < 1:
            raise argparse.ArgumentTypeError("must be at least 1")
        return n

    p.add_argument("--repeat", type=at_least_one, default=default, help=f"{what} (default {default})")


def _version(name: str) -> str | None:
    try:
        return version(name)
    except PackageNotFoundError:  # not installed
        return None


def machine(*packages: str, numpy: bool = True) -> dict:
    """The machine a benchmark runs on.

    Imports none of the packages (a benchmark may time their import or first call).

    Parameters
    ----------
    *packages : str
        Further distributions whose versions to record (``None`` where not installed).
    numpy : bool
        Whether to record numpy's version.

    Returns
    -------
    dict
        ``cpu_model``, ``nproc``, ``cores_available``, ``python``, ``numpy``, ``platform``, the
        versions of ``packages`` and ``load_average`` (where the system has one), in this order.
    """
    cpu = platform.processor() or ""
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            cpu = next((line.split(":", 1)[1].strip() for line in f if line.startswith("model name")), cpu)
    except OSError:  # not Linux
        pass
    info = {
        "cpu_model": cpu,
        "nproc": os.cpu_count(),
        "cores_available": len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count(),
        "python": platform.python_version(),
    }
    if numpy:
        info["numpy"] = _version("numpy")
    info["platform"] = platform.platform()
    for name in packages:
        info[name] = _version(name)
    if hasattr(os, "getloadavg"):
        info["load_average"] = [round(x, 2) for x in os.getloadavg()]
    return info


def pin_one_core() -> int | None:
    """Run this process (and its children) on one CPU, for per-core figures.

    Returns
    -------
    int or None
        The CPU, or None where the system cannot pin a process.
    """
    if not hasattr(os, "sched_setaffinity"):
        return None
    cpu = min(os.sched_getaffinity(0))
    os.sched_setaffinity(0, {cpu})
    return cpu


def machine_text(m: dict, note: str | None = None, *, load: bool = True) -> str:
    """The sentence of a results page that describes the machine.

    Parameters
    ----------
    m : dict
        The output of :func:`machine`.
    note : str, optional
        Said after the cores, before the versions (e.g. the CPU the benchmark was pinned to).
    load : bool
        Whether to say the load average at the start (where ``m`` holds it).

    Returns
    -------
    str
        ``Machine: <CPU>, <n> cores available (nproc <n>), Python <version>, <package> <version>,
        ..., <platform>``, then the load average at the start;
        ``(nproc <n>), <note>; Python`` where there is a note.
    """
    head = f"Machine: {m['cpu_model']}, {m['cores_available']} cores available (nproc {m['nproc']})"
    head += f", {note}; " if note else ", "
    fixed = ("cpu_model", "nproc", "cores_available", "python", "platform", "load_average")
    parts = [f"Python {m['python']}", *(f"{k} {v}" for k, v in m.items() if k not in fixed), m["platform"]]
    if load and "load_average" in m:
        parts.append(f"load average at start {m['load_average']}")
    return head + ", ".join(parts) + "."


def command(script: str, argv: list[str] | None) -> str:
    """The command line of a benchmark run, as its results show it.

    Parameters
    ----------
    script : str
        The script's name without ``.py``.
    argv : list of str or None
        The arguments given to the script's ``main``; ``None``: those of this process.

    Returns
    -------
    str
        ``python benchmarks/<script>.py <arguments>``.
    """
    shown = sys.argv[1:] if argv is None else list(argv)
    return " ".join([f"python benchmarks/{script}.py", *shown])


def write_json(path: Path, res: dict) -> str:
    """Write results as strict, indented JSON (its folder created if missing).

    Parameters
    ----------
    path : Path
        The file.
    res : dict
        The results.

    Returns
    -------
    str
        The JSON written, without the final newline.
    """
    text = dumps(res, indent=2)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text + "\n")
    return text


def write_results(out: Path, stem: str, res: dict, page: str, *, show: bool = False) -> list[Path]:
    """Write ``<stem>.json`` and the Markdown page ``<stem>.md`` into a folder.

    Parameters
    ----------
    out : Path
        The folder (created if missing).
    stem : str
        The files' name without suffix.
    res : dict
        The results.
    page : str
        The Markdown page.
    show : bool
        Whether to print the page and then the files written.

    Returns
    -------
    list of Path
        The JSON file and the page.
    """
    paths = [out / f"{stem}.json", out / f"{stem}.md"]
    write_json(paths[0], res)
    paths[1].write_text(page)
    if show:
        print(page)
        print("written:", ", ".join(map(str, paths)))
    return paths
