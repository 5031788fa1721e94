"""``umbmark fleet``: a fleet's recordings calibrated on a local Dask cluster into one history;
each recorded once (re-runs skip what is recorded, a killed worker's recording is done again and
recorded once, two fleets at once on one history record it once), a failed recording named while
the rest go on; the selfcal options that would write elsewhere refused before any job, manifest
mistakes named by line, no password printed, no scratch folder left, and without Dask one line
saying what to install. On PostgreSQL too when UMBMARK_TEST_POSTGRES_URL names a database the
tests may wipe.

One cluster serves the module (a local one is started by the first test only, to see it leave
nothing behind)."""

from __future__ import annotations

import contextlib
import io
import json
import os
import signal
import subprocess
import sys
import threading
import time
from collections import Counter
from dataclasses import replace
from pathlib import Path

import pytest

from umbmark.cli import main
from umbmark.history import open_history
from umbmark.io.intervals_csv import write_intervals_csv
from umbmark.realrobot.selfcal_settings import SelfcalSettings
from umbmark.studies.drift import draw_fleet, session_intervals

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


@pytest.fixture(scope="module")
def client(tmp_path_factory):
    """A local cluster of two workers for the module's fleets (``--scheduler`` its address)."""
    distributed = pytest.importorskip("distributed")
    scratch = tmp_path_factory.mktemp("dask")
    cluster = distributed.LocalCluster(
        n_workers=2,
        threads_per_worker=1,
        processes=True,
        dashboard_address=":0",
        scheduler_kwargs={"dashboard": False},
        local_directory=str(scratch),
    )
    c = distributed.Client(cluster)
    yield c
    c.close()
    cluster.close()


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


def _jobs(root):
    from umbmark.fleet import plan_fleet

    return [replace(j, settings=SelfcalSettings(0.1, 0.3)) for j in plan_fleet(root, tuple(GEO))]


def test_every_recording_once_a_failure_named_and_reruns_skip(tmp_path, monkeypatch, client):
    pytest.importorskip("distributed")
    root = _fleet_dir(tmp_path / "fleet", 3, 3)
    (root / "robot-01" / "broken.csv").write_text("dt_s,left_rad\n1,2\n")
    # recordings whose file times cannot date a record (a clock in 2099, a copy dated 1965)
    truth = draw_fleet(1, 1, 0)[0].truth(0)
    for name, year, seed in (("future.csv", 2099, 5), ("old.csv", 1965, 6)):
        write_intervals_csv(session_intervals(truth, seed=seed), root / "robot-02" / name)
        t = time.mktime((year, 1, 1, 12, 0, 0, 0, 0, 0))
        os.utime(root / "robot-02" / name, (t, t))
    db = str(tmp_path / "h.sqlite")
    # the local cluster keeps its scratch files in a temporary folder it removes
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    monkeypatch.setattr("tempfile.tempdir", str(tmp))
    code, out, err = run("fleet", str(root), *GEO, "--db", db, "--json")
    assert code == 2, err
    assert list(tmp.iterdir()) == []
    d = json.loads(out)
    assert (d["recorded"], d["skipped"], d["failed"]) == (9, 0, 3)
    failed = {Path(o["path"]).name: o for o in d["outcomes"] if o["status"] == "failed"}
    assert failed["broken.csv"]["robot"] == "robot-01" and "no header" in failed["broken.csv"]["error"]
    assert "2099-01-01" in failed["future.csv"]["error"] and "in the future" in failed["future.csv"]["error"]
    assert "1965-01-01" in failed["old.csv"]["error"] and "before 1970" in failed["old.csv"]["error"]
    counts = _hashes(db)
    assert len(counts) == 9 and set(counts.values()) == {1}
    with open_history(db) as h:
        assert all(1970 < r.time.year < 2099 for r in h.records())
    # a re-run does only what is new: nothing
    address = client.scheduler.address
    code, out, _ = run("fleet", str(root), *GEO, "--db", db, "--scheduler", address, "--json")
    assert json.loads(out)["skipped"] == 9 and _hashes(db) == counts
    # the text names each recording and the totals
    for name in ("robot-01/broken.csv", "robot-02/future.csv", "robot-02/old.csv"):
        (root / name).unlink()
    write_intervals_csv(session_intervals(truth, seed=77), root / "robot-02" / "new.csv")
    code, out, _ = run("fleet", str(root), *GEO, "--db", db, "--scheduler", address)
    assert code == 0 and "robot-02: " in out and "new.csv: recorded as #10" in out
    assert "1 recorded, 9 already recorded, 0 failed" in out


