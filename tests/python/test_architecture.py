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


PACKAGE = ROOT / "env-py" / "python" / "panda_rapier"
#: The package's layers, bottom up: the environment (the top level), then its wings.
WINGS = ("agents", "learning", "scale", "tools")


def _module_name(path: Path) -> str:
    """``env``, ``learning.recipes``; the package's own ``__init__`` is ``__init__``, a wing's
    is the wing's name."""
    parts = list(path.relative_to(PACKAGE).with_suffix("").parts)
    if parts[-1] == "__init__" and len(parts) > 1:
        parts.pop()
    return ".".join(parts)


def _imported(path: Path, node: ast.Import | ast.ImportFrom, modules: set[str]) -> set[str]:
    """The package modules an import statement in the file ``path`` names."""
    if isinstance(node, ast.Import):
        wanted = [a.name for a in node.names]
    elif node.level == 0:
        wanted = [node.module or ""] + [f"{node.module}.{a.name}" for a in node.names]
    else:
        package = list(path.relative_to(PACKAGE).parent.parts)
        base = package[: len(package) - (node.level - 1)]
        stem = [*base, *(node.module.split(".") if node.module else [])]
        wanted = [".".join(["panda_rapier", *stem])]
        wanted += [".".join(["panda_rapier", *stem, a.name]) for a in node.names]
    found = set()
    for name in wanted:
        if name == "panda_rapier" or not name.startswith("panda_rapier."):
            continue
        name = name.removeprefix("panda_rapier.")
        while name and name not in modules:  # an attribute of a module: that module
            name = name.rpartition(".")[0]
        found.add(name or "__init__")
    return found


def python_imports(local: bool = True) -> dict[str, set[str]]:
    """Module (``env``, ``learning.recipes``, ...) -> the package modules it imports, in the
    package and its subpackages (function-local imports included unless ``local`` is
    false)."""
    paths = {_module_name(path): path for path in PACKAGE.rglob("*.py")}
    modules = set(paths) | {"_native"}  # the compiled module (its stubs: _native.pyi)
    edges: dict[str, set[str]] = {name: set() for name in modules}
    for name, path in paths.items():
        tree = ast.parse(path.read_text())
        nodes = ast.walk(tree) if local else iter(tree.body)
        for node in nodes:
            if isinstance(node, ast.Import | ast.ImportFrom):
                edges[name].update(m for m in _imported(path, node, modules) if m != name)
    return edges


def layer(module: str) -> int:
    """0 for the environment (the top level), then 1 to 4 for the wings bottom up."""
    first = module.split(".")[0]
    return WINGS.index(first) + 1 if first in WINGS else 0


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


def _code(path: Path) -> str:
    """The file's code without comments, documentation and its test module (tests may use any
    module of the crate; they are no part of the module graph)."""
    text = path.read_text()
    test_module = re.search(r"^#\[cfg\(test\)\]\s*\nmod tests\b", text, re.M)
    if test_module:
        text = text[: test_module.start()]
    return "\n".join(line.split("//")[0] for line in text.splitlines())


def _first_names(body: str) -> set[str]:
    """The first path segment of each item of a `use` group body (`a, b::c, d::{e, f}`)."""
    return set(re.findall(r"(?:^|[{,])\s*([A-Za-z_][A-Za-z0-9_]*)", body))


def rust_submodules(crate: str, folder: str) -> dict[str, set[str]]:
    """Module of `<crate>/src/<folder>/` (a file, or a sub-folder as one module; `mod` for the
    folder's `mod.rs`, or the crate's `lib.rs` for the folder `""`) -> the modules of the
    folder its code names: `crate::<folder>::x` and, from a file directly in the folder,
    `super::x`, each with `{...}` groups. Names `mod.rs` re-exports (`pub use x::{A, B}`)
    count as `x`, and its `mod`/`pub use` lines are not edges (they declare the folder's
    modules and facade)."""
    root = ROOT / crate / "src" / folder
    mod_rs = root / ("mod.rs" if folder else "lib.rs")
    modules = {p.stem for p in root.glob("*.rs") if p != mod_rs}
    modules |= {p.name for p in root.iterdir() if p.is_dir()}
    reexports: dict[str, str] = {}
    facade = re.compile(r"^\s*pub(?:\([a-z]+\))? (?:use|mod) .*?;", re.M | re.S)
    for source, body in re.findall(r"pub use (\w+)::\{?([^;]*?)\}?;", _code(mod_rs)):
        for name in _first_names(body):
            reexports[name] = source

    def resolve(name: str) -> str:
        return name if name in modules else reexports.get(name, "mod")

    edges: dict[str, set[str]] = {}
    prefix = "::".join(["crate", *filter(None, folder.split("/"))])
    for path in root.rglob("*.rs"):
        parts = path.relative_to(root).parts
        module = "mod" if path == mod_rs else parts[0].removesuffix(".rs")
        code = _code(path)
        if path == mod_rs:
            code = facade.sub("", code)
        names: set[str] = set()
        heads = [re.escape(prefix) + "::"]
        if len(parts) == 1 and folder:
            heads.append(r"(?<![\w:])super::")
        for head in heads:
            names.update(re.findall(head + r"([A-Za-z_]\w*)", code))
            for body in re.findall(head + r"\{([^;]*?)\}", code):
                names.update(_first_names(body))
        edges.setdefault(module, set()).update(resolve(n) for n in names if resolve(n) != module)
    return edges


