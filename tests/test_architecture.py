"""The import contract of the package layers, read from the source (every import statement,
including those inside functions):

* a layer imports only the layers listed for it in ``ALLOWED`` (lower ones);
* only ``umbmark.cli`` imports click or names command-line flags;
* no import cycle between modules;
* the real-robot commands (replay, selfcal, validate, export, bag-info) and the fleet import
  nothing from ``umbmark.studies``, lazily or not, directly or through another module; the fleet's
  command calls the library, not the command line's ``main``;
* no module reads a key of a result's ``extra`` dict (results are typed);
* no function is longer than :data:`MAX_FUNCTION_LINES` but the numba kernels (compiled whole);
* the top-level ``umbmark`` package loads its public names lazily (importing it imports no layer).
"""

from __future__ import annotations

import ast
import functools
import re
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import REPO

SRC = REPO / "src" / "umbmark"

# layer -> the layers it may import (besides itself); the base modules are open to all
BASE = {"errors", "jsonutil", "_version", "_numba", "_lazy", "_stats", "_files", "_numbers", "_check"}
ALLOWED: dict[str, set[str]] = {
    "model": set(),
    "kinds": {"model"},
    "metrics": {"model"},
    "io": {"model", "kinds"},
    "correct": {"model", "kinds", "metrics"},
    "history": {"model", "kinds"},
    "realrobot": {"model", "kinds", "metrics", "io", "correct"},
    "viz": {"model", "kinds", "metrics", "io", "correct", "realrobot", "history"},
    "studies": {"model", "kinds", "metrics", "io", "correct", "realrobot", "history", "viz"},
    "fleet": {"model", "kinds", "metrics", "io", "correct", "realrobot", "history"},
    "cli": {"model", "kinds", "metrics", "io", "correct", "realrobot", "history", "viz", "studies", "fleet"},
}
FLAG = re.compile(r"(?<![\w-])--[a-z][a-z0-9]*(?:-[a-z0-9]+)*")


@functools.cache
def _parse(source: str) -> ast.Module:
    """The syntax tree of a source (each module parsed once for all the rules; read only)."""
    return ast.parse(source)


