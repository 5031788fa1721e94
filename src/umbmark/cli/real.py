"""CLI commands of issue 3 (replay, export: real robots). Registers on ``app`` from ``.app``."""

from __future__ import annotations

from .app import app  # noqa: F401
