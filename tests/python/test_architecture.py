"""The module graph has no cycles, in the Python package and in the core crate: a module that
needs another's types imports them, never the other way round as well (issue 27)."""

from __future__ import annotations

import ast
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def _cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """Every cycle a depth-first search meets (empty for a DAG)."""
    state: dict[str, int] = {}
    found: list[list[str]] = []

    def visit(node: str, path: list[str]) -> None:
        state[node] = 1
        path.append(node)
        for target in sorted(edges.get(node, ())):
            if state.get(target) == 1:
                found.append([*path[path.index(target) :], target])
            elif target not in state:
                visit(target, path)
        path.pop()
        state[node] = 2

    for node in sorted(edges):
        if node not in state:
            visit(node, [])
    return found


def python_imports() -> dict[str, set[str]]:
    """Module -> the package modules it imports (function-local imports included)."""
    package = ROOT / "env-py" / "python" / "panda_rapier"
    modules = {path.stem: path for path in package.glob("*.py")}
    edges: dict[str, set[str]] = {name: set() for name in modules}
    for name, path in modules.items():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.level == 1:
                targets = (
                    [node.module.split(".")[0]] if node.module else [a.name for a in node.names]
                )
                edges[name].update(t for t in targets if t in modules and t != name)
    return edges


def rust_imports(crate: str = "env-core") -> dict[str, set[str]]:
    """Top-level module of a crate -> the top-level modules its code names through `crate::`
    paths (in `use` lines or inline; comments and documentation links are not imports)."""
    src = ROOT / crate / "src"
    edges: dict[str, set[str]] = {}
    group = re.compile(r"use crate::\{([^;]*)\}", re.S)
    path_re = re.compile(r"crate::([a-z_]+)")
    for path in src.rglob("*.rs"):
        module = path.relative_to(src).parts[0].removesuffix(".rs")
        if module == "lib":
            continue
        code = "\n".join(line.split("//")[0] for line in path.read_text().splitlines())
        names = set(path_re.findall(code))
        for body in group.findall(code):
            names.update(re.findall(r"(?:^|[{,])\s*([a-z_]+)", body))
        edges.setdefault(module, set()).update(n for n in names if n != module)
    return edges


def test_python_modules_import_without_cycles() -> None:
    assert _cycles(python_imports()) == []


def test_rust_modules_import_without_cycles() -> None:
    core = rust_imports("env-core")
    assert {"physics", "robot", "model", "task"} <= set(core)
    assert _cycles(core) == []
    bindings = rust_imports("env-py")
    assert {"env", "vector", "render", "sensors"} <= set(bindings)
    assert _cycles(bindings) == []
    assert _cycles(rust_imports("policies")) == []


def test_the_cycle_finder_finds_cycles() -> None:
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == [["a", "b", "c", "a"]]
    assert _cycles({"a": {"b"}, "b": set()}) == []
