"""SPEC §1 layering: liecontrol never imports spacecraft or benchmarks; spacecraft never imports
benchmarks. Checked on the source (static imports, including ones inside functions)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
FORBIDDEN = {"liecontrol": {"spacecraft", "benchmarks"}, "spacecraft": {"benchmarks"}}


def _imports(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    out: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out.update(alias.name.split(".")[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            out.add(node.module.split(".")[0])
    return out


@pytest.mark.parametrize("package", sorted(FORBIDDEN))
def test_package_respects_layering(package: str):
    offenders = {
        str(p.relative_to(ROOT)): sorted(_imports(p) & FORBIDDEN[package])
        for p in (ROOT / package).rglob("*.py")
        if _imports(p) & FORBIDDEN[package]
    }
    assert offenders == {}, f"{package} imports a higher layer: {offenders}"


def _relative_imports(path: Path, package: str) -> set[str]:
    """Sibling modules a module of ``package`` imports (relative or absolute, at any depth)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    out: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level == 1 and node.module:
                out.add(node.module.split(".")[0])
            elif node.level == 1:
                out.update(a.name for a in node.names)
            elif node.level == 0 and node.module and node.module.startswith(package + "."):
                out.add(node.module.split(".")[1])
        elif isinstance(node, ast.Import):
            for a in node.names:
                if a.name.startswith(package + "."):
                    out.add(a.name.split(".")[1])
    return out


@pytest.mark.parametrize("package", ["benchmarks"])
def test_no_import_cycles_between_modules(package: str):
    """No two modules of the package import each other, directly or through others (function-
    level imports included): the package is layered (``benchmarks/__init__.py`` lists the
    layers); the package's ``__init__`` itself may import any module."""
    root = ROOT / package
    mods = {p.stem: p for p in root.glob("*.py") if p.stem != "__init__"}
    graph = {m: _relative_imports(p, package) & set(mods) for m, p in mods.items()}
    cycles = []
    state: dict[str, int] = {}

    def visit(m: str, stack: list[str]) -> None:
        state[m] = 1
        for n in sorted(graph[m]):
            if state.get(n) == 1:
                cycles.append(stack[stack.index(n):] + [n] if n in stack else [m, n])
            elif n not in state:
                visit(n, [*stack, n])
        state[m] = 2

    for m in sorted(graph):
        if m not in state:
            visit(m, [m])
    assert cycles == [], f"import cycles in {package}: {cycles}"
