"""Every `umbmark ...` command line in a fenced code block of README.md runs, in order, in one
temporary folder (with `data` pointing at the repository's data folder), with exit status 0."""

import os
import re
import stat
import subprocess
import sys
import time

import pytest
from conftest import REPO

FENCE = re.compile(r"^\s*(```|~~~)")


def readme_commands(text: str) -> list[tuple[int, str]]:
    """``(line number, command)`` for every line starting with ``umbmark `` inside fenced code
    blocks; a trailing backslash continues the command on the next line."""
    out = []
    in_block = False
    fence = None
    pending = None
    for i, line in enumerate(text.splitlines(), 1):
        m = FENCE.match(line)
        if m and (not in_block or line.strip().startswith(fence)):
            if in_block and pending:
                out.append(pending)
                pending = None
            in_block = not in_block
            fence = m.group(1) if in_block else None
            continue
        if not in_block:
            continue
        if pending is not None:
            start, cmd = pending
            body = line.strip()
            if body.endswith("\\"):
                pending = (start, cmd + " " + body[:-1].strip())
            else:
                out.append((start, cmd + " " + body))
                pending = None
            continue
        s = line.strip()
        if s.startswith("umbmark "):
            if s.endswith("\\"):
                pending = (i, s[:-1].strip())
            else:
                out.append((i, s))
    if pending:
        out.append(pending)
    return out


def test_extractor():
    text = "\n".join(
        [
            "umbmark outside a block",
            "```bash",
            "umbmark one --a 1",
            "  umbmark two \\",
            "    --b 2 \\",
            "    --c 3",
            "pip install umbmark",
            "python3 -m venv .venv && umbmark demo",
            "```",
            "```python",
            "x = 'umbmark not a command'",
            "```",
            "~~~",
            "umbmark three",
            "~~~",
        ]
    )
    assert readme_commands(text) == [(3, "umbmark one --a 1"), (4, "umbmark two --b 2 --c 3"), (14, "umbmark three")]


def _wrapper_bin(tmp_path):
    """A folder with an `umbmark` that runs this interpreter's umbmark (python -m umbmark)."""
    b = tmp_path / "bin"
    b.mkdir()
    exe = b / "umbmark"
    exe.write_text(f'#!/bin/sh\nexec "{sys.executable}" -m umbmark "$@"\n')
    exe.chmod(exe.stat().st_mode | stat.S_IXUSR | stat.S_IXGRP | stat.S_IXOTH)
    return b


@pytest.mark.slow
def test_every_readme_command_runs(tmp_path):
    cmds = readme_commands((REPO / "README.md").read_text(encoding="utf-8"))
    assert len(cmds) >= 5
    work = tmp_path / "work"
    work.mkdir()
    (work / "data").symlink_to(REPO / "data", target_is_directory=True)
    env = dict(os.environ)
    env.update(
        {
            "PATH": f"{_wrapper_bin(tmp_path)}{os.pathsep}{env.get('PATH', '')}",
            "UMBMARK_DB": str(tmp_path / "history.sqlite"),  # never the user's own history
            "XDG_DATA_HOME": str(tmp_path / "xdg"),
            "MPLBACKEND": "Agg",
        }
    )
    env.pop("_UMBMARK_COMPLETE", None)
    failures = []
    timings = []
    for line, cmd in cmds:
        t0 = time.monotonic()
        r = subprocess.run(["bash", "-c", cmd], cwd=work, env=env, capture_output=True, text=True, timeout=600)
        timings.append((time.monotonic() - t0, cmd))
        if r.returncode != 0:
            tail = (r.stderr or r.stdout).strip().splitlines()[-3:]
            failures.append(f"README.md:{line}: exit {r.returncode}: {cmd}\n    " + "\n    ".join(tail))
    slow = [f"{t:.1f} s: {c}" for t, c in sorted(timings, reverse=True)[:3]]
    assert not failures, "\n".join(failures) + "\nslowest: " + "; ".join(slow)
