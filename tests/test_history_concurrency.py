"""A writer killed (SIGKILL) mid-transaction, and two writer processes in parallel, leave the
history database consistent with every committed record present.

Backends: the SQLite file (standard library), SQLite through SQLAlchemy (a ``sqlite:///`` URL),
and PostgreSQL when ``UMBMARK_TEST_POSTGRES_URL`` names a database the tests may wipe
(e.g. ``postgresql+psycopg://postgres@/umbmark_test?host=/tmp/pgsock&port=55432``)."""

import os
import signal
import subprocess
import sys
import time

import pytest

from umbmark.history import open_history


def _has_sqlalchemy():
    try:
        import sqlalchemy  # noqa: F401
    except ImportError:
        return False
    return True


@pytest.fixture(params=["sqlite-file", "sqlalchemy-sqlite", "postgresql"])
def db(request, tmp_path):
    """A fresh, empty history database of each backend (not created yet)."""
    if request.param == "sqlite-file":
        return tmp_path / "h.sqlite"
    if not _has_sqlalchemy():
        pytest.skip("SQLAlchemy not installed (optional extra 'db')")
    if request.param == "sqlalchemy-sqlite":
        return f"sqlite:///{tmp_path / 'sa.sqlite'}"
    return request.getfixturevalue("postgres_url")


WRITER = r"""
import sys, time, os
from umbmark.history import open_history as History

db, mode, tag, n = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4])
go = sys.argv[5] if len(sys.argv) > 5 and sys.argv[5] else None
pause = float(sys.argv[6]) if len(sys.argv) > 6 else 0.0

def add(h, i):
    return h.add(tag, kind="analyze", method="bf", note=f"{tag}-{i}",
                 results={"emax_syst_mm": 100.0 + i, "payload": "x" * 2000},
                 parameters={"c_left": 1.0 - i * 1e-6, "c_right": 1.0 + i * 1e-6, "wheelbase_mm": 336.0 + i * 1e-3,
                             "Ed": 1.0 + i * 1e-6, "Eb": 0.99},
                 inputs={"runs": [{"i": i, "k": k} for k in range(20)]})

h = History(db)
print("ready", flush=True)
if go:
    while not os.path.exists(go):
        time.sleep(0.005)
if mode == "loop":
    for i in range(n):
        rid = add(h, i)
        print(f"committed {i} {rid}", flush=True)
        if pause:
            time.sleep(pause)
elif mode == "hang":
    for i in range(n):
        rid = add(h, i)
        print(f"committed {i} {rid}", flush=True)
    with h.transaction() as c:
        row = h._row(tag, "analyze", "bf", {"emax_syst_mm": 1.0}, {"c_left": 1.0}, {}, None, None, None,
                     f"{tag}-uncommitted", None, None)
        h._insert(c, row)
        h._insert(c, row)
        print("inside", flush=True)
        time.sleep(120)
"""


def _start(db, mode, tag, n, go=None, pause=0.0):
    args = [sys.executable, "-c", WRITER, str(db), mode, tag, str(n), str(go or ""), str(pause)]
    return subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _read_until(p, prefix, timeout=60):
    t0 = time.monotonic()
    lines = []
    while time.monotonic() - t0 < timeout:
        line = p.stdout.readline()
        if not line:
            raise AssertionError(f"writer ended early: {p.stderr.read()}")
        lines.append(line.strip())
        if line.startswith(prefix):
            return lines
    raise AssertionError("timeout")


def _notes(db, tag):
    with open_history(db) as h:
        assert h.integrity_check() == "ok"
        return [r.note for r in h.records(tag)]


def test_sigkill_inside_a_transaction_loses_only_the_uncommitted_record(db):
    p = _start(db, "hang", "robot-a", 3)
    try:
        lines = _read_until(p, "inside")
        # while the writer holds the write lock, a reader still sees the committed records (WAL)
        assert _notes(db, "robot-a") == ["robot-a-0", "robot-a-1", "robot-a-2"]
        os.kill(p.pid, signal.SIGKILL)
        p.wait(timeout=30)
    finally:
        if p.poll() is None:
            p.kill()
    assert p.returncode == -signal.SIGKILL
    assert sum(ln.startswith("committed") for ln in lines) == 3
    assert _notes(db, "robot-a") == ["robot-a-0", "robot-a-1", "robot-a-2"]
    # the lock died with the writer: a new write goes through at once
    t0 = time.monotonic()
    with open_history(db) as h:
        h.add("robot-a", kind="analyze", method="bf", results={}, parameters={}, note="after")
        assert h.count() == 4
    assert time.monotonic() - t0 < 5


