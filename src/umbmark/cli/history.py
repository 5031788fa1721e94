"""CLI commands of issue 4 (history, report, guide, measure). Registers on ``app`` from ``.app``."""

from __future__ import annotations

from .app import app  # noqa: F401
