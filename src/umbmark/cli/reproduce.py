"""CLI commands of issue 6 (reproduce the paper). Registers on ``app`` from ``.app``."""

from __future__ import annotations

from .app import app  # noqa: F401