def module_name(path: Path) -> str:
    parts = list(path.relative_to(SRC.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


MODULES = {module_name(p): p for p in sorted(SRC.rglob("*.py"))}


def layer_of(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else ""


def imports_of(path: Path) -> list[tuple[int, str]]:
    """``(line, module)`` for every umbmark module (or package) an import statement loads."""
    mod = module_name(path)
    return imports_in(path.read_text(), mod if path.name == "__init__.py" else mod.rpartition(".")[0])


def imports_in(source: str, package: str) -> list[tuple[int, str]]:
    out = []
    for node in ast.walk(_parse(source)):
        if isinstance(node, ast.Import):
            out += [(node.lineno, a.name) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            for a in node.names:
                sub = f"{target}.{a.name}"
                out.append((node.lineno, sub if sub in MODULES else target))
    return [(line, m) for line, m in out if m == "umbmark" or m.startswith("umbmark.") or m == "click"]


def test_every_module_is_in_a_known_layer():
    unknown = {m for m in MODULES if m != "umbmark" and layer_of(m) not in ALLOWED and layer_of(m) not in BASE}
    unknown -= {"umbmark.__main__"}
    assert not unknown, f"modules outside the layers: {sorted(unknown)}"


def test_layers_import_only_lower_layers():
    bad = []
    for mod, path in MODULES.items():
        layer = layer_of(mod)
        if layer not in ALLOWED:
            continue
        for line, target in imports_of(path):
            if target == "click":
                continue
            tl = layer_of(target)
            if target == "umbmark" or (tl != layer and tl not in BASE and tl not in ALLOWED[layer]):
                bad.append(f"{path.relative_to(REPO)}:{line}: {layer} imports {target}")
    assert not bad, "\n".join(bad)


def test_base_modules_import_no_layer():
    bad = [
        f"{MODULES[m].relative_to(REPO)}:{line}: imports {t}"
        for m in MODULES
        if layer_of(m) in BASE
        for line, t in imports_of(MODULES[m])
        if t != "click" and layer_of(t) not in BASE
    ]
    assert not bad, "\n".join(bad)


def test_only_the_cli_imports_click():
    bad = [
        f"{p.relative_to(REPO)}:{line}"
        for m, p in MODULES.items()
        if layer_of(m) != "cli"
        for line, t in imports_of(p)
        if t == "click"
    ]
    assert not bad, "click imported outside umbmark.cli: " + ", ".join(bad)


def _strings(tree: ast.AST):
    """String constants, without docstrings (a docstring may show a command line)."""
    docs = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            body = node.body
            if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant):
                docs.add(id(body[0].value))
    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in docs:
            yield node


def test_only_the_cli_names_flags():
    """Library messages name parameters (``wheelbase_m``); the CLI maps them to its flags."""
    bad = []
    for mod, path in MODULES.items():
        if layer_of(mod) == "cli" or mod == "umbmark.realrobot.guide":
            continue  # the field guide prints the commands to type
        for node in _strings(_parse(path.read_text())):
            for flag in FLAG.findall(node.value):
                bad.append(f"{path.relative_to(REPO)}:{node.lineno}: {flag}")
    assert not bad, "flags named outside umbmark.cli:\n" + "\n".join(bad)


def _graph() -> dict[str, set[str]]:
    return {m: set(t) for m, t in _import_graph().items()}  # a copy: a rule may prune it


@functools.lru_cache(maxsize=1)
def _import_graph() -> dict[str, set[str]]:
    g: dict[str, set[str]] = {m: set() for m in MODULES}
    for mod, path in MODULES.items():
        for _, t in imports_of(path):
            if t in MODULES and t != mod:
                g[mod].add(t)
        # importing a module first imports its packages
        parts = mod.split(".")
        for i in range(1, len(parts)):
            parent = ".".join(parts[:i])
            if parent in MODULES and parent != "umbmark":
                g[mod].add(parent)
    return g


def test_no_import_cycles():
    g = _graph()
    # a package importing its own submodules is the usual re-export, not a cycle
    for mod in g:
        g[mod] = {t for t in g[mod] if not (MODULES[mod].name == "__init__.py" and t.startswith(mod + "."))}
    state: dict[str, int] = {}
    cycles = []

    def visit(m, stack):
        state[m] = 1
        stack.append(m)
        for t in sorted(g[m]):
            if state.get(t) == 1:
                cycles.append(" -> ".join(stack[stack.index(t) :] + [t]))
            elif t not in state:
                visit(t, stack)
        stack.pop()
        state[m] = 2

    for m in sorted(g):
        if m not in state:
            visit(m, [])
    assert not cycles, "\n".join(cycles)


REAL_ROBOT_COMMANDS = (
    "umbmark.cli.replay",
    "umbmark.cli.convert",
    "umbmark.cli.bag_info",
    "umbmark.cli.export",
    "umbmark.cli.selfcal",
    "umbmark.cli.validate",
    "umbmark.cli.fleet",
)


def _closure(start: str) -> dict[str, str]:
    """Every umbmark module ``start`` imports, directly or not (lazy imports included), but for the
    CLI's registry of commands (the ``umbmark.cli`` package, which imports every command's module
    to register it: their bodies run only when their command does): module -> the module that
    imports it first."""
    g = _graph()
    seen = {start: ""}
    todo = [start]
    while todo:
        m = todo.pop()
        for t in sorted(g.get(m, ())):
            if t not in seen and t != "umbmark.cli":
                seen[t] = m
                todo.append(t)
    return seen


@pytest.mark.parametrize("command", REAL_ROBOT_COMMANDS)
def test_the_real_robot_commands_import_nothing_from_the_studies(command):
    reached = _closure(command)
    studies = {m: by for m, by in reached.items() if layer_of(m) == "studies"}
    assert not studies, f"{command} reaches {', '.join(f'{m} (from {by})' for m, by in sorted(studies.items()))}"


def test_the_fleet_command_calls_the_library_not_the_command_line():
    """``umbmark fleet`` calls :mod:`umbmark.fleet` (which calls the self-calibration's library
    function), not ``umbmark.cli.main`` with its output redirected."""
    path = MODULES["umbmark.cli.fleet"]
    imported = {t for _, t in imports_of(path)}
    assert "umbmark.cli" not in imported and "umbmark.fleet" in imported
    calls = {
        n.func.id
        for n in ast.walk(_parse(path.read_text()))
        if isinstance(n, ast.Call) and isinstance(n.func, ast.Name)
    }
    assert "main" not in calls
    assert "umbmark.realrobot.selfcal_settings" in _closure("umbmark.fleet.run")


def test_the_closure_sees_a_study():
    """``calibrate`` runs the calibration loop of the studies: the reading above finds it."""
    assert "umbmark.studies.iterate" in _closure("umbmark.cli.calibrate")


def _extra_reads(source: str) -> list[int]:
    """Lines reading a key of an ``extra`` attribute: ``x.extra[...]``, ``x.extra.get(...)``, ``x.extra.items()``."""
    lines = []
    for node in ast.walk(_parse(source)):
        target = None
        if isinstance(node, ast.Subscript):
            target = node.value
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute):
            if node.func.attr in ("get", "items", "keys", "values", "pop", "setdefault"):
                target = node.func.value
        if isinstance(target, ast.Attribute) and target.attr == "extra":
            lines.append(node.lineno)
    return lines


def test_no_module_reads_a_key_of_extra():
    found = [f"{m}:{line}" for m, p in MODULES.items() for line in _extra_reads(p.read_text())]
    assert not found, f"typed results, not extra keys: {found}"


def test_the_extra_rule_sees_a_violation():
    assert _extra_reads("a = r.extra['Ed_ci95']\nb = r.extra.get('x')\nc = r.details.intervals\n") == [1, 2]


MAX_FUNCTION_LINES = 120


def _kernels(tree: ast.Module) -> set[str]:
    """The functions a module compiles with numba: ``numba.njit(...)(f)``, and the names of its
    ``_KERNELS`` tuple."""
    out: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Call):
            inner = node.func.func
            if isinstance(inner, ast.Attribute) and inner.attr == "njit" and node.args:
                if isinstance(node.args[0], ast.Name):
                    out.add(node.args[0].id)
        if isinstance(node, ast.Assign) and any(isinstance(t, ast.Name) and t.id == "_KERNELS" for t in node.targets):
            if isinstance(node.value, (ast.Tuple, ast.List)):
                out |= {e.value for e in node.value.elts if isinstance(e, ast.Constant) and isinstance(e.value, str)}
    return out


def _long_functions(source: str, most: int = MAX_FUNCTION_LINES) -> list[tuple[str, int, int]]:
    """``(name, line, length)`` of the functions longer than ``most`` lines, but the kernels."""
    tree = _parse(source)
    kernels = _kernels(tree)
    out = []
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and node.name not in kernels:
            n = (node.end_lineno or node.lineno) - node.lineno + 1
            if n > most:
                out.append((node.name, node.lineno, n))
    return out


def test_no_function_is_longer_than_the_limit():
    long = [
        f"{m}.{name} (line {line}): {n} lines"
        for m, p in MODULES.items()
        for name, line, n in _long_functions(p.read_text())
    ]
    assert not long, f"split these at their steps (at most {MAX_FUNCTION_LINES} lines):\n" + "\n".join(long)


def test_the_length_rule_sees_a_long_function_and_spares_a_kernel():
    body = "\n".join(f"    x{i} = {i}" for i in range(130))
    source = f"def long():\n{body}\n\ndef _k():\n{body}\n\nk = numba.njit(cache=True)(_k)\n"
    assert [name for name, _, _ in _long_functions(source)] == ["long"]


def test_the_contract_sees_a_violation():
    """The reading above finds what a violation would look like, lazy imports included."""
    source = "import click\n\ndef f():\n    from ..cli import app\n    from umbmark.viz.plots import save_figure\n"
    found = {t for _, t in imports_in(source, "umbmark.model")}
    assert found == {"click", "umbmark.cli.app", "umbmark.viz.plots"}


@pytest.mark.parametrize("statement", ["import umbmark", "import umbmark.cli"])
def test_importing_is_light(statement):
    """``import umbmark`` and the CLI's start import neither scipy nor matplotlib."""
    code = (
        f"{statement}\nimport sys\n"
        "heavy = [m for m in ('scipy', 'matplotlib', 'numba', 'rosbags', 'yaml') if m in sys.modules]\n"
        "print(','.join(heavy))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert out == "", f"{statement} imports {out}"


# ---------------------------------------------------------------- the kinds of robot
def _kind_names() -> set[str]:
    from umbmark.kinds import KINDS

    return set(KINDS)


def _kind_branches(source: str, names: set[str]) -> list[int]:
    """Lines that branch on a kind of robot's name: a string constant equal to a kind's name in a
    comparison (``== "tricycle"``, ``in ("tricycle", "mecanum")``), as a dict's key (``{"tricycle":
    ...}``, ``dict(tricycle=...)``), or looked up by it (``d["tricycle"]``, ``d.get("tricycle")``)."""

    def named(node: ast.AST | None) -> bool:
        if isinstance(node, ast.Constant) and node.value in names:
            return True
        if isinstance(node, (ast.Tuple, ast.List, ast.Set)):
            return any(named(e) for e in node.elts)
        return False

    lines = []
    for node in ast.walk(_parse(source)):
        hit = False
        if isinstance(node, ast.Compare):
            hit = any(named(x) for x in [node.left, *node.comparators])
        elif isinstance(node, ast.Dict):
            hit = any(named(k) for k in node.keys)
        elif isinstance(node, ast.Subscript):
            hit = named(node.slice)
        elif isinstance(node, ast.Call):
            func = node.func
            if isinstance(func, ast.Attribute) and func.attr in ("get", "pop", "setdefault") and node.args:
                hit = named(node.args[0])
            elif isinstance(func, ast.Name) and func.id == "dict":
                hit = any(k.arg in names for k in node.keywords)
        elif isinstance(node, ast.match_case):
            hit = any(named(n) for n in ast.walk(node.pattern) if isinstance(n, ast.Constant))
        if hit:
            lines.append(node.lineno if hasattr(node, "lineno") else node.pattern.lineno)
    return sorted(set(lines))


def test_no_module_branches_on_a_kinds_name():
    """Only ``umbmark.kinds`` knows its kinds by name: the rest of the package asks the kind
    (:func:`umbmark.kinds.kind_named`), so that a new kind is one module."""
    names = _kind_names()
    found = [
        f"{p.relative_to(REPO)}:{line}"
        for m, p in MODULES.items()
        if layer_of(m) != "kinds"
        for line in _kind_branches(p.read_text(), names)
    ]
    assert not found, "ask the kind (umbmark.kinds), do not compare its name:\n" + "\n".join(found)


def test_the_kind_rule_sees_a_violation():
    source = (
        'if kind == "tricycle":\n'
        '    x = kind in ("a", "mecanum")\n'
        'NOUN = {"mecanum": "mecanum robot"}\n'
        'y = JOINTS["tricycle"]\n'
        'z = CONTROLLERS.get("mecanum")\n'
        "w = dict(tricycle=1)\n"
        'match kind:\n    case "mecanum":\n        pass\n'
        'print("a tricycle", "tricycle")\n'
        'ok = kind == "straight"\n'
    )
    assert _kind_branches(source, {"tricycle", "mecanum"}) == [1, 2, 3, 4, 5, 6, 8]


def test_the_kinds_sit_above_the_model_only():
    """The kinds' package is a layer: it imports the model (and the base modules), and every layer
    that asks a kind imports it."""
    assert ALLOWED["kinds"] == {"model"}
    assert all(
        "kinds" in ALLOWED[layer] for layer in ("io", "correct", "history", "realrobot", "viz", "studies", "cli")
    )
    assert "kinds" not in ALLOWED["model"] and "kinds" not in ALLOWED["metrics"]
