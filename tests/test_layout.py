"""The library's layout: its bands and core's data flow (import-linter), torch-free faces.

The import contracts themselves live in ``.importlinter`` at the repository root and are checked
by ``lint-imports`` in ``make test``; these tests check that the contracts cover every module,
that they catch what they are meant to catch, and what the contracts cannot see: which heavy
packages an import loads.
"""

import configparser
import importlib
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
PACKAGE = REPO / "e2vlib"
CONTRACTS = REPO / ".importlinter"
HEAVY = {"torch._C": "torch", "vtkmodules.vtkCommonCore": "VTK", "pyvista.core": "pyvista",
         "numba.core": "numba", "ipywidgets.widgets": "ipywidgets"}
"""A module each heavy package loads when it really loads (``lazy_loader.load`` only
registers a placeholder under the package's own name), and the package's name."""


def _layers() -> list[set[str]]:
    config = configparser.ConfigParser()
    config.read(CONTRACTS)
    lines = config["importlinter:contract:bands"]["layers"].split("\n")
    return [{m.strip() for m in line.replace("|", ":").split(":")} for line in lines if line]


def test_every_module_of_the_package_sits_in_one_band_or_stage():
    tops = {f"e2vlib.{p.stem}" for p in PACKAGE.glob("*.py") if p.stem != "__init__"}
    tops |= {f"e2vlib.{p.parent.name}" for p in PACKAGE.glob("*/__init__.py")}
    placed = [m for layer in _layers() for m in layer]
    assert len(placed) == len(set(placed)), "a module is named in two layers"
    assert tops - set(placed) == set(), "give these modules a layer in .importlinter"
    assert set(placed) - tops == set(), "these layers name modules that do not exist"
    bands = [layer for layer in _layers() if layer & {"e2vlib.cli", "e2vlib.experiments",
                                                      "e2vlib.scale"}]
    assert bands == [{"e2vlib.__main__", "e2vlib.cli"}, {"e2vlib.experiments"}, {"e2vlib.scale"}]


def test_core_names_the_pipeline_and_shapes_and_viz_have_their_own_contracts():
    """Core's contract lists every module but the objects (shapes), the pictures (viz) and the
    bands above; shapes and viz each have a contract of their own, and the module map puts
    each top-level module in the band of the contracts, lowest first."""
    sys.path.insert(0, str(REPO / "tools"))
    try:
        from module_map import BANDS, band
    finally:
        sys.path.remove(str(REPO / "tools"))
    config = configparser.ConfigParser()
    config.read(CONTRACTS)

    def sources(contract):
        return set(config[f"importlinter:contract:{contract}"]["source_modules"].split())

    tops = {m for layer in _layers() for m in layer}
    above = {"e2vlib.scale", "e2vlib.experiments", "e2vlib.cli", "e2vlib.__main__"}
    assert sources("core-never-imports-lab-or-scale") == tops - above - {"e2vlib.shapes",
                                                                         "e2vlib.viz"}
    assert sources("objects-are-content") == {"e2vlib.shapes"}
    assert sources("pictures-draw-the-pipeline") == {"e2vlib.viz"}
    order = [band(m.split(".")[1]) for layer in reversed(_layers()) for m in sorted(layer)]
    firsts = list(dict.fromkeys(b for b in order if b != "core"))
    assert firsts == [b for b in BANDS if b != "core"]  # the bands climb as the layers do
    assert band("shapes") == "objects" and band("viz") == "pictures" and band("geometry") == "core"


def test_no_contract_waives_an_import():
    # the lab's commands fail through e2vlib.experiments.errors, below the command line
    config = configparser.ConfigParser()
    config.read(CONTRACTS)
    waived = {name: config[name]["ignore_imports"] for name in config.sections()
              if "ignore_imports" in config[name]}
    assert waived == {}, f"contracts waive imports: {waived}"


