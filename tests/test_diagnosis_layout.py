"""Layout of identification/diagnosis (issue 57 item 1): no function over 80 lines, and a public
API without private re-exports (every name a module's ``__all__`` lists is defined in it)."""

from __future__ import annotations

import ast
import importlib
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "identification" / "diagnosis"
MAX_LINES = 80
MODULES = sorted(PACKAGE.glob("*.py"))


def _functions(tree: ast.AST):
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            yield node


@pytest.mark.parametrize("path", MODULES, ids=lambda p: p.name)
def test_no_function_is_longer_than_80_lines(path):
    tree = ast.parse(path.read_text(encoding="utf-8"))
    long = [(n.name, n.lineno, n.end_lineno - n.lineno + 1) for n in _functions(tree)
            if n.end_lineno - n.lineno + 1 > MAX_LINES]
    assert not long, f"{path.name}: functions over {MAX_LINES} lines (name, line, length): {long}"


def test_the_length_check_can_fail():
    body = "\n".join(f"    x{i} = {i}" for i in range(MAX_LINES))
    (fn,) = _functions(ast.parse(f"def f():\n{body}\n"))
    assert fn.end_lineno - fn.lineno + 1 == MAX_LINES + 1


@pytest.mark.parametrize("path", MODULES, ids=lambda p: p.name)
def test_all_lists_only_names_the_module_defines(path):
    tree = ast.parse(path.read_text(encoding="utf-8"))
    imported = {a.asname or a.name for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) for a in n.names}
    name = "identification.diagnosis" + ("" if path.stem == "__init__" else f".{path.stem}")
    names = set(getattr(importlib.import_module(name), "__all__", ()))
    if path.stem == "__init__":  # lazily resolved, each from the module that defines it
        imported = set()
    assert not {n for n in names if n.startswith("_")}, f"{path.name} exports private names"
    assert not names & imported, f"{path.name} re-exports imported names: {sorted(names & imported)}"


def test_the_package_api_is_public_and_resolves():
    pkg = importlib.import_module("identification.diagnosis")
    assert all(not n.startswith("_") for n in pkg.__all__)
    for n in pkg.__all__:
        assert getattr(pkg, n) is not None
