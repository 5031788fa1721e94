"""The accuracy benchmark's cells on a process pool and on a Dask cluster: the serial results."""

from __future__ import annotations

import json
from dataclasses import replace

import pytest

from umbmark.cli import main
from umbmark.errors import InputError
from umbmark.studies.accuracy import QUICK, run_accuracy

# smaller than --quick: one E_d, two E_b values, 2 robots per noisy cell (8 cells)
SMALL = replace(QUICK, ed_departures=(0.02,), eb_values=(0.9995, 2.5), robots=2)


def _numbers(res):
    return json.dumps({k: res[k] for k in ("cells", "floors", "summary")}, sort_keys=True)


def test_pool_and_dask_give_the_serial_results():
    distributed = pytest.importorskip("distributed")
    seen = []
    serial = run_accuracy(replace(SMALL, workers=1), progress=lambda d, t: seen.append((d, t)))
    assert seen == [(i, 8) for i in range(1, 9)]
    assert serial["backend"] == "this process"
    ref = _numbers(serial)
    pool = run_accuracy(replace(SMALL, workers=2))
    assert pool["backend"] == "process pool, 2 workers"
    assert _numbers(pool) == ref
    with (
        distributed.LocalCluster(processes=False, n_workers=1, threads_per_worker=2, dashboard_address=None) as cluster,
        distributed.Client(cluster) as client,
    ):
        assert _numbers(run_accuracy(SMALL, dask=client)) == ref
        assert _numbers(run_accuracy(SMALL, dask=cluster.scheduler_address)) == ref


def test_bad_workers_are_rejected():
    with pytest.raises(InputError, match="workers"):
        run_accuracy(replace(SMALL, workers=0))


@pytest.mark.slow
def test_cli_workers_and_json_stay_pure(tmp_path, capsys):
    outs = []
    for w in ("1", "2"):
        assert (
            main(
                ["bench", "accuracy", "--quick", "--robots", "1", "--workers", w, "--out", str(tmp_path / w), "--json"]
            )
            == 0
        )
        cap = capsys.readouterr()
        assert cap.err == ""  # no progress bar when stderr is not a terminal
        outs.append(json.loads(cap.out))
    assert outs[0]["summary"] == outs[1]["summary"] and outs[0]["floors"] == outs[1]["floors"]
    assert outs[1]["backend"] == "process pool, 2 workers"
    assert (tmp_path / "1" / "accuracy.csv").read_text() == (tmp_path / "2" / "accuracy.csv").read_text()
