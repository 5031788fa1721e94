"""Exact (non-linearised) calibration, method ``exact`` (issue 7). Not implemented yet."""

from __future__ import annotations
