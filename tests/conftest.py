import os
from collections import Counter
from pathlib import Path

import pytest

os.environ.setdefault("MPLBACKEND", "Agg")
# the width the commands print tables at off a terminal (cli.app.console), whatever terminal or
# test runner started the tests
os.environ["COLUMNS"] = "120"

REPO = Path(__file__).resolve().parents[1]
DATA = REPO / "data"


def pytest_collection_modifyitems(config, items):
    """The files that hold slow tests first (the most first), then the others by their number of tests (as
    pytest-xdist's own ordering): with ``--dist loadfile`` the long files start while the short
    ones are left to fill the end, rather than one long file running alone at the end. The
    order within a file is kept."""
    files = [item.nodeid.partition("::")[0] for item in items]
    count = Counter(files)
    slow = Counter(f for f, item in zip(files, items) if item.get_closest_marker("slow"))
    rank = {f: i for i, f in enumerate(sorted(count, key=lambda f: (-slow[f], -count[f], f)))}
    order = sorted(range(len(items)), key=lambda i: (rank[files[i]], i))
    items[:] = [items[i] for i in order]


@pytest.fixture
def repo_root() -> Path:
    return REPO


@pytest.fixture
def optiodom() -> Path:
    return DATA / "optiodom"


@pytest.fixture
def postgres_url():
    """A PostgreSQL history database with no umbmark tables (UMBMARK_TEST_POSTGRES_URL; `.ci/postgres.sh`
    starts a throw-away server), or a skip with the reason. The database is shared by every test
    worker (pytest-xdist): a test holds an exclusive file lock on it while it runs."""
    url = os.environ.get("UMBMARK_TEST_POSTGRES_URL")
    if not url:
        pytest.skip("set UMBMARK_TEST_POSTGRES_URL to run the PostgreSQL backend tests")
    import fcntl
    import hashlib
    import tempfile

    import sqlalchemy as sa

    lock_path = Path(tempfile.gettempdir()) / f"umbmark-test-pg-{hashlib.sha256(url.encode()).hexdigest()[:12]}.lock"
    with open(lock_path, "a") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            eng = sa.create_engine(url)
            with eng.begin() as c:
                for t in ("calibrations", "robots", "umbmark_schema"):
                    c.exec_driver_sql(f"DROP TABLE IF EXISTS {t} CASCADE")
            eng.dispose()
            yield url
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)
