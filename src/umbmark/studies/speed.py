"""The speed benchmark (``umbmark bench speed``, ``python benchmarks/speed.py``).

Measures, side by side with the obvious alternatives and in the same run:

* **replay** of a synthetic encoder log (1 kHz, integer increments of a robot driving at
  about 0.2 m/s with slowly varying wheel speeds) for 10^5 .. 10^8 samples: samples per second
  and peak RSS of the per-sample Python loop (``reference``), the plain numpy vectorisation
  with one cos and sin per sample (``numpy-trig``: :func:`umbmark.model.odometry.integrate_pulses`
  with ``kernel="trig"``),
  the fast float kernel (``fast-float``: :func:`umbmark.model.odometry.integrate`), the integer
  table kernel with every pose kept (``fast-pulses``: :func:`umbmark.model.odometry.integrate_pulses`)
  and the streaming replay in chunks with only the end pose kept (``stream``:
  :func:`umbmark.model.odometry.replay_stream`). In-memory cases stop at 10^7 samples.
* **simulation** of UMBmark experiments (LabMate geometry, 4 m square, 0.2 m/s, 10 ms
  sampling, 5 cw + 5 ccw runs, ``paper`` noise) for batches of 1 .. 10^4 random robots:
  experiments per second and peak RSS of the per-sample reference loop, the vectorised numpy
  simulator (:func:`umbmark.model.simulate.run_program`) and the batched numba engine
  (:func:`umbmark.model.batch.simulate_batch`), on one thread and on all cores; and the same batch
  split over a process pool or a Dask cluster (:func:`umbmark.studies.sweep.map`).

Every case runs in a fresh subprocess (peak RSS from ``resource.getrusage``, in MiB, includes
the interpreter and numpy: ``rss_base_mib`` is the peak before the case). The slow baselines
are timed on a subset when the case is large (``timed_samples`` / ``timed_robots`` say how
many); their rate does not depend on the size.

Timing: both wall clock and the process's CPU time are recorded (``*_wall``, ``*_cpu``). The
headline rate of a one-thread case is per CPU-second (the one-core throughput, robust when
other jobs share the machine); cases that use several threads or processes (``numba-threads``,
the sweeps) are rated by wall clock. Fast replay cases are warmed up on the full input and
timed best of 3 (best of 2 at 10^7, one pass at 10^8); the reference loops are timed best
of 2, simulation batches of up to 100 robots best of 2, larger ones in one pass.
"""

from __future__ import annotations

import json
import math
import os
import platform
import resource
import subprocess
import sys
import time
from typing import Any

import numpy as np

from umbmark.errors import InputError
from umbmark.viz.text import fmt

__all__ = ["FULL", "QUICK", "machine_info", "run_case_here", "run_benchmark", "markdown"]

FULL = dict(
    replay_sizes=[10**5, 10**6, 10**7, 10**8],
    replay_inmem_max=10**7,
    replay_ref_max=10**6,
    sim_robots=[1, 10, 100, 1000, 10000],
    sim_numpy_max=1000,
    sim_ref_robots=3,
    sweep_robots=1000,
)
QUICK = dict(
    replay_sizes=[10**5],
    replay_inmem_max=10**5,
    replay_ref_max=10**5,
    sim_robots=[1, 10],
    sim_numpy_max=10,
    sim_ref_robots=1,
    sweep_robots=10,
)

CHUNK = 1 << 16
M_PER_PULSE = math.pi * 0.150 / (20 * 500)  # LabMate geometry of umbmark.model.geometry.LABMATE


