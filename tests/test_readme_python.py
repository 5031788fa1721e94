"""The Python examples of the README and of docs/library.md run as written.

The README keeps one short example that uses only names of the top-level package
(``umbmark.X``). The blocks of docs/library.md run in order in one namespace (a later block
uses what an earlier one made), in a fresh folder with ``data`` pointing at the repository's
data folder and the example bag the page names."""

import ast
import re

import matplotlib
import pytest
from conftest import REPO
from test_readme import write_example_bags

import umbmark

PYTHON_BLOCK = re.compile(r"```python\n(.*?)```", flags=re.S)


def top_level_names(code: str) -> set[str]:
    """The attributes read from the name ``umbmark`` in ``code`` (``umbmark.X`` -> ``X``)."""
    return {
        n.attr
        for n in ast.walk(ast.parse(code))
        if isinstance(n, ast.Attribute) and isinstance(n.value, ast.Name) and n.value.id == "umbmark"
    }


def test_top_level_names():
    assert top_level_names("import umbmark\nx = umbmark.a(umbmark.b.c)\ny = other.d") == {"a", "b"}


def _workdir(tmp_path, monkeypatch, text):
    (tmp_path / "data").symlink_to(REPO / "data", target_is_directory=True)
    write_example_bags(tmp_path, text)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("UMBMARK_DB", str(tmp_path / "history.sqlite"))
    matplotlib.use("Agg")  # the figures of the page are saved, never shown


def test_readme_example_uses_the_public_api(tmp_path, monkeypatch):
    text = (REPO / "README.md").read_text(encoding="utf-8")
    blocks = PYTHON_BLOCK.findall(text)
    assert len(blocks) == 1, "the README keeps one short Python example"
    names = top_level_names(blocks[0])
    assert names and all(n in umbmark.__all__ for n in names), sorted(names - set(umbmark.__all__))
    _workdir(tmp_path, monkeypatch, text)
    exec(compile(blocks[0], "README.md", "exec"), {"__name__": "readme"})


def test_library_page_runs(tmp_path, monkeypatch):
    text = (REPO / "docs" / "library.md").read_text(encoding="utf-8")
    blocks = PYTHON_BLOCK.findall(text)
    assert len(blocks) >= 8
    _workdir(tmp_path, monkeypatch, text)
    namespace = {"__name__": "library"}
    for i, code in enumerate(blocks, 1):
        try:
            exec(compile(code, f"docs/library.md block {i}", "exec"), namespace)
        except Exception as e:  # noqa: BLE001 - name the block that failed
            pytest.fail(f"docs/library.md, Python block {i}: {type(e).__name__}: {e}")
