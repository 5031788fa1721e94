"""``umbmark fleet``: a fleet's recordings calibrated on a local Dask cluster into one history;
each recorded once (re-runs skip what is recorded, a killed worker's recording is done again and
recorded once), a failed recording named while the rest go on. On PostgreSQL too when
UMBMARK_TEST_POSTGRES_URL names a database the tests may wipe."""

from __future__ import annotations

import contextlib
import io
import json
import os
import signal
from collections import Counter
from pathlib import Path

import pytest

from umbmark.cli import main
from umbmark.cli.fleet import _calibrate, _record
from umbmark.history import open_history
from umbmark.io.intervals_csv import write_intervals_csv
from umbmark.studies.drift import draw_fleet, session_intervals
from umbmark.studies.fleet import plan_fleet, run_fleet

distributed = pytest.importorskip("distributed")

GEO = ["--wheel-diameter-mm", "100", "--wheelbase-mm", "300"]


def run(*args: str) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(list(args))
    return code, out.getvalue(), err.getvalue()


def _fleet_dir(root: Path, robots: int, sessions: int, n: int = 120) -> Path:
    for r in draw_fleet(robots, sessions, 0, seed=3):
        d = root / r.name
        d.mkdir(parents=True)
        for k in range(sessions):
            write_intervals_csv(session_intervals(r.truth(k), seed=100 * k + len(r.name), n=n), d / f"s{k:03d}.csv")
    return root


@pytest.fixture(params=["sqlite", "postgresql"])
def fleet_db(request, tmp_path):
    """The fleet's history: an SQLite file, and PostgreSQL (conftest's postgres_url: skipped
    without a server)."""
    if request.param == "postgresql":
        return request.getfixturevalue("postgres_url")
    return str(tmp_path / "fleet.sqlite")


def _hashes(db):
    with open_history(db) as h:
        return Counter((r.robot, r.input_sha256) for r in h.records())


def test_every_recording_once_a_failure_named_and_reruns_skip(tmp_path):
    root = _fleet_dir(tmp_path / "fleet", 3, 3)
    (root / "robot-01" / "broken.csv").write_text("dt_s,left_rad\n1,2\n")
    db = str(tmp_path / "h.sqlite")
    code, out, err = run("fleet", str(root), *GEO, "--db", db, "--json")
    assert code == 2, err
    d = json.loads(out)
    assert (d["recorded"], d["skipped"], d["failed"]) == (9, 0, 1)
    (bad,) = [o for o in d["outcomes"] if o["status"] == "failed"]
    assert bad["robot"] == "robot-01" and bad["path"].endswith("broken.csv") and "no header" in bad["error"]
    counts = _hashes(db)
    assert len(counts) == 9 and set(counts.values()) == {1}
    # a re-run does only what is new: nothing
    code, out, _ = run("fleet", str(root), *GEO, "--db", db, "--json")
    assert json.loads(out)["skipped"] == 9 and _hashes(db) == counts
    # the text names each recording and the totals
    (root / "robot-01" / "broken.csv").unlink()
    write_intervals_csv(session_intervals(draw_fleet(1, 1, 0)[0].truth(0), seed=77), root / "robot-02" / "new.csv")
    code, out, _ = run("fleet", str(root), *GEO, "--db", db)
    assert code == 0 and "robot-02: " in out and "new.csv: recorded as #10" in out
    assert "1 recorded, 9 already recorded, 0 failed" in out


def test_a_killed_worker_s_recording_is_done_again_and_recorded_once(tmp_path, fleet_db):
    # 100 recordings on a local cluster of two workers; one worker killed while it calibrates
    root = _fleet_dir(tmp_path / "fleet", 5, 20, n=60)
    jobs = plan_fleet(root, tuple(GEO))
    db = fleet_db
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None)
    client = distributed.Client(cluster)
    killed = []

    def told(outcome, done, total):
        if done == 10 and not killed:
            busy = [w for w, tasks in client.processing().items() if tasks]
            pid = client.run(os.getpid, workers=[busy[0]])[busy[0]]
            killed.append(pid)
            os.kill(pid, signal.SIGKILL)

    try:
        summary = run_fleet(jobs, _calibrate, _record, db, dask=client, on_outcome=told)
    finally:
        client.close()
        cluster.close()
    assert killed
    assert summary.count("recorded") == 100 and summary.count("failed") == 0
    counts = _hashes(db)
    assert len(counts) == 100 and set(counts.values()) == {1}


def test_manifest_and_refusals(tmp_path):
    root = _fleet_dir(tmp_path / "fleet", 2, 2)
    manifest = tmp_path / "fleet.yaml"
    manifest.write_text(
        "robots:\n"
        "  alpha:\n    recordings: [fleet/robot-00/s000.csv, fleet/robot-00/s001.csv]\n"
        "    args: [--wheel-diameter-mm, 100, --wheelbase-mm, 300]\n"
        "  beta:\n    recordings: [fleet/robot-01/s000.csv]\n    args: --wheel-diameter-mm 100 --wheelbase-mm 300\n"
    )
    db = str(tmp_path / "h.sqlite")
    code, out, err = run("fleet", str(manifest), "--db", db, "--json")
    assert code == 0, err
    assert json.loads(out)["recorded"] == 3
    assert {r for r, _ in _hashes(db)} == {"alpha", "beta"}
    cases = [
        ([str(root), "--wheel-diameter-mm", "100", "--wheelbase-mm", "300", "--no-such-option"], "no-such-option"),
        ([str(root), "--wheel-diameter-mm", "0.1", "--wheelbase-mm", "300"], "0.1 mm"),
        ([str(tmp_path / "fleet" / "robot-00")], "no recordings"),
        ([str(manifest), *GEO], "none after it"),
    ]
    bad = tmp_path / "bad.yaml"
    bad.write_text("robots:\n  alpha:\n    recordings: [missing.bag]\n")
    cases.append(([str(bad)], "missing.bag does not exist"))
    for args, message in cases:
        before = _hashes(db)
        code, out, err = run("fleet", *args, "--db", db)
        assert code == 2 and message in err and len(err.strip().splitlines()) == 1, (args, err)
        assert _hashes(db) == before