def machine_info() -> dict:
    """The machine the benchmark runs on.

    Returns
    -------
    dict
        ``nproc``, ``cores_available``, ``cpu_model``, ``python``, ``numpy``, ``platform``,
        ``numba`` (``None`` when not installed) and ``load_average`` where the system has one.
    """
    cpu = platform.processor() or ""
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:  # pragma: no cover - not Linux
        pass
    info = dict(
        nproc=os.cpu_count(),
        cores_available=len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count(),
        cpu_model=cpu,
        python=platform.python_version(),
        numpy=np.__version__,
        platform=platform.platform(),
    )
    try:
        import numba

        info["numba"] = numba.__version__
    except ImportError:  # pragma: no cover
        info["numba"] = None
    try:
        info["load_average"] = [round(x, 2) for x in os.getloadavg()]
    except OSError:  # pragma: no cover
        pass
    return info


# ---------------------------------------------------------------- synthetic data
def log_chunk(seed: int, i: int, n: int):
    """One chunk of the synthetic 1 kHz encoder log.

    Integer increments of each wheel, about 4 pulses per ms (0.2 m/s), with wheel speeds varying
    slowly over 20 s and +-1 pulse of jitter.

    Parameters
    ----------
    seed : int
        Seed of the log.
    i : int
        Index of the chunk (chunks are :data:`CHUNK` samples long).
    n : int
        Samples in this chunk.

    Returns
    -------
    nl, nr : numpy.ndarray
        The left and right increments (int64).
    """
    rng = np.random.default_rng([seed, i])
    t = (i * CHUNK + np.arange(n)) * 1e-3
    base = 4.25 + 1.5 * np.sin(2 * np.pi * t / 20.0)
    nl = np.rint(base + rng.uniform(-1, 1, n)).astype(np.int64)
    nr = np.rint(base[::-1] + rng.uniform(-1, 1, n)).astype(np.int64)
    return nl, nr


