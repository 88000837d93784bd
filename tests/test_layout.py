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
    graph = import_graph()
    viz = set().union(*(deps for name, deps in graph.items() if name.partition(".")[0] == "viz"))
    top = {m.partition(".")[0] for m in viz} - {"viz"}  # the package and its modules
    assert not top & {"data", "model", "train", "explore", "figures"}, sorted(viz)
    assert top <= {"events", "frames", "metrics", "render", "voxels", "files", "paper",
                   "orbit", "_headless"}


def test_explore_uses_viz_but_not_data():
    graph = import_graph()
    assert "viz" in graph["explore"] and "explore" not in graph["viz"]
    assert "data" not in graph["explore"]  # its constants come from e2vlib.paper
    # the README pictures are the top layer: only the command line imports them
    assert {name for name, deps in graph.items() if "figures" in deps} == {"__main__"}


@pytest.mark.parametrize("module", ["e2vlib.viz", "e2vlib.experiments.explore"])
def test_importing_the_view_layer_loads_no_torch_pyvista_or_widgets(module):
    code = (f"import sys, {module}; "
            "print(sorted(m for m in ('torch', 'pyvista', 'ipywidgets') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, timeout=120)
    assert out.stdout.strip() == "[]"


# ----------------------------------------------------------------------------- stages

SHARED = {"paper", "files", "events", "metrics", "losses"}
"""Modules every stage may import: the paper's facts, crash-safe writing, the event array,
scoring of plain arrays (IoU, F-score) and the losses."""

STAGES: list[set[str]] = [
    {"shapes"},
    {"voxels", "orbit", "_headless"},
    {"render"},
    {"simulate"},
    {"io"},
    {"frames", "frames_fast"},
    {"inputs"},
    {"data", "dataset_checks", "shards", "real_meshes"},
    {"model"},
    {"train"},
    {"geometry", "viz"},
    {"experiments", "geometry_study", "real_study", "explore", "figures", "reports",
     "reconstruct"},
    {"__main__", "cli"},
]
"""DESIGN.md's data flow as import stages, earliest first; a package is one module here."""


def stage_of(module: str) -> int | None:
    top = module.partition(".")[0]
    return next((i for i, names in enumerate(STAGES) if top in names), None)


def stage_violations(graph: dict[str, set[str]]) -> list[str]:
    """``"a (stage i) imports b (stage j > i)"`` for every import of a later stage."""
    out = []
    for module, targets in sorted(graph.items()):
        here = stage_of(module)
        for target in sorted(targets):
            if target.partition(".")[0] in SHARED:
                continue
            there = stage_of(target)
            if here is not None and there is not None and there > here:
                out.append(f"{module} (stage {here}) imports {target} (stage {there})")
    return out


def test_every_module_has_a_stage_and_no_stage_imports_a_later_one():
    graph = import_graph()
    tops = {m.partition(".")[0] for m in graph}
    unplaced = sorted(t for t in tops - SHARED if stage_of(t) is None)
    assert unplaced == [], f"give these modules a stage in STAGES: {unplaced}"
    assert stage_violations(graph) == []


def test_the_stage_check_catches_an_import_of_a_later_stage():
    graph = {"data.build": {"model", "frames", "paper"}, "model": {"metrics"},
             "frames": {"events"}}
    assert stage_violations(graph) == ["data.build (stage 7) imports model (stage 8)"]
    assert stage_violations({"train.loop": {"model", "data"}}) == []


MAX_LINES = 600


def test_no_module_exceeds_600_lines():
    long = {str(p.relative_to(PACKAGE)): n for p in PACKAGE.rglob("*.py")
            if (n := len(p.read_text().splitlines())) > MAX_LINES}
    assert long == {}, f"split these modules by job (at most {MAX_LINES} lines): {long}"


def test_the_module_map_in_the_package_docstring_and_the_readme_is_current():
    sys.path.insert(0, str(PACKAGE.parent / "tools"))
    try:
        import module_map
    finally:
        sys.path.pop(0)
    stale = [str(path.relative_to(PACKAGE.parent)) for path, text in module_map.current().items()
             if path.read_text() != text]
    assert stale == [], f"the module map is out of date in {stale}: run " \
                        "`python tools/module_map.py --write`"
    rows = module_map.module_rows()
    assert ("metrics.py", len((PACKAGE / "metrics.py").read_text().splitlines())) in \
        [(name, n) for name, n, _ in rows]
