"""umbmark bench speed: the harness runs, measures, writes its results (speed itself is
measured by the benchmark, not asserted here)."""

import json

import pytest

from umbmark.cli import main
from umbmark.studies import speed as speedbench


def test_quick_cli_writes_results(tmp_path, capsys):
    out = tmp_path / "res"
    assert main(["bench", "speed", "--quick", "--workers", "2", "--out", str(out), "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert (out / "speed-quick.json").exists() and (out / "speed-quick.md").exists()
    on_disk = json.loads((out / "speed-quick.json").read_text())
    assert on_disk["summary"] == res["summary"]
    m = res["machine"]
    assert m["nproc"] >= 1 and m["numpy"] and "cpu_model" in m
    replay = {c["impl"]: c for c in res["cases"] if c["kind"] == "replay"}
    assert set(replay) == {"reference", "numpy-trig", "fast-float", "fast-pulses", "stream"}
    ends = [c["end"] for c in replay.values()]
    for e in ends[1:]:  # every implementation replayed the same log to the same end pose
        assert e == pytest.approx(ends[0], abs=1e-9)
    for c in res["cases"]:
        assert "error" not in c
        assert c["seconds"] > 0 and c["rss_peak_mib"] > 0
    sims = [c for c in res["cases"] if c["kind"] == "sim"]
    firsts = {c["impl"]: c["first_x_abs_mm"] for c in sims if c["n"] == 10}
    for v in firsts.values():  # same robots, same seeds: same numbers from every engine
        assert v == pytest.approx(firsts["numpy"], abs=1e-6)
    assert res["summary"]["sweep"][0]["experiments_per_s"] > 0
    md = (out / "speed-quick.md").read_text()
    assert "| 1e+05 |" in md and "Machine:" in md


def test_dask_sweep_case_matches_pool(tmp_path, capsys):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(
        processes=False, n_workers=1, threads_per_worker=2, dashboard_address=None
    ) as cluster:
        rc = main(
            [
                "bench",
                "speed",
                "--quick",
                "--replay-sizes",
                "1000",
                "--robots",
                "1",
                "--workers",
                "2",
                "--dask",
                cluster.scheduler_address,
                "--out",
                str(tmp_path),
                "--json",
            ]
        )
    assert rc == 0
    res = json.loads(capsys.readouterr().out)
    assert res["summary"]["targets"]["dask_same_numbers_as_pool"] is True


def test_isolated_case_reports_its_own_rss():
    r = speedbench._run_isolated(dict(kind="replay", impl="stream", n=200_000), timeout=120)
    assert "error" not in r
    assert r["timed_samples"] == 200_000 and r["rss_peak_mib"] >= r["rss_base_mib"] > 10


def test_bad_sizes_exit_2(tmp_path, capsys):
    assert main(["bench", "speed", "--quick", "--robots", "ten", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "--robots" in err and len(err.strip().splitlines()) == 1
