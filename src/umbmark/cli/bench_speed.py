"""``umbmark bench speed``. Registers on the ``bench`` group."""

from __future__ import annotations

from .bench import bench  # noqa: F401
