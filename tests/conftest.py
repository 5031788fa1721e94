import os
from pathlib import Path

import pytest

os.environ.setdefault("MPLBACKEND", "Agg")

REPO = Path(__file__).resolve().parents[1]
DATA = REPO / "data"


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
