"""The library's layout: no import cycle anywhere in e2vlib, and viz draws without data.

The import graph is read from the source with ``ast`` (every ``import`` and ``from ...
import`` statement, including those inside functions, which run later but still tie two
modules together), so the check needs no import and sees lazy imports too.
"""

import ast
import subprocess
import sys
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "e2vlib"


def _module_name(path: Path, package: Path) -> str:
    """``e2vlib/viz.py`` -> ``viz``, ``e2vlib/shapes/builders.py`` -> ``shapes.builders``,
    ``e2vlib/shapes/__init__.py`` -> ``shapes``, ``e2vlib/__init__.py`` -> ``""``."""
    parts = list(path.relative_to(package).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _resolve(target: str, modules: set[str]) -> str | None:
    """The module ``target`` (relative to e2vlib) lives in: itself or its longest known
    parent; None outside the package's modules."""
    while target and target not in modules:
        target = target.rpartition(".")[0]
    return target or None


def import_graph(package: Path = PACKAGE) -> dict[str, set[str]]:
    """``{module: {modules it imports}}`` for every module of ``package`` (names relative
    to it, the package's own ``__init__`` left out)."""
    files = {_module_name(p, package): p for p in package.rglob("*.py")}
    modules = set(files) - {""}
    graph: dict[str, set[str]] = {}
    for name, path in files.items():
        if not name:
            continue
        is_package = path.name == "__init__.py"
        here = name if is_package else name.rpartition(".")[0]  # the package it sits in
        targets = []
        for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
            if isinstance(node, ast.Import):
                targets += [a.name.removeprefix("e2vlib.") for a in node.names
                            if a.name.startswith("e2vlib.")]
            elif isinstance(node, ast.ImportFrom):
                if node.level:  # relative: from . import x, from ..y import z
                    base = here.split(".") if here else []
                    base = base[:len(base) - (node.level - 1)]
                    module = ".".join(base + ([node.module] if node.module else []))
                elif node.module == "e2vlib":
                    module = ""
                elif node.module and node.module.startswith("e2vlib."):
                    module = node.module.removeprefix("e2vlib.")
                else:
                    continue
                for alias in node.names:  # `from pkg import submodule` imports the submodule
                    sub = f"{module}.{alias.name}" if module else alias.name
                    targets.append(sub if sub in modules else module)
        graph[name] = {m for t in targets if (m := _resolve(t, modules)) and m != name}
    return graph


def find_cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    cycles: list[list[str]] = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for nxt in sorted(graph.get(node, ())):
            if nxt not in index:
                visit(nxt)
                low[node] = min(low[node], low[nxt])
            elif nxt in on_stack:
                low[node] = min(low[node], index[nxt])
        if low[node] == index[node]:
            component = []
            while True:
                member = stack.pop()
                on_stack.discard(member)
                component.append(member)
                if member == node:
                    break
            if len(component) > 1:
                cycles.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return cycles


def test_the_cycle_finder_finds_cycles_and_resolves_imports(tmp_path):
    """The checker itself, on a hand-made package with a known cycle."""
    pkg = tmp_path / "e2vlib"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text("def f():\n    from e2vlib.b import g\n")  # lazy import
    (pkg / "b.py").write_text("from e2vlib import c\n")
    (pkg / "c.py").write_text("import e2vlib.a\nimport numpy\n")
    (pkg / "d.py").write_text("from e2vlib.sub import leaf\nfrom e2vlib.sub.leaf import x\n")
    (pkg / "sub" / "__init__.py").write_text("from .leaf import x\n")
    (pkg / "sub" / "leaf.py").write_text("from ..c import y\nx = 1\n")
    graph = import_graph(pkg)
    assert graph == {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"sub.leaf"},
                     "sub": {"sub.leaf"}, "sub.leaf": {"c"}}
    assert find_cycles(graph) == [["a", "b", "c"]]
    assert find_cycles({"x": {"y"}, "y": set()}) == []


def test_no_import_cycle_in_e2vlib():
    graph = import_graph()
    assert {"viz", "explore", "figures", "data", "paper"} <= set(graph)
    cycles = find_cycles(graph)
    assert cycles == [], f"import cycles in e2vlib: {cycles}"


def test_viz_imports_only_lower_layers():
    viz = import_graph()["viz"]
    top = {m.partition(".")[0] for m in viz}
    assert not top & {"data", "model", "train", "explore", "figures"}, sorted(viz)
    assert top <= {"events", "frames", "metrics", "render", "voxels", "files", "paper"}


def test_explore_uses_viz_but_not_data():
    graph = import_graph()
    assert "viz" in graph["explore"] and "explore" not in graph["viz"]
    assert "data" not in graph["explore"]  # its constants come from e2vlib.paper
    # the README pictures are the top layer: only the command line imports them
    assert {name for name, deps in graph.items() if "figures" in deps} == {"__main__"}


@pytest.mark.parametrize("module", ["e2vlib.viz", "e2vlib.explore"])
def test_importing_the_view_layer_loads_no_torch_pyvista_or_widgets(module):
    code = (f"import sys, {module}; "
            "print(sorted(m for m in ('torch', 'pyvista', 'ipywidgets') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, timeout=120)
    assert out.stdout.strip() == "[]"
