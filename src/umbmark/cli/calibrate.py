"""CLI commands of issue 7 (calibrate loop). Registers on ``app`` from ``.app``."""

from __future__ import annotations

from .app import app  # noqa: F401
