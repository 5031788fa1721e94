import os
from pathlib import Path

import pytest

os.environ.setdefault("MPLBACKEND", "Agg")
# the width the commands print tables at off a terminal (cli.app.console), whatever terminal or
# test runner started the tests
os.environ["COLUMNS"] = "120"

REPO = Path(__file__).resolve().parents[1]
DATA = REPO / "data"


def pytest_collection_modifyitems(config, items):
    """Groups for pytest-xdist (``--dist loadgroup``): a test file runs in one worker, so that its
    module-scoped fixtures are built once; the files that use the PostgreSQL server (one shared
    database, whose tables each test drops) all run in one worker, one after the other."""
    uses_postgres: dict[str, bool] = {}
    for item in items:
        path = str(item.path)
        if path not in uses_postgres:
            uses_postgres[path] = "postgres_url" in Path(path).read_text(encoding="utf-8")
        group = "postgres" if uses_postgres[path] else item.nodeid.split("::")[0]
        item.add_marker(pytest.mark.xdist_group(group))


@pytest.fixture
def repo_root() -> Path:
    return REPO


@pytest.fixture
def optiodom() -> Path:
    return DATA / "optiodom"


@pytest.fixture
def postgres_url() -> str:
    """A PostgreSQL history database with no umbmark tables (UMBMARK_TEST_POSTGRES_URL; `.ci/postgres.sh`
    starts a throw-away server), or a skip with the reason."""
    url = os.environ.get("UMBMARK_TEST_POSTGRES_URL")
    if not url:
        pytest.skip("set UMBMARK_TEST_POSTGRES_URL to run the PostgreSQL backend tests")
    import sqlalchemy as sa

    eng = sa.create_engine(url)
    with eng.begin() as c:
        for t in ("calibrations", "robots", "umbmark_schema"):
            c.exec_driver_sql(f"DROP TABLE IF EXISTS {t} CASCADE")
    eng.dispose()
    return url
