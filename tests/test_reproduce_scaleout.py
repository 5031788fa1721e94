"""`umbmark reproduce` on a process pool and on a Dask cluster gives the serial study, to the byte."""

from __future__ import annotations

import json
from dataclasses import replace

import pytest

from umbmark.cli import main
from umbmark.studies import reproduce as rep


def _small(**kw):
    # chunk_runs=80 with 5 runs per direction: 2 seeds per group, so 4 seeds make 2 sweep tasks
    return replace(rep.StudyConfig(seeds=4, chunk_runs=80), **kw)


def _bytes(study):
    return json.dumps(study.to_dict(), sort_keys=True)


def test_seed_groups_partition_the_seeds():
    cfg = _small(seeds=5)
    groups = rep.seed_groups(cfg)
    assert groups == [[1, 2], [3, 4], [5]]
    assert rep.seed_groups(rep.StudyConfig(seeds=60)) == [list(range(1, 26)), list(range(26, 51)), list(range(51, 61))]


def test_pool_and_dask_give_the_serial_study():
    distributed = pytest.importorskip("distributed")
    cfg = _small()
    seen = []
    serial = rep.run_study(cfg, pitfall=False, workers=1, on_progress=lambda d, t: seen.append((d, t)))
    assert seen == [(2, 4), (4, 4)]
    ref = _bytes(serial)
    assert _bytes(rep.run_study(cfg, pitfall=False, workers=2)) == ref
    with (
        distributed.LocalCluster(processes=False, n_workers=1, threads_per_worker=2, dashboard_address=None) as cluster,
        distributed.Client(cluster) as client,
    ):
        assert _bytes(rep.run_study(cfg, pitfall=False, dask=client)) == ref
    # the batch a test is simulated in does not change it: one group of 4 seeds, same study
    assert _bytes(rep.run_study(_small(chunk_runs=1000), pitfall=False, workers=1)) == ref


def test_cli_workers_do_not_change_the_output(capsys):
    outs = []
    for w in ("1", "2"):
        assert main(["reproduce", "--json", "--seeds", "3", "--no-pitfall", "--workers", w]) == 0
        outs.append(capsys.readouterr().out)
    assert outs[0] == outs[1]
    json.loads(outs[0])  # pure JSON: no progress bar on stdout


def test_cli_rejects_a_bad_dask_address(capsys):
    assert main(["reproduce", "--seeds", "2", "--no-pitfall", "--dask", "nowhere"]) == 2
    err = capsys.readouterr().err
    assert "scheduler address" in err and "Traceback" not in err