def _log(n, seed=1):
    parts = [log_chunk(seed, i, min(CHUNK, n - i * CHUNK)) for i in range(-(-n // CHUNK))]
    return np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts])


def _robots(n, seed=7):
    from umbmark.model.geometry import ErrorParams

    z = np.random.default_rng(seed).standard_normal((n, 2))  # robot i is the same for every n
    return [ErrorParams(ed=1.0 + 2e-3 * float(a), eb=1.0 + 1e-2 * float(b)) for a, b in z]


def _clock():
    return np.array([time.perf_counter(), time.process_time()])


def _rss_mib():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


# ---------------------------------------------------------------- one case, in this process
def _replay_case(c):
    from umbmark.model import geometry as kinematics
    from umbmark.model import odometry
    from umbmark.studies import reference

    n, impl = c["n"], c["impl"]
    params = kinematics.OdometryParams(M_PER_PULSE, M_PER_PULSE * 1.0005, 0.340)
    if impl == "stream":
        gen = np.zeros(2)

        def chunks(m):
            nonlocal gen
            for i in range(-(-m // CHUNK)):
                g0 = _clock()
                ch = log_chunk(1, i, min(CHUNK, m - i * CHUNK))
                gen += _clock() - g0
                yield ch

        odometry.replay_stream(chunks(min(n, 4 * CHUNK)), params=params)  # warm-up
        rss0 = _rss_mib()
        best = np.full(2, np.inf)
        for _ in range(1 if n > 10**7 else 3):
            gen[:] = 0.0
            t0 = _clock()
            res = odometry.replay_stream(chunks(n), params=params)
            best = np.minimum(best, _clock() - t0 - gen)  # generating the synthetic log is not timed
        return dict(
            seconds=best[0],
            cpu_seconds=best[1],
            timed_samples=n,
            generation_seconds=gen[0],
            end=[res.x, res.y, res.theta],
            rss_base_mib=rss0,
        )
    m = min(n, c.get("cap", n))
    nl, nr = _log(m)
    if impl == "reference":

        def fn(a, b):
            return reference.integrate_pulses(a, b, params)
    elif impl == "numpy-trig":

        def fn(a, b):
            return odometry.integrate_pulses(a, b, params, kernel="trig")
    elif impl == "fast-float":
        nl = nl * params.left_m_per_pulse
        nr = nr * params.right_m_per_pulse

        def fn(a, b):
            return odometry.integrate(a, b, params.wheelbase_m)
    elif impl == "fast-pulses":

        def fn(a, b):
            return odometry.integrate_pulses(a, b, params)
    else:
        raise InputError(f"unknown replay implementation {impl!r}")
    # warm-up (first-call costs, the allocator's first touch of large arrays: not throughput)
    if impl == "reference":
        fn(nl[:1000], nr[:1000])
    else:
        fn(nl, nr)
    rss0 = _rss_mib()
    repeat = 2 if impl == "reference" else (3 if m <= 10**6 else 2)
    best = np.full(2, np.inf)
    for _ in range(repeat):
        t0 = _clock()
        x, y, th = fn(nl, nr)
        best = np.minimum(best, _clock() - t0)
        end = [float(x[-1]), float(y[-1]), float(th[-1])]
        del x, y, th
    return dict(seconds=best[0], cpu_seconds=best[1], timed_samples=m, repeats=repeat, end=end, rss_base_mib=rss0)


def _sim_case(c):
    from umbmark.model import batch
    from umbmark.studies import reference

    n, impl = c["n"], c["impl"]
    m = min(n, c.get("cap", n))
    robots = _robots(m)
    seeds = list(range(m))
    if impl.startswith("numba"):
        batch.simulate_batch(robots[:1], n_runs=1, noise="paper", engine="numba")  # compile / load the cache
    if impl == "reference":

        def fn():
            return [reference.simulate_umbmark(e, n_runs=5, noise="paper", seed=s) for e, s in zip(robots, seeds)]
    elif impl == "numpy":

        def fn():
            return batch.simulate_batch(robots, n_runs=5, noise="paper", seeds=seeds, engine="numpy")
    elif impl == "numba":

        def fn():
            return batch.simulate_batch(robots, n_runs=5, noise="paper", seeds=seeds, engine="numba", threads=1)
    elif impl == "numba-threads":

        def fn():
            return batch.simulate_batch(
                robots,
                n_runs=5,
                noise="paper",
                seeds=seeds,
                engine="numba",
                threads=c.get("threads") or len(os.sched_getaffinity(0)),
                chunk_runs=64,
            )
    else:
        raise InputError(f"unknown simulation implementation {impl!r}")
    rss0 = _rss_mib()
    # best of 2 for the baseline and for small batches (a load spike on a shared machine
    # would otherwise decide the ratio); one pass for the long ones
    repeat = 2 if (impl == "reference" or m <= 100) else 1
    best = np.full(2, np.inf)
    for _ in range(repeat):
        t0 = _clock()
        tabs = fn()
        best = np.minimum(best, _clock() - t0)
    first = tabs[0]
    return dict(
        seconds=best[0],
        cpu_seconds=best[1],
        timed_robots=m,
        repeats=repeat,
        first_x_abs_mm=[round(float(v) * 1e3, 6) for v in np.asarray(first.x_abs)[:2]],
        rss_base_mib=rss0,
    )


def _sweep_part(args):
    """One task of the sweep case: a part of the robots simulated as one batch (module level:
    picklable)."""
    from umbmark.model import batch

    seeds, ed, eb = args
    from umbmark.model.geometry import ErrorParams

    tabs = batch.simulate_batch(
        [ErrorParams(ed=a, eb=b) for a, b in zip(ed, eb)], n_runs=5, noise="paper", seeds=seeds, engine="auto"
    )
    return [float(np.asarray(t.x_abs)[0]) for t in tabs]


def _sweep_case(c):
    from umbmark.studies import sweep

    n = c["n"]
    robots = _robots(n)
    workers = c.get("workers")
    parts = sweep.split(list(range(n)), max(1, 4 * (workers or sweep.local_cores())))
    items = [(p, [robots[i].ed for i in p], [robots[i].eb for i in p]) for p in parts]
    rss0 = _rss_mib()
    t0 = _clock()
    res = sweep.map(_sweep_part, items, workers=workers, dask=c.get("dask"))
    t = (_clock() - t0)[0]
    flat = [v for r in res for v in r]
    return dict(
        seconds=t,
        timed_robots=n,
        first_x_abs_mm=[round(v * 1e3, 6) for v in flat[:2]],
        backend=sweep.describe_backend(workers, c.get("dask")),
        rss_base_mib=rss0,
    )


def run_case_here(c: dict) -> dict:
    """Run one case of the plan in this process.

    Parameters
    ----------
    c : dict
        The case: ``kind`` (``replay``, ``sim``, ``sweep``), ``impl``, ``n`` and its options.

    Returns
    -------
    dict
        The timings of the case, its ``kind``, ``impl``, ``n`` and the peak RSS ``rss_peak_mib``.

    Raises
    ------
    InputError
        If the implementation is unknown.
    """
    kind = c["kind"]
    out = {"replay": _replay_case, "sim": _sim_case, "sweep": _sweep_case}[kind](c)
    out["rss_peak_mib"] = _rss_mib()
    out.update({k: c[k] for k in ("kind", "impl", "n") if k in c})
    return out


def _run_isolated(c: dict, timeout: float) -> dict:
    p = subprocess.run(
        [sys.executable, "-m", "umbmark.studies._speed_child", json.dumps(c)],
        capture_output=True,
        text=True,
        timeout=timeout,
    )
    if p.returncode != 0:
        err = (p.stderr.strip().splitlines() or ["no output"])[-1]
        return dict(c, error=err)
    return json.loads(p.stdout.strip().splitlines()[-1])


# ---------------------------------------------------------------- the whole benchmark
def _plan(cfg, dask=None, workers=None):
    cases = []
    for n in cfg["replay_sizes"]:
        cases.append(dict(kind="replay", impl="reference", n=n, cap=cfg["replay_ref_max"]))
        if n <= cfg["replay_inmem_max"]:
            for impl in ("numpy-trig", "fast-float", "fast-pulses"):
                cases.append(dict(kind="replay", impl=impl, n=n))
        cases.append(dict(kind="replay", impl="stream", n=n))
    for n in cfg["sim_robots"]:
        cases.append(dict(kind="sim", impl="reference", n=n, cap=cfg["sim_ref_robots"]))
        if n <= cfg["sim_numpy_max"]:
            cases.append(dict(kind="sim", impl="numpy", n=n))
        cases.append(dict(kind="sim", impl="numba", n=n))
        if n >= 100:
            cases.append(dict(kind="sim", impl="numba-threads", n=n, threads=workers))
    if cfg["sweep_robots"]:
        cases.append(dict(kind="sweep", impl="pool", n=cfg["sweep_robots"], workers=workers))
    if dask and cfg["sweep_robots"]:
        cases.append(dict(kind="sweep", impl="dask", n=cfg["sweep_robots"], workers=workers, dask=dask))
    return cases


def run_benchmark(
    quick: bool = False,
    isolate: bool = True,
    progress=None,
    dask=None,
    workers=None,
    timeout: float = 3600.0,
    **overrides,
) -> dict:
    """Run the benchmark: every case of the plan, each in a fresh process unless ``isolate`` is off.

    Parameters
    ----------
    quick : bool
        Start from :data:`QUICK` instead of :data:`FULL`.
    isolate : bool
        Run every case in its own subprocess (its own peak RSS).
    progress : callable, optional
        Called with each finished case (a dict).
    dask : str, optional
        Also time the sweep on a Dask cluster (an address or ``"local"``).
    workers : int, optional
        Local processes of the pool sweep and threads of ``numba-threads`` (default: all cores).
    timeout : float
        Seconds an isolated case may take.
    **overrides
        Replace entries of :data:`FULL` / :data:`QUICK` (``None`` keeps the entry).

    Returns
    -------
    dict
        JSON-able: ``machine``, ``quick``, ``config``, ``cases`` (one dict per case, with its
        rates) and ``summary``.

    Raises
    ------
    InputError
        If an override names no setting.
    """
    cfg = dict(QUICK if quick else FULL)
    for k, v in overrides.items():
        if k not in cfg:
            raise InputError(f"unknown benchmark setting {k!r}")
        if v is not None:
            cfg[k] = v
    info = machine_info()
    results = []
    for c in _plan(cfg, dask, workers):
        r = _run_isolated(c, timeout) if isolate else dict(run_case_here(c))
        _rates(r)
        results.append(r)
        if progress:
            progress(r)
    return dict(machine=info, quick=quick, config=cfg, cases=results, summary=_summary(results))


def _rates(r):
    if "error" in r:
        return
    key, size = (
        ("samples_per_s", r["timed_samples"]) if r["kind"] == "replay" else ("experiments_per_s", r["timed_robots"])
    )
    r[key + "_wall"] = size / r["seconds"] if r["seconds"] > 0 else None
    cpu = r.get("cpu_seconds")
    r[key + "_cpu"] = size / cpu if cpu else None
    # the headline rate: per CPU-second for one-thread cases (robust on a shared machine),
    # wall clock for cases that use several threads or processes
    multi = r["kind"] == "sweep" or r.get("impl") == "numba-threads"
    r[key] = r[key + "_wall"] if (multi or not cpu) else r[key + "_cpu"]


def _get(results, kind, impl, n):
    for r in results:
        if r.get("kind") == kind and r.get("impl") == impl and r.get("n") == n and "error" not in r:
            return r
    return None


def _summary(results):
    s: dict[str, Any] = {"replay": [], "sim": [], "targets": {}}
    for n in sorted({r["n"] for r in results if r["kind"] == "replay"}):
        ref = _get(results, "replay", "reference", n)
        row = {"n": n}
        for impl in ("reference", "numpy-trig", "fast-float", "fast-pulses", "stream"):
            r = _get(results, "replay", impl, n)
            if r:
                row[impl] = dict(
                    samples_per_s=r["samples_per_s"],
                    rss_peak_mib=r["rss_peak_mib"],
                    x_reference=(r["samples_per_s"] / ref["samples_per_s"]) if ref else None,
                )
        s["replay"].append(row)
    for n in sorted({r["n"] for r in results if r["kind"] == "sim"}):
        ref = _get(results, "sim", "reference", n)
        row = {"n": n}
        for impl in ("reference", "numpy", "numba", "numba-threads"):
            r = _get(results, "sim", impl, n)
            if r:
                row[impl] = dict(
                    experiments_per_s=r["experiments_per_s"],
                    rss_peak_mib=r["rss_peak_mib"],
                    x_reference=(r["experiments_per_s"] / ref["experiments_per_s"]) if ref else None,
                )
        s["sim"].append(row)
    for r in results:
        if r["kind"] == "sweep" and "error" not in r:
            s.setdefault("sweep", []).append(
                dict(impl=r["impl"], n=r["n"], backend=r.get("backend"), experiments_per_s=r["experiments_per_s"])
            )
    t = s["targets"]
    big = [row for row in s["replay"] if row["n"] >= 10**6]
    best = [max((row.get(k, {}).get("samples_per_s") or 0) for k in ("fast-pulses", "stream")) for row in big]
    if big:
        t["replay_min_samples_per_s_at_1e6_plus"] = min(best)
        t["replay_min_x_reference_at_1e6_plus"] = min(
            max((row.get(k, {}).get("x_reference") or 0) for k in ("fast-pulses", "stream")) for row in big
        )
        t["replay_target_met"] = (
            t["replay_min_samples_per_s_at_1e6_plus"] >= 20e6 and t["replay_min_x_reference_at_1e6_plus"] >= 10
        )
    st = _get(results, "replay", "stream", 10**8)
    if st:
        t["stream_1e8_rss_peak_mib"] = st["rss_peak_mib"]
        t["stream_target_met"] = st["rss_peak_mib"] < 1024
    sim_1000 = next((r for r in s["sim"] if r["n"] == 1000), None)
    if sim_1000 and "numba" in sim_1000:
        t["sim_1000_x_reference_one_thread"] = sim_1000["numba"]["x_reference"]
        if "numba-threads" in sim_1000:
            t["sim_1000_x_reference_threads"] = sim_1000["numba-threads"]["x_reference"]
        t["sim_target_met_one_thread"] = (sim_1000["numba"]["x_reference"] or 0) >= 30
    res_pool = _get(results, "sweep", "pool", next(iter([x["n"] for x in s.get("sweep", [])]), None))
    res_dask = _get(results, "sweep", "dask", res_pool["n"] if res_pool else None)
    if res_pool and res_dask:
        t["dask_same_numbers_as_pool"] = res_pool["first_x_abs_mm"] == res_dask["first_x_abs_mm"]
    return s


def markdown(res: dict) -> str:
    """The results as Markdown tables (written beside the JSON).

    Parameters
    ----------
    res : dict
        The output of :func:`run_benchmark`.

    Returns
    -------
    str
    """
    m = res["machine"]
    lines = [
        f"# Speed benchmark{' (quick)' if res['quick'] else ''}",
        "",
        f"Machine: {m['cpu_model']}, nproc {m['nproc']}, Python {m['python']}, numpy {m['numpy']}, "
        f"numba {m.get('numba')}, load average at start {m.get('load_average')}.",
        "",
        "Rates per CPU-second of the benchmark process for one-thread cases, wall clock for threads "
        "and process pools (see umbmark/studies/speed.py).",
        "",
        "## Replay (million samples/s; x = ratio to the per-sample Python loop; peak RSS MiB)",
        "",
        "| samples | reference | numpy-trig | fast-float | fast-pulses | stream | stream RSS |",
        "|---|---|---|---|---|---|---|",
    ]
    for row in res["summary"]["replay"]:
        cells = []
        for impl in ("reference", "numpy-trig", "fast-float", "fast-pulses", "stream"):
            v = row.get(impl)
            cells.append("-" if not v else f"{fmt(v['samples_per_s'], 2, scale=1e6)} ({fmt(v['x_reference'], 0)}x)")
        rss = row.get("stream", {}).get("rss_peak_mib")
        lines.append(f"| {row['n']:.0e} | " + " | ".join(cells) + f" | {fmt(rss, 0)} |")
    lines += [
        "",
        "## Simulation (UMBmark experiments/s, 10 runs each, paper noise, 10 ms; x = ratio to the reference loop)",
        "",
        "| robots | reference | numpy | numba (1 thread) | numba (threads) | numba RSS |",
        "|---|---|---|---|---|---|",
    ]
    for row in res["summary"]["sim"]:
        cells = []
        for impl in ("reference", "numpy", "numba", "numba-threads"):
            v = row.get(impl)
            cells.append("-" if not v else f"{fmt(v['experiments_per_s'], 1)} ({fmt(v['x_reference'], 0)}x)")
        rss = row.get("numba", {}).get("rss_peak_mib")
        lines.append(f"| {row['n']} | " + " | ".join(cells) + f" | {fmt(rss, 0)} |")
    if res["summary"].get("sweep"):
        lines += ["", "## Sweep scale-out (experiments/s)", ""]
        for x in res["summary"]["sweep"]:
            lines.append(
                f"- {x['impl']} ({x['backend']}): {x['n']} robots, {fmt(x['experiments_per_s'], 1)} experiments/s"
            )
    lines += ["", "## Targets", ""]
    for k, v in res["summary"]["targets"].items():
        lines.append(f"- {k}: {v}")
    errs = [c for c in res["cases"] if "error" in c]
    if errs:
        lines += ["", "## Failed cases", ""] + [f"- {c['kind']} {c['impl']} {c['n']}: {c['error']}" for c in errs]
    return "\n".join(lines) + "\n"