@pytest.mark.slow
@pytest.mark.parametrize("after", [1, 17, 60])
def test_sigkill_at_a_random_moment_keeps_every_committed_record(db, after):
    p = _start(db, "loop", "r", 100000)
    try:
        _read_until(p, "ready")
        committed = []
        while len(committed) < after:
            line = p.stdout.readline()
            assert line, p.stderr.read()
            committed.append(int(line.split()[1]))
        os.kill(p.pid, signal.SIGKILL)  # the writer is somewhere inside its next transactions
        p.wait(timeout=30)
        rest = p.stdout.read().split("\n")
        committed += [int(ln.split()[1]) for ln in rest if ln.startswith("committed")]
    finally:
        if p.poll() is None:
            p.kill()
    notes = _notes(db, "r")
    # every record the writer saw committed is there; at most one more (committed, not yet printed)
    assert notes[: len(committed)] == [f"r-{i}" for i in committed]
    assert len(committed) <= len(notes) <= len(committed) + 1
    assert notes == [f"r-{i}" for i in range(len(notes))]


@pytest.mark.parametrize("pause", [0.0, 0.003])
def test_two_writer_processes_in_parallel(db, tmp_path, pause):
    # the database is empty: both processes race to create the schema too
    go = tmp_path / "go"
    n = 60
    # a short pause between writes, like separate commands; without it SQLite's busy handler lets
    # one writer re-take the lock many times in a row (still correct, but not interleaved)
    ps = [_start(db, "loop", tag, n, go, pause=pause) for tag in ("left", "right")]
    try:
        for p in ps:
            _read_until(p, "ready")
        go.touch()
        outs = [p.communicate(timeout=120) for p in ps]
    finally:
        for p in ps:
            if p.poll() is None:
                p.kill()
    for p, (out, err) in zip(ps, outs):
        assert p.returncode == 0, err
        assert out.count("committed") == n
    assert _notes(db, "left") == [f"left-{i}" for i in range(n)]
    assert _notes(db, "right") == [f"right-{i}" for i in range(n)]
    with open_history(db) as h:
        recs = h.records()
        assert len(recs) == 2 * n == h.count()
        assert len({r.id for r in recs}) == 2 * n
        assert h.schema_version >= 2
        by_id = [r.robot for r in sorted(recs, key=lambda r: r.id)]
    switches = sum(a != b for a, b in zip(by_id, by_id[1:]))
    if pause:
        assert switches >= 2, "the two writers did not overlap in time"


OPENER = r"""
import os, sys, time
from umbmark.history import open_history

db, go = sys.argv[1], sys.argv[2]
print("ready", flush=True)
while not os.path.exists(go):
    time.sleep(0.0005)
with open_history(db) as h:
    h.add("r", kind="analyze", method="bf", results={"emax_syst_mm": 1.0}, parameters={"c_left": 1.0})
"""


def test_processes_opening_one_new_file_at_once_all_take_it_as_a_history(tmp_path):
    """Five processes opening the same new SQLite file at the same instant, twelve times over: one
    creates the schema, the others wait for it; none takes the half-seen file (the schema's
    version read before the creator's commit, its tables after) for another application's."""
    for round_ in range(12):
        db, go = tmp_path / f"h{round_}.sqlite", tmp_path / f"go{round_}"
        ps = [
            subprocess.Popen([sys.executable, "-c", OPENER, str(db), str(go)], stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, text=True)
            for _ in range(5)
        ]  # fmt: skip
        for p in ps:
            _read_until(p, "ready")
        go.touch()
        for p in ps:
            _, err = p.communicate(timeout=60)
            assert p.returncode == 0, err
        with open_history(db) as h:
            assert h.count() == 5
