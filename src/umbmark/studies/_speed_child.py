"""Subprocess entry point of the speed benchmark: runs one case, prints one JSON line.

``python -m umbmark.studies._speed_child '{"kind": "replay", ...}'`` (used by :mod:`umbmark.studies.speed`
so that every case has a fresh process and its own peak RSS)."""

from __future__ import annotations

import json
import sys

from umbmark.studies.speed import run_case_here

__all__: list[str] = []  # a program, not an importable interface

if __name__ == "__main__":  # pragma: no cover - exercised through subprocesses
    sys.stdout.write(json.dumps(run_case_here(json.loads(sys.argv[1]))) + "\n")
