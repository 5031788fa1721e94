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
