"""The tests' own hygiene: a test module imports the packages it tests, tests/support and conftest, never
another module of tests/ (a fixture reaches a test by name, through conftest.py and its pytest_plugins); and the
closed-loop harnesses of amr_evaluation are used only by the evaluation tests (a test of a lower package that needs
the whole loop is an integration test: it lives in tests/evaluation)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

TESTS = Path(__file__).resolve().parents[1]
SUPPORT = TESTS / "support"
TEST_MODULES = sorted(path for path in TESTS.rglob("test_*.py") if path.parent != SUPPORT)
SUPPORT_MODULES = {f"support.{path.stem}": path for path in SUPPORT.glob("*.py") if path.stem != "__init__"}
LOCAL_MODULES = {path.stem for path in TESTS.rglob("*.py")} - {"conftest"} | {"tests"}
"""Names a test module could import from its own directory or another one of tests/ (prepend import mode)."""
TOP = "amr_evaluation"
TOP_USERS = {"evaluation", "foundation"}
"""Test directories that may use amr_evaluation (the foundation tests check every package)."""
PENDING: dict[str, str] = {}
"""Known offenders, each expected to fail (strictly: once mended, its entry here must go)."""


def imported(path: Path) -> set[str]:
    """Absolute names of the modules `path` imports anywhere (functions included), `from a import b` as a and a.b."""
    names: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
            names.add(node.module)
            names.update(f"{node.module}.{alias.name}" for alias in node.names)
    return names


def reached(path: Path) -> set[str]:
    """What `path` imports, and what the support modules it imports do, transitively."""
    names, todo, seen = set(), [path], set()
    while todo:
        module = todo.pop()
        if module in seen:
            continue
        seen.add(module)
        found = imported(module)
        names |= found
        todo.extend(SUPPORT_MODULES[name] for name in found if name in SUPPORT_MODULES)
    return names


def name(path: Path) -> str:
    return str(path.relative_to(TESTS))


def pending(path: Path):
    reason = PENDING.get(name(path))
    return pytest.param(path, marks=pytest.mark.xfail(reason=reason, strict=True)) if reason else path


@pytest.mark.parametrize("path", [pending(p) for p in [*TEST_MODULES, *SUPPORT_MODULES.values()]], ids=name)
def test_a_test_module_imports_no_other_module_of_tests(path):
    local = sorted(n for n in imported(path) if n.split(".")[0] in LOCAL_MODULES)
    assert not local, f"{name(path)} imports {local}: move what it needs to tests/support (fixtures: pytest_plugins)"


@pytest.mark.parametrize("path", [p for p in TEST_MODULES if p.parent.name not in TOP_USERS], ids=name)
def test_only_the_evaluation_tests_use_the_evaluation_harnesses(path):
    used = sorted(n for n in reached(path) if n.split(".")[0] == TOP)
    assert not used, f"{name(path)} uses {used}: an integration test of the whole loop belongs in tests/evaluation"


def test_the_checks_see_the_tests():
    assert len(TEST_MODULES) > 100 and "support.ros" in SUPPORT_MODULES
    assert "test_test_imports" in LOCAL_MODULES  # another test module is caught by name
    assert any("support.ros" in imported(path) for path in TEST_MODULES)