def test_manifest_and_refusals(tmp_path, client):
    root = _fleet_dir(tmp_path / "fleet", 2, 2)
    manifest = tmp_path / "fleet.yaml"
    manifest.write_text(
        "robots:\n"
        "  alpha:\n    recordings: [fleet/robot-00/s000.csv, fleet/robot-00/s001.csv]\n"
        "    args: [--wheel-diameter-mm, 100, --wheelbase-mm, 300]\n"
        "  beta:\n    recordings: [fleet/robot-01/s000.csv]\n    args: --wheel-diameter-mm 100 --wheelbase-mm 300\n"
    )
    db = str(tmp_path / "h.sqlite")
    code, out, err = run("fleet", str(manifest), "--db", db, "--scheduler", client.scheduler.address, "--json")
    assert code == 0, err
    assert json.loads(out)["recorded"] == 3
    assert {r for r, _ in _hashes(db)} == {"alpha", "beta"}
    cases = [
        ([str(root), "--wheel-diameter-mm", "100", "--wheelbase-mm", "300", "--no-such-option"], "no-such-option"),
        ([str(root), "--wheel-diameter-mm", "0.1", "--wheelbase-mm", "300"], "0.1 mm"),
        ([str(tmp_path / "fleet" / "robot-00")], "no recordings"),
        ([str(manifest), *GEO], "none after it"),
        ([str(root), "--wheelbase-mm", "300"], "give the nominal wheel size"),
    ]
    bad = tmp_path / "bad.yaml"
    bad.write_text("robots:\n  alpha:\n    recordings: [missing.bag]\n")
    cases.append(([str(bad)], "missing.bag does not exist"))
    for args, message in cases:
        before = _hashes(db)
        code, out, err = run("fleet", *args, "--db", db)
        assert code == 2 and message in err and len(err.strip().splitlines()) == 1, (args, err)
        assert _hashes(db) == before


def test_the_selfcal_options_that_write_elsewhere_are_refused_before_any_job(tmp_path):
    """What would write besides the fleet's history, or break its bookkeeping, is refused in one
    line naming the option; nothing is written, not even the history."""
    pytest.importorskip("distributed")
    root = _fleet_dir(tmp_path / "fleet", 1, 1, n=40)
    out_file = tmp_path / "out.json"
    db = tmp_path / "h.sqlite"
    cases = [
        (["--robot", "r1", "--record"], "--robot"),
        (["--record"], "--record"),
        (["--save", str(out_file)], "--save"),
        (["--write-config", str(out_file)], "--write-config"),
        (["--recorded-at", "2024-01-01"], "--recorded-at"),
        (["--intervals-out", str(out_file)], "--intervals-out"),
        (["--window", "10min"], "--window"),
        (["--kinematics", "mecanum", "--lx-plus-ly-mm", "400"], "--kinematics mecanum"),
        (["--scan-topic", "/front"], "--scan-topic reads bags"),
    ]
    config = tmp_path / "c.yaml"
    config.write_text("selfcal:\n  record: true\n  robot: r9\n")
    cases.append((["--config", str(config)], "--robot"))
    for extra, flag in cases:
        code, out, err = run("fleet", str(root), *GEO, *extra, "--db", str(db))
        assert code == 2 and len(err.strip().splitlines()) == 1 and "Traceback" not in err, (extra, err)
        assert flag in err and "self-calibration's options" in err, (extra, err)
        assert not out_file.exists() and not db.exists(), extra
    # in a manifest's args: its own --db or --json are refused (named with the robot and the line)
    for args, flag in ((f"--db {tmp_path / 'other.sqlite'}", "--db"), ("--json", "--json"), ("extra.csv", "extra.csv")):
        manifest = tmp_path / "m.yaml"
        rec = "recordings: [fleet/robot-00/s000.csv]"
        manifest.write_text(f"robots:\n  r1:\n    {rec}\n    args: {' '.join(GEO)} {args}\n")
        code, out, err = run("fleet", str(manifest), "--db", str(db))
        assert code == 2 and flag in err and f"robot r1 ({manifest}:2)" in err, err
        assert not db.exists() and not (tmp_path / "other.sqlite").exists()
    # the fleet's own --db given twice: neither silently wins
    code, _, err = run("fleet", str(root), *GEO, "--db", str(db), "--db", str(tmp_path / "two.sqlite"))
    assert code == 2 and "given twice" in err and not db.exists()


