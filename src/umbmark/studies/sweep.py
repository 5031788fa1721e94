"""Scale-out of Monte Carlo sweeps: a process pool over all local cores, or a Dask cluster.

    from umbmark.studies import sweep
    results = sweep.map(fn, items)                      # all local cores
    results = sweep.map(fn, items, workers=1)           # in this process, one by one
    results = sweep.map(fn, items, dask="tcp://10.0.0.5:8786")   # an existing Dask cluster
    results = sweep.map(fn, items, dask="local")        # a Dask cluster on the local machine

``fn`` is called once per item and must be picklable (a module-level function, not a lambda);
results come back in input order. Carry the seeds in the items (``fn`` must not draw from a
global generator): then every backend returns exactly the same numbers as a plain loop
``[fn(item) for item in items]``.

Dask is optional: ``pip install -e ".[dask]"``.
"""

from __future__ import annotations

import builtins
import os
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import ProcessPoolExecutor

from umbmark.errors import InputError

__all__ = ["map", "local_cores", "split", "describe_backend"]


def local_cores() -> int:
    """Cores this process may run on.

    Returns
    -------
    int
    """
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        return os.cpu_count() or 1


def split(items: Sequence, parts: int) -> list[list]:
    """``items`` cut into at most ``parts`` contiguous, nearly equal, non-empty pieces (to batch
    many small items into few tasks; concatenating the pieces gives ``items`` back).

    Parameters
    ----------
    items : sequence
        The items.
    parts : int
        The largest number of pieces.

    Returns
    -------
    list of list
        The pieces, in order (none for no items).

    Raises
    ------
    InputError
        If ``parts`` is below 1.
    """
    items = list(items)
    if parts < 1:
        raise InputError(f"parts must be >= 1, got {parts}")
    parts = min(parts, len(items)) or 1
    q, r = divmod(len(items), parts)
    out, a = [], 0
    for i in range(parts):
        b = a + q + (i < r)
        out.append(items[a:b])
        a = b
    return [p for p in out if p] if items else []


def describe_backend(workers: int | None = None, dask=None) -> str:
    """A one-line description of where :func:`map` would run.

    Parameters
    ----------
    workers : int, optional
        As for :func:`map`.
    dask : str or distributed.Client, optional
        As for :func:`map`.

    Returns
    -------
    str
        ``"this process"``, ``"process pool, N workers"``, ``"dask ADDRESS"`` or ``"dask client"``.
    """
    if dask is not None:
        return f"dask {dask}" if isinstance(dask, str) else "dask client"
    n = local_cores() if workers is None else workers
    return "this process" if n == 1 else f"process pool, {n} workers"


def _check_workers(workers):
    if workers is None:
        return local_cores()
    if not isinstance(workers, int) or isinstance(workers, bool) or workers < 1:
        raise InputError(f"workers must be a positive integer, got {workers!r}")
    return workers


def map(
    fn: Callable,
    items: Iterable,
    workers: int | None = None,
    dask=None,
    chunksize: int = 1,
    mp_context=None,
    on_progress: Callable[[int, int], None] | None = None,
) -> list:
    """``[fn(item) for item in items]``, in parallel.

    Parameters
    ----------
    fn : callable
        Called once per item; picklable (a module-level function) for a pool or Dask.
    items : iterable
        The items.
    workers : int, optional
        Local processes (``None``: all local cores; ``1``: no pool, in this process).
    dask : str or distributed.Client, optional
        ``None`` (local pool), a scheduler address such as ``"tcp://host:8786"``, ``"local"``
        (start a Dask cluster on the local machine with ``workers`` processes) or a client.
    chunksize : int
        Items sent to a pool worker at a time.
    mp_context : multiprocessing context, optional
        The start method of the pool's processes.
    on_progress : callable, optional
        ``on_progress(done, total)``, called in this process each time an item has finished.

    Returns
    -------
    list
        ``fn(item)`` of every item, in input order.

    Raises
    ------
    InputError
        For bad ``workers``, ``chunksize`` or ``dask``, a missing Dask or an unreachable scheduler.
        An exception raised by ``fn`` is raised here.
    """
    items = list(items)
    if chunksize < 1:
        raise InputError(f"chunksize must be >= 1, got {chunksize}")
    tick = _ticker(on_progress, len(items))
    if dask is not None:
        return _dask_map(fn, items, dask, workers, tick)
    n = _check_workers(workers)
    if n == 1 or len(items) <= 1:
        out = []
        for it in items:
            out.append(fn(it))
            tick()
        return out
    out = []
    with ProcessPoolExecutor(max_workers=min(n, len(items)), mp_context=mp_context) as ex:
        for r in ex.map(fn, items, chunksize=chunksize):  # in input order
            out.append(r)
            tick()
    return out


def _ticker(on_progress, total):
    done = 0

    def tick():
        nonlocal done
        done += 1
        if on_progress is not None:
            on_progress(done, total)

    return tick


def _dask_map(fn, items, dask, workers, tick=lambda: None):
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise InputError(
            'Dask is not installed: pip install -e ".[dask]" (or pip install "dask[distributed]")'
        ) from None
    if not items:
        return []
    own: list[Client | LocalCluster] = []  # closed at the end, the client first
    try:
        if isinstance(dask, str):
            if dask == "local":
                n = _check_workers(workers)
                cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None)
                own.append(cluster)
                client = Client(cluster)
            elif "://" in dask:
                try:
                    client = Client(dask, timeout="10s")
                except (OSError, TimeoutError) as e:
                    raise InputError(f"cannot reach the Dask scheduler at {dask}: {e}") from None
            else:
                raise InputError(f"`dask` wants a scheduler address such as tcp://host:8786 or 'local', got {dask!r}")
            own.insert(0, client)
        else:
            client = dask
            if not builtins.all(hasattr(client, a) for a in ("map", "gather")):
                raise InputError("dask must be an address, 'local' or a distributed.Client")
        from distributed import as_completed

        futures = client.map(fn, items, pure=False)
        for _ in as_completed(futures):
            tick()
        return client.gather(futures)
    finally:
        for o in own:
            o.close()
