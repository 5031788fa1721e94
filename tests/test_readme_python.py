"""The README's Python example runs as written.

It uses only names of the top-level package (``umbmark.X``). While the installed umbmark lacks one
of them, the test is skipped and says which (the top-level API is being assembled); the
examples of docs/library.md are not run here."""

import ast
import re

import pytest
from conftest import REPO

import umbmark


def top_level_names(code: str) -> set[str]:
    """The attributes read from the name ``umbmark`` in ``code`` (``umbmark.X`` -> ``X``)."""
    return {
        n.attr
        for n in ast.walk(ast.parse(code))
        if isinstance(n, ast.Attribute) and isinstance(n.value, ast.Name) and n.value.id == "umbmark"
    }


def test_top_level_names():
    assert top_level_names("import umbmark\nx = umbmark.a(umbmark.b.c)\ny = other.d") == {"a", "b"}


def test_python_blocks_run(tmp_path, monkeypatch):
    text = (REPO / "README.md").read_text(encoding="utf-8")
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    assert len(blocks) <= 1, "the README keeps at most one short Python example"
    if not blocks:
        pytest.skip("the README has no Python example")
    missing = sorted(n for code in blocks for n in top_level_names(code) if not hasattr(umbmark, n))
    if missing:
        pytest.skip("the top-level API does not have " + ", ".join(f"umbmark.{n}" for n in missing) + " yet")
    monkeypatch.chdir(tmp_path)
    for code in blocks:
        exec(compile(code, "README.md", "exec"), {"__name__": "readme"})