def test_manifest_mistakes_are_named_by_line(tmp_path):
    pytest.importorskip("distributed")
    _fleet_dir(tmp_path / "fleet", 1, 2, n=40)
    rec = "    recordings: [fleet/robot-00/s000.csv]\n"
    other = "    recordings: [fleet/robot-00/s001.csv]\n"
    cases = {
        # one robot named twice: the first entry would be dropped
        "robots:\n  r1:\n" + rec + "  r1:\n" + other: (4, "`r1:` given twice (lines 2"),
        "robots:\n  r1:\n" + rec + "    arg: [--wheel-diameter-mm, 100]\n": (4, "unknown key `arg:`"),
        "robot:\n  r1:\n" + rec: (1, "unknown key `robot:`"),
        "robots:\n  r1:\n" + rec + "  r2:\n" + rec: (5, "recording fleet/robot-00/s000.csv is listed already (line 3"),
        "robots:\n  r1:\n    args: [--wheelbase-mm, 300]\n": (2, "needs `recordings:`"),
        "robots: {}\n": (1, "names no robot"),
        "robots:\n  r1:\n\trecordings: []\n": (3, "not a readable YAML manifest"),
    }
    manifest = tmp_path / "m.yaml"
    for text, (line, message) in cases.items():
        manifest.write_text(text)
        code, _, err = run("fleet", str(manifest), *(), "--db", str(tmp_path / "h.sqlite"))
        assert code == 2 and f"{manifest}:{line}: " in err and message in err, (text, err)
        assert len(err.strip().splitlines()) == 1 and not (tmp_path / "h.sqlite").exists()