def registered_task_modules() -> set[str]:
    """The task modules the registry's `tasks!` list names (`Variant => super::module::Type`)."""
    registry = (ROOT / "env-core" / "src" / "task" / "registry.rs").read_text()
    listing = registry[registry.rindex("tasks! {") :]
    return set(re.findall(r"=>\s*super::(\w+)::\w+", listing[: listing.index("}")]))


def test_python_modules_import_without_cycles() -> None:
    assert _cycles(python_imports()) == []


def test_python_modules_are_found_in_every_subpackage() -> None:
    edges = python_imports()
    assert {"env", "cli", "agents.evaluation", "learning.runner", "scale.rllib"} <= set(edges)
    assert {"learning.recipes", "learning.runs", "agents.model_file"} <= edges["learning.runner"]
    assert "_common" in edges["agents.evaluation"]


def test_python_imports_point_down_the_layers() -> None:
    """The environment never imports a wing (the cli only inside its functions), agents never
    learning, scale or tools, learning never scale or tools, scale never tools."""
    wrong = sorted(
        (module, target)
        for module, targets in python_imports().items()
        for target in targets
        if layer(target) > layer(module) and module != "cli"
    )
    assert wrong == []
    at_import = python_imports(local=False)["cli"]
    assert sorted(t for t in at_import if layer(t) > 0) == []


#: The wing modules that drive native kernels the environment layer has no Python face for:
#: the seeded evaluation driver, the Wilson interval and episode summaries (evaluation), the
#: native policy network (inference) and the tutorial-fidelity check (bench).
NATIVE_IN_WINGS = {"agents.evaluation", "agents.inference", "tools.bench"}


def test_wings_reach_the_native_module_only_where_pinned() -> None:
    """Everything else goes through the environment's public API."""
    edges = python_imports()
    users = {module for module, targets in edges.items() if "_native" in targets}
    assert {m for m in users if layer(m) > 0} == NATIVE_IN_WINGS


def test_the_layer_test_sees_a_wrong_import(tmp_path: Path) -> None:
    source = tmp_path / "x.py"
    source.write_text("from .learning.runner import train\n")
    tree = ast.parse(source.read_text())
    node = tree.body[0]
    assert isinstance(node, ast.ImportFrom)
    modules = {"learning.runner", "learning", "env"}
    assert _imported(PACKAGE / "env.py", node, modules) == {"learning.runner"}
    assert layer("learning.runner") > layer("env")


def test_rust_modules_import_without_cycles() -> None:
    core = rust_imports("env-core")
    assert {"physics", "robot", "model", "task"} <= set(core)
    assert _cycles(core) == []
    bindings = rust_imports("env-py")
    assert {"env", "vector", "render", "sensors"} <= set(bindings)
    assert _cycles(bindings) == []
    assert _cycles(rust_imports("policies")) == []


def test_task_modules_import_without_cycles_and_no_task_imports_another() -> None:
    graph = rust_submodules("env-core", "task")
    tasks = registered_task_modules()
    assert tasks == {
        "pick_and_place",
        "reach",
        "lift",
        "stack",
        "push",
        "slide",
        "flip",
        "peg_insertion",
        "pick_object",
        "open_drawer",
    }
    assert tasks <= set(graph)
    for task in sorted(tasks):
        assert graph[task] & tasks == set(), f"{task} imports {graph[task] & tasks}"
    # The registry's pattern: it names every task, tasks name its descriptor types.
    assert graph["registry"] >= tasks
    without_registry_list = {
        module: targets - tasks if module == "registry" else targets
        for module, targets in graph.items()
    }
    assert _cycles(without_registry_list) == []


def test_render_modules_import_without_cycles() -> None:
    graph = rust_submodules("render", "")
    assert {"scene", "look", "palette", "camera"} <= set(graph)
    assert _cycles(graph) == []


def test_the_cycle_finder_finds_cycles() -> None:
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == [["a", "b", "c", "a"]]
    assert _cycles({"a": {"b"}, "b": set()}) == []
