"""``umbmark bench speed``. Registers on the ``bench`` group."""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import click

from umbmark.cli.app import console, emit_json, fmt, is_quiet, table
from umbmark.cli.bench import BENCH_SPEED_OUT, bench
from umbmark.cli.progress import progress as progress_bar
from umbmark.cli.scaleout import scale_options
from umbmark.errors import InputError

if TYPE_CHECKING:
    from rich.console import Console

__all__ = ["bench_speed"]


def _ints(text: str | None, name: str) -> list[int] | None:
    if text is None:
        return None
    try:
        vals = [int(float(v)) for v in text.split(",") if v.strip()]
    except ValueError:
        raise InputError(f"{name}: expected comma-separated numbers such as 1e5,1e6, got {text!r}") from None
    if not vals or any(v < 1 for v in vals):
        raise InputError(f"{name}: expected positive numbers, got {text!r}")
    return vals


def _n_cases(quick: bool, overrides: dict[str, Any], dask: str | None, workers: int | None) -> int | None:
    """How many cases the benchmark will run (for the progress bar; None if unknown)."""
    from umbmark.studies import speed as speedbench

    try:
        cfg = {
            **(speedbench.QUICK if quick else speedbench.FULL),
            **{k: v for k, v in overrides.items() if v is not None},
        }
        return len(speedbench._plan(cfg, dask, workers))
    except Exception:  # noqa: BLE001 - only the bar's total; the benchmark reports its own errors
        return None


@bench.command("speed")
@click.option("--quick", is_flag=True, help="Small sizes (a few seconds): 1e5 samples, batches of 1 and 10 robots.")
@click.option(
    "--out",
    "out_dir",
    type=click.Path(file_okay=False),
    default=BENCH_SPEED_OUT,
    show_default=True,
    help="Folder for speed.json and speed.md (speed-quick.* with --quick); created if missing.",
)
@click.option(
    "--replay-sizes",
    metavar="N,N,...",
    default=None,
    help="Replay log lengths in samples (default 1e5,1e6,1e7,1e8; quick 1e5).",
)
@click.option(
    "--robots",
    metavar="N,N,...",
    default=None,
    help="Simulation batch sizes in robots (default 1,10,100,1000,10000; quick 1,10).",
)
@click.option(
    "--isolate/--no-isolate",
    default=None,
    help="Run every case in a fresh process, for its own peak RSS (default: on; off with --quick).",
)
@scale_options
@click.option("--json", "as_json", is_flag=True, help="Print the results as JSON.")
def bench_speed(
    quick: bool,
    out_dir: str,
    replay_sizes: str | None,
    robots: str | None,
    isolate: bool | None,
    workers: int | None,
    dask: str | None,
    as_json: bool,
) -> None:
    """Speed and memory of odometry replay and batched simulation, side by side with the
    per-sample Python loop and plain numpy, measured in the same run.

    Writes OUT/speed.json and OUT/speed.md. The full run (no --quick) takes several minutes
    and replays a 10^8-sample log in streaming mode; --dask adds the sweep on a Dask cluster.

    \b
    Examples:
      umbmark bench speed --quick --out bench-quick
      umbmark bench speed
    """
    from umbmark.io.atomic import atomic_write
    from umbmark.studies import speed as speedbench

    sizes = _ints(replay_sizes, "--replay-sizes")
    rob = _ints(robots, "--robots")
    if isolate is None:
        isolate = not quick
    overrides: dict[str, Any] = {}
    if sizes:
        overrides["replay_sizes"] = sizes
        quick_most = cast(int, speedbench.QUICK["replay_inmem_max"])
        overrides["replay_inmem_max"] = max(min(10**7, max(sizes)), quick_most)
    if rob:
        overrides["sim_robots"] = rob
    show = not (as_json or is_quiet())
    con = console()

    def progress(c: dict[str, Any]) -> None:
        advance()
        if show:
            what = f"{c['kind']} {c['impl']} n={c['n']}"
            if "error" in c:
                con.print(f"  {what}: failed: {c['error']}")
            else:
                rate = c.get("samples_per_s") or c.get("experiments_per_s")
                unit = "samples/s" if c["kind"] == "replay" else "experiments/s"
                con.print(f"  {what}: {rate:,.0f} {unit}, peak RSS {c['rss_peak_mib']:.0f} MiB")

    with progress_bar("speed benchmark: cases", total=_n_cases(quick, overrides, dask, workers)) as advance:
        res = speedbench.run_benchmark(
            quick=quick, isolate=isolate, progress=progress, dask=dask, workers=workers, **overrides
        )
    res["isolated"] = isolate
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    stem = "speed-quick" if quick else "speed"
    atomic_write(out / f"{stem}.json", json.dumps(res, indent=2, default=float) + "\n")
    atomic_write(out / f"{stem}.md", speedbench.markdown(res))
    if as_json:
        emit_json(res)
        return
    if is_quiet():
        return
    _print_speed(res, con, out, stem)


def _print_speed(res: dict, con: Console, out: Path, stem: str) -> None:
    """The replay and simulation tables of the speed benchmark, the sweeps, the targets, the files."""
    rows = []
    for row in res["summary"]["replay"]:

        def cell(k: str, row: dict = row) -> str:
            v = row.get(k)
            return "-" if not v else f"{v['samples_per_s'] / 1e6:.2f} ({fmt(v['x_reference'], 0)}x)"

        rows.append(
            [f"{row['n']:.0e}"]
            + [cell(k) for k in ("reference", "numpy-trig", "fast-float", "fast-pulses", "stream")]
            + [fmt(row.get("stream", {}).get("rss_peak_mib"), 0)]
        )
    con.print(
        table(
            "replay: million samples/s (x reference loop)",
            ["samples", "reference", "numpy-trig", "fast-float", "fast-pulses", "stream", "stream RSS MiB"],
            rows,
        )
    )
    rows = []
    for row in res["summary"]["sim"]:

        def cell(k: str, row: dict = row) -> str:
            v = row.get(k)
            return "-" if not v else f"{v['experiments_per_s']:.1f} ({fmt(v['x_reference'], 0)}x)"

        rows.append([row["n"]] + [cell(k) for k in ("reference", "numpy", "numba", "numba-threads")])
    con.print(
        table(
            "simulation: UMBmark experiments/s (x reference loop)",
            ["robots", "reference", "numpy", "numba", "numba threads"],
            rows,
        )
    )
    for x in res["summary"].get("sweep", []):
        con.print(f"sweep {x['impl']} ({x['backend']}): {x['experiments_per_s']:.1f} experiments/s")
    for k, v in res["summary"]["targets"].items():
        con.print(f"{k}: {v}")
    con.print(f"wrote {out / (stem + '.json')} and {out / (stem + '.md')}", markup=False, soft_wrap=True)