def test_the_contracts_catch_a_core_module_importing_scale_inside_a_function(tmp_path):
    """The same contract types on a hand-made package: a lazy import breaks them."""
    pkg = tmp_path / "bandpkg"
    (pkg / "scale").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "scale" / "__init__.py").write_text("")
    (pkg / "scale" / "fast.py").write_text("from bandpkg import core\n")
    (pkg / "core.py").write_text("def f():\n    from bandpkg.scale import fast\n")
    config = tmp_path / "contracts.ini"
    config.write_text(textwrap.dedent("""\
        [importlinter]
        root_package = bandpkg
        [importlinter:contract:bands]
        name = bands
        type = layers
        layers =
            bandpkg.scale
            bandpkg.core
        """))
    lint = [sys.executable, "-c", "from importlinter.cli import lint_imports_command as c; c()",
            "--config", str(config), "--no-cache"]
    env = {"PYTHONPATH": str(tmp_path), "PATH": "/usr/bin:/bin"}
    broken = subprocess.run(lint, capture_output=True, text=True, env=env, cwd=tmp_path)
    assert broken.returncode == 1 and "bandpkg.core -> bandpkg.scale.fast" in broken.stdout
    (pkg / "core.py").write_text("def f():\n    return 1\n")
    kept = subprocess.run(lint, capture_output=True, text=True, env=env, cwd=tmp_path)
    assert kept.returncode == 0, kept.stdout


def _heavy_after(code: str) -> list[str]:
    probe = (f"import sys\n{code}\n"
             f"print(sorted(name for m, name in {HEAVY!r}.items() if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                         check=True, timeout=120, cwd=REPO)
    return eval(out.stdout.strip().splitlines()[-1])  # a printed list of names


def test_the_command_lines_help_loads_neither_torch_nor_vtk():
    code = textwrap.dedent("""\
        import contextlib, io, runpy
        sys.argv = ["e2vlib", "--help"]
        with contextlib.redirect_stdout(io.StringIO()) as out:
            try:
                runpy.run_module("e2vlib", run_name="__main__")
            except SystemExit:
                pass
        assert "make-data" in out.getvalue() and "experiment" in out.getvalue()
        """)
    assert _heavy_after(code) == []


@pytest.mark.parametrize("code", [
    "from e2vlib import paper; paper.CATEGORIES",
    "from e2vlib.data import BuildConfig; BuildConfig(categories=('chair',), per_category=1)",
    "from e2vlib.model import PRESETS, E2VConfig",
    "from e2vlib.train import RECIPES, get_recipe; get_recipe('tiny')",
    "from e2vlib.losses import LOSSES",
    "from e2vlib.experiments import STUDIES, summarize",
    "from e2vlib.experiments import reports",
    "import e2vlib.viz, e2vlib.experiments.explore",
    "from e2vlib import data, model, train, inputs, shapes, viz, experiments",
])
def test_importing_a_constant_config_or_recipe_loads_no_torch_or_vtk(code):
    assert _heavy_after(code) == []


FACES = ["e2vlib.data", "e2vlib.model", "e2vlib.train", "e2vlib.inputs", "e2vlib.shapes",
         "e2vlib.viz", "e2vlib.experiments", "e2vlib.experiments.real_meshes"]


@pytest.mark.parametrize("face", FACES)
def test_every_name_a_package_face_lists_resolves(face):
    module = importlib.import_module(face)
    missing = [name for name in module.__all__ if not hasattr(module, name)]
    assert missing == [], f"{face} lists names its modules do not define: {missing}"


def test_the_module_map_in_the_package_docstring_and_the_developer_guide_is_current():
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


def test_the_library_has_one_training_step():
    """One ``.backward()`` in the library, in ``train.loop.train_step``: the step ``fit`` runs,
    which the speed and scale band reaches through ``FitHooks`` and never copies."""
    calls = [f"{path.relative_to(REPO)}:{number}" for path in sorted(PACKAGE.rglob("*.py"))
             for number, line in enumerate(path.read_text().splitlines(), 1)
             if ".backward(" in line]
    assert len(calls) == 1 and calls[0].startswith("e2vlib/train/loop.py:"), calls
