"""The layers of docs/architecture.md, checked on the source itself.

import-linter (`lint-imports`, run by `make test`) checks the contracts in pyproject.toml. This test is a
second, independent check written from scratch: it reads every module of the four packages with `ast`,
takes every import (inside functions too, where cycles used to hide), resolves relative imports and
`from package import submodule`, and asks
- for no cycle among modules (strongly connected components of one module), and
- that `realtime`, `groundtruth` and `engines` import neither each other nor `experiments`, and `scenes` none of them.
A negative control plants a cycle and a forbidden import in a throwaway package and requires both found.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("scenes", "realtime", "groundtruth", "engines", "experiments")


def modules_under(root: Path, packages: tuple[str, ...]) -> dict[str, Path]:
    """{dotted module name: file} of every .py file of `packages` below `root` (data folders skipped)."""
    out = {}
    for pkg in packages:
        for path in sorted((root / pkg).rglob("*.py")):
            rel = path.relative_to(root).with_suffix("")
            parts = rel.parts[:-1] if rel.name == "__init__" else rel.parts
            if all((root.joinpath(*parts[:i]) / "__init__.py").exists() for i in range(1, len(parts))):
                out[".".join(parts)] = path
    return out


def imports_of(name: str, path: Path, known: set[str]) -> set[str]:
    """The modules of `known` that module `name` imports anywhere in its body."""
    is_package = path.name == "__init__.py"
    found: set[str] = set()

    def add(dotted: str) -> None:
        while dotted and dotted not in known:  # `import a.b.c` of a module: its longest known prefix
            dotted = dotted.rpartition(".")[0]
        if dotted:
            found.add(dotted)

    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            for alias in node.names:
                add(alias.name)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = name.split(".") if is_package else name.split(".")[:-1]
                base = base[: len(base) - (node.level - 1)]
                module = ".".join(base + ([node.module] if node.module else []))
            else:
                module = node.module or ""
            for alias in node.names:
                sub = f"{module}.{alias.name}"
                add(sub if sub in known else module)
    found.discard(name)
    return found


def import_graph(root: Path, packages: tuple[str, ...]) -> dict[str, set[str]]:
    mods = modules_under(root, packages)
    return {name: imports_of(name, path, set(mods)) for name, path in mods.items()}


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out: list[list[str]] = []
    counter = 0
    for start in sorted(graph):
        if start in index:
            continue
        work = [(start, iter(sorted(graph[start])))]
        index[start] = low[start] = counter
        counter += 1
        stack.append(start)
        on_stack.add(start)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = counter
                    counter += 1
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph.get(child, ())))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    top = stack.pop()
                    on_stack.discard(top)
                    component.append(top)
                    if top == node:
                        break
                if len(component) > 1:
                    out.append(sorted(component))
    return out


#: package -> the top-level packages it must never import
FORBIDDEN = {"scenes": {"realtime", "groundtruth", "engines", "experiments"},
             "realtime": {"groundtruth", "engines", "experiments"},
             "groundtruth": {"realtime", "engines", "experiments"},
             "engines": {"realtime", "groundtruth", "experiments"}}


def forbidden_imports(graph: dict[str, set[str]]) -> list[tuple[str, str]]:
    return sorted((a, b) for a, targets in graph.items() for b in targets
                  if b.split(".")[0] in FORBIDDEN.get(a.split(".")[0], ()))


@pytest.fixture(scope="module")
def graph() -> dict[str, set[str]]:
    return import_graph(ROOT, PACKAGES)


def test_the_graph_sees_the_packages(graph):
    # a reader that found nothing would pass every check below
    assert len(graph) > 80
    assert "groundtruth.pathtracer.reference_cache" in graph["groundtruth.pathtracer.reference"]
    assert "scenes.model.scene" in graph["scenes"]


def test_no_import_cycles(graph):
    assert cycles(graph) == []


def test_renderers_import_neither_each_other_nor_experiments(graph):
    assert forbidden_imports(graph) == []


def test_negative_control_finds_a_planted_cycle_and_a_forbidden_import(tmp_path):
    for pkg in ("scenes", "realtime", "groundtruth", "experiments"):
        (tmp_path / pkg).mkdir()
        (tmp_path / pkg / "__init__.py").write_text("")
    (tmp_path / "realtime" / "a.py").write_text("def f():\n    from . import b\n")  # hidden in a function
    (tmp_path / "realtime" / "b.py").write_text("from realtime import a\n")
    (tmp_path / "groundtruth" / "c.py").write_text("def g():\n    import realtime.a\n")
    (tmp_path / "scenes" / "d.py").write_text("import os\n")
    planted = import_graph(tmp_path, PACKAGES)
    assert cycles(planted) == [["realtime.a", "realtime.b"]]
    assert forbidden_imports(planted) == [("groundtruth.c", "realtime.a")]
