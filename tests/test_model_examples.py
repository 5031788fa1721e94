"""The runnable examples (``>>>``) in the docstrings of :mod:`umbmark.model`: each module's
examples run here (under plain ``pytest`` and under xdist), and there are at least 20 of them."""

from __future__ import annotations

import doctest
import importlib
import pkgutil

import pytest

import umbmark.model

MODULES = ["umbmark.model", *(m.name for m in pkgutil.iter_modules(umbmark.model.__path__, "umbmark.model."))]
FLAGS = doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE


def _tests(name: str) -> list[doctest.DocTest]:
    module = importlib.import_module(name)
    return [t for t in doctest.DocTestFinder().find(module, name) if t.examples]


@pytest.mark.parametrize("name", MODULES)
def test_the_examples_of_the_model_run(name):
    runner = doctest.DocTestRunner(optionflags=FLAGS)
    failures = []
    for test in _tests(name):
        out: list[str] = []
        result = runner.run(test, out=out.append)
        if result.failed:
            failures.append("".join(out))
    assert not failures, "\n".join(failures)


def test_the_model_has_at_least_20_examples():
    examples = {name: sum(len(t.examples) for t in _tests(name)) for name in MODULES}
    assert sum(examples.values()) >= 20, examples
    assert sum(n > 0 for n in examples.values()) >= 5, examples  # spread over the model, not one module


def test_a_wrong_example_fails():
    """The runner above reports a wrong expectation (it does not pass whatever the output)."""
    test = doctest.DocTestParser().get_doctest(">>> 1 + 1\n3\n", {}, "wrong", None, 0)
    runner = doctest.DocTestRunner(optionflags=FLAGS)
    assert runner.run(test, out=lambda s: None).failed == 1
