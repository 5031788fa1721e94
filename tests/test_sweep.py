"""umbmark.studies.sweep: the process pool and a Dask cluster return exactly the numbers of a plain loop."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from umbmark.errors import InputError
from umbmark.metrics import umbmark_figures
from umbmark.model import batch
from umbmark.model.geometry import ErrorParams
from umbmark.studies import sweep


def emax_of_robots(item):
    """A seeded Monte Carlo task: E_max,syst [mm] of a few simulated robots (module level:
    picklable)."""
    seeds, eds = item
    tabs = batch.simulate_batch(
        [ErrorParams(ed=e, eb=0.99) for e in eds], side_m=1.0, n_runs=2, noise="paper", seeds=seeds
    )
    return [umbmark_figures(t).emax_syst * 1e3 for t in tabs]


def square(x):
    return x * x


def fail_on_three(x):
    if x == 3:
        raise ValueError("three")
    return x


def _items():
    rng = np.random.default_rng(0)
    eds = list(1.0 + rng.normal(0, 2e-3, 8))
    return [([s for s in range(i, i + 2)], eds[i : i + 2]) for i in range(0, 8, 2)]


def test_pool_equals_plain_loop():
    items = _items()
    plain = [emax_of_robots(it) for it in items]
    assert sweep.map(emax_of_robots, items, workers=1) == plain
    assert sweep.map(emax_of_robots, items, workers=2) == plain
    assert sweep.map(emax_of_robots, items) == plain  # all cores
    assert sweep.map(square, range(50), workers=2, chunksize=7) == [x * x for x in range(50)]


def test_dask_local_cluster_equals_local_run():
    distributed = pytest.importorskip("distributed")
    items = _items()
    local = sweep.map(emax_of_robots, items, workers=2)
    with (
        distributed.LocalCluster(processes=False, n_workers=1, threads_per_worker=2, dashboard_address=None) as cluster,
        distributed.Client(cluster) as client,
    ):
        assert sweep.map(emax_of_robots, items, dask=client) == local
        # by address, as --dask tcp://host:port does
        assert sweep.map(square, [3, 1, 2], dask=cluster.scheduler_address) == [9, 1, 4]
        seen = []
        assert sweep.map(square, [3, 1, 2], dask=client, on_progress=lambda d, t: seen.append((d, t))) == [9, 1, 4]
        assert seen == [(1, 3), (2, 3), (3, 3)]


def test_errors_propagate_and_bad_arguments():
    with pytest.raises(ValueError, match="three"):
        sweep.map(fail_on_three, range(6), workers=2)
    with pytest.raises(InputError, match="workers"):
        sweep.map(square, [1], workers=0)
    with pytest.raises(InputError, match="scheduler address"):
        sweep.map(square, [1], dask="myhost")
    with pytest.raises(InputError, match="chunksize"):
        sweep.map(square, [1], chunksize=0)
    assert sweep.map(square, [], workers=2) == []


@given(st.lists(st.integers(), max_size=40), st.integers(1, 12))
def test_split_is_an_ordered_partition(items, parts):
    pieces = sweep.split(items, parts)
    assert [x for p in pieces for x in p] == items
    assert len(pieces) <= parts and all(pieces)
    if pieces:
        sizes = [len(p) for p in pieces]
        assert max(sizes) - min(sizes) <= 1


def test_describe_backend():
    assert sweep.describe_backend(1) == "this process"
    assert "4 workers" in sweep.describe_backend(4)
    assert "tcp://h:1" in sweep.describe_backend(None, "tcp://h:1")


def test_on_progress_counts_every_item_once():
    for workers in (1, 2):
        seen: list = []
        assert sweep.map(
            square, range(7), workers=workers, on_progress=lambda d, t, seen=seen: seen.append((d, t))
        ) == [x * x for x in range(7)]
        assert seen == [(i, 7) for i in range(1, 8)]
    seen = []
    with pytest.raises(ValueError, match="three"):
        sweep.map(fail_on_three, range(6), workers=1, on_progress=lambda d, t: seen.append(d))
    assert seen == [1, 2, 3]  # items 0, 1, 2 finished before the failure