def test_without_dask_one_line_says_what_to_install(tmp_path):
    """The plain install has no Dask: ``distributed`` made unimportable in a fresh process."""
    root = _fleet_dir(tmp_path / "fleet", 1, 1, n=40)
    code = "import sys\nsys.modules['distributed'] = None\nfrom umbmark.cli import main\nsys.exit(main(sys.argv[1:]))"
    p = subprocess.run(
        [sys.executable, "-c", code, "fleet", str(root), *GEO, "--db", str(tmp_path / "h.sqlite")],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert p.returncode == 2 and p.stdout == "", p.stderr
    assert p.stderr.strip().splitlines() == [
        "umbmark: error: the fleet runs on Dask, which is not installed here: pip install 'umbmark[dask]' "
        "(in a checkout of umbmark: pip install -e '.[dask]')"
    ]


def test_a_scheduler_s_password_is_never_printed(tmp_path):
    pytest.importorskip("distributed")
    root = _fleet_dir(tmp_path / "fleet", 1, 1, n=40)
    for address in ("tcp://user:s3cr3t@127.0.0.1:1", "user:s3cr3t@127.0.0.1:1", "tls://u:s3cr3t@h:8786/x"):
        code, out, err = run("fleet", str(root), *GEO, "--scheduler", address, "--db", str(tmp_path / "h.sqlite"))
        assert code == 2 and "s3cr3t" not in out + err and len(err.strip().splitlines()) == 1, err
        assert "***@" in err and "user name or password" in err
    code, out, err = run("fleet", str(root), *GEO, "--scheduler", "somewhere", "--db", str(tmp_path / "h.sqlite"))
    assert code == 2 and "tcp://host:8786" in err


def test_two_fleets_at_once_on_one_history_record_each_recording_once(tmp_path, monkeypatch, client):
    """Both fleets look up the history before either records (held at their first record): each
    then sends every recording, and the history's guard keeps one record of each."""
    import umbmark.fleet.run as fleet_run

    root = _fleet_dir(tmp_path / "fleet", 2, 3, n=60)
    jobs = _jobs(root)
    db = str(tmp_path / "h.sqlite")
    barrier = threading.Barrier(2, timeout=60)
    record = fleet_run._record
    first = threading.local()

    def held(history, job, result):
        if not getattr(first, "passed", False):
            first.passed = True
            barrier.wait()
        return record(history, job, result)

    monkeypatch.setattr(fleet_run, "_record", held)
    summaries = [None, None]

    def fleet(i):
        summaries[i] = fleet_run.run_fleet(jobs, db, dask=client)

    threads = [threading.Thread(target=fleet, args=(i,)) for i in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(120)
    assert all(s is not None for s in summaries)
    assert sum(s.count("recorded") for s in summaries) == 6 and sum(s.count("skipped") for s in summaries) == 6
    assert all(s.count("failed") == 0 for s in summaries)
    counts = _hashes(db)
    assert len(counts) == 6 and set(counts.values()) == {1}


@pytest.mark.slow
def test_a_killed_worker_s_recording_is_done_again_and_recorded_once(tmp_path, fleet_db, client):
    # 100 recordings on a local cluster of two workers; one worker killed while it calibrates
    # (last in the module: the cluster's nanny starts a new worker)
    from umbmark.fleet import run_fleet

    root = _fleet_dir(tmp_path / "fleet", 5, 20, n=60)
    jobs = _jobs(root)
    killed = []

    def told(outcome, done, total):
        if done == 10 and not killed:
            busy = [w for w, tasks in client.processing().items() if tasks]
            pid = client.run(os.getpid, workers=[busy[0]])[busy[0]]
            killed.append(pid)
            os.kill(pid, signal.SIGKILL)

    summary = run_fleet(jobs, fleet_db, dask=client, on_outcome=told)
    assert killed
    assert summary.count("recorded") == 100 and summary.count("failed") == 0
    counts = _hashes(fleet_db)
    assert len(counts) == 100 and set(counts.values()) == {1}


def test_skipped_checks_reach_the_workers_self_calibration(tmp_path, monkeypatch):
    """``--skip-check`` among the options travels in the settings and is applied on the worker."""
    import umbmark.realrobot.selfcal as selfcal
    from umbmark._check import skipped
    from umbmark.cli.fleet import _jobs as fleet_jobs
    from umbmark.fleet import calibrate_job

    root = _fleet_dir(tmp_path / "fleet", 1, 1, n=40)
    (job,) = fleet_jobs(str(root), (*GEO, "--skip-check", "wheel_units"))
    assert job.settings.skip_checks == {"wheel_units"}
    seen = []
    real = selfcal.selfcal_from_intervals

    def spy(*args, **kwargs):
        seen.append(skipped("wheel_units"))
        return real(*args, **kwargs)

    monkeypatch.setattr(selfcal, "selfcal_from_intervals", spy)
    assert calibrate_job(job).fields is not None and seen == [True]
    assert not skipped("wheel_units")  # only inside the job


def test_a_manifest_names_each_robots_kind(tmp_path, client):
    """A tricycle's recording beside a differential drive's, its kind named in the manifest: each
    calibrated by its own kind's self-calibration and recorded with its own parameters, which
    drift reads; a kind given twice, or one no robot is, named by line."""
    import kinematic_bags

    drive = kinematic_bags.write_short_drive(tmp_path, "tricycle", duration_s=30.0)
    _fleet_dir(tmp_path / "fleet", 1, 1)
    manifest = tmp_path / "fleet.yaml"
    joints, sizes = " ".join(drive["joints"]), " ".join(drive["sizes"])
    manifest.write_text(
        "robots:\n"
        f"  agv:\n    kind: tricycle\n    recordings: [drive.bag]\n    args: {joints} {sizes}\n"
        "  diff:\n    recordings: [fleet/robot-00/s000.csv]\n    args: --wheel-diameter-mm 100 --wheelbase-mm 300\n"
    )
    db = str(tmp_path / "h.sqlite")
    code, out, err = run("fleet", str(manifest), "--db", db, "--scheduler", client.scheduler.address, "--json")
    assert code == 0 and json.loads(out)["recorded"] == 2, err
    with open_history(db) as h:
        agv = h.latest("agv")
    assert agv.parameters["kinematics"] == "tricycle" and "wheelbase_mm" in agv.parameters
    code, out, err = run("drift", "agv", "--db", db, "--json")
    assert code == 0, err
    for bad, said in (
        (f"    kind: tricycle\n    recordings: [drive.bag]\n    args: --kinematics tricycle {joints} {sizes}\n",
         "the manifest's `kind:` names it"),
        ("    kind: hovercraft\n    recordings: [drive.bag]\n", "hovercraft"),
    ):  # fmt: skip
        manifest.write_text(f"robots:\n  agv:\n{bad}")
        code, out, err = run("fleet", str(manifest), "--db", db)
        assert code == 2 and said in err and "fleet.yaml:" in err and len(err.strip().splitlines()) == 1, err
