"""The module map of e2vlib: every module, its lines and its purpose, generated from the code.

The map stands in two places, ``e2vlib/__init__.py``'s docstring and the "Layout" section of
the developer guide (``docs/developer.md``), each between the markers ``module map:`` and its
end marker; ``--write`` rewrites both from the code, and ``tests/test_layout.py`` fails when
either is out of date.

Usage: ``python tools/module_map.py [--write]`` (prints the map; ``--write`` updates both).
"""

from __future__ import annotations

import argparse
import ast
import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
PACKAGE = REPO / "e2vlib"
INIT = PACKAGE / "__init__.py"
DEVELOPER = REPO / "docs" / "developer.md"
BEGIN, END = "<!-- module map: begin -->", "<!-- module map: end -->"
DOC_BEGIN, DOC_END = "Module map (", "End of the module map."
WIDTH = 92  # every line of the map fits the 100-character limit inside the docstring


def purpose(path: Path) -> str:
    """The first sentence of a module's docstring (``""`` without one), on one line."""
    doc = ast.get_docstring(ast.parse(path.read_text())) or ""
    first = " ".join(doc.strip().split("\n\n")[0].split())
    sentence = re.split(r"(?<=[a-z0-9)`])\. ", first)[0].rstrip(".")
    sentence = re.sub(r":[a-z]+:`~?(?:[\w.]+\.)?([\w]+)`", r"\1", sentence)  # :func:`a.b` -> b
    return sentence.replace("``", "")


def lines(path: Path) -> int:
    return len(path.read_text().splitlines())


BANDS = ("objects", "core", "pictures", "speed and scale", "lab", "command line")
"""The library's bands in import order (lowest first), as ``.importlinter`` has them: the
objects to reconstruct (``shapes``), core (the pipeline), the pictures (``viz``), speed and
scale, the lab, and the command line on top."""


def band(name: str) -> str:
    """The band a top-level module or package (``"frames.py"``, ``"scale/"``) belongs to."""
    top = name.strip().rstrip("/").removesuffix(".py")
    named = {"shapes": "objects", "viz": "pictures", "scale": "speed and scale",
             "experiments": "lab", "cli": "command line", "__main__": "command line"}
    return named.get(top, "core")


def _package_rows(path: Path, depth: int) -> list[tuple[str, int, str]]:
    """A package's row (all its modules' lines, nested packages included), then its members."""
    pad = "  " * depth
    members = sorted(path.rglob("*.py"))
    rows = [(f"{pad}{path.name}/", sum(lines(p) for p in members), purpose(path / "__init__.py"))]
    for child in sorted(path.iterdir()):
        if child.is_dir() and (child / "__init__.py").exists():
            rows += _package_rows(child, depth + 1)
        elif child.suffix == ".py" and child.name != "__init__.py":
            rows.append((f"{pad}  {child.name}", lines(child), purpose(child)))
    return rows


def module_rows(package: Path = PACKAGE) -> list[tuple[str, int, str]]:
    """``(name, lines, purpose)`` of every module, grouped by band (:data:`BANDS`, lowest
    first); a package first (its ``__init__``'s purpose, the lines of all its modules)
    and then its modules, indented; sorted by name within a band."""
    top = []
    for path in sorted(package.iterdir()):
        if path.is_dir() and (path / "__init__.py").exists():
            top.append((path.name + "/", _package_rows(path, 0)))
        elif path.suffix == ".py" and path.name != "__init__.py":
            top.append((path.name, [(path.name, lines(path), purpose(path))]))
    return [row for b in BANDS for name, rows in top if band(name) == b for row in rows]


def band_lines(package: Path = PACKAGE) -> dict[str, int]:
    """Lines of code and docs per band (the package's own ``__init__`` counts as core)."""
    totals = dict.fromkeys(BANDS, 0)
    for path in package.rglob("*.py"):
        first = path.relative_to(package).parts[0]
        totals[band(first)] += lines(path)
    return totals


def render(rows: list[tuple[str, int, str]], indent: str = "") -> str:
    """The map as aligned text lines, each at most :data:`WIDTH` characters after ``indent``."""
    name_width = max(len(name) for name, _, _ in rows)
    out = []
    for name, count, text in rows:
        head = f"{name:<{name_width}} {count:>5}  "
        room = WIDTH - len(head)
        if len(text) > room and ": " in text:  # "Datasets: build ..." -> "Datasets"
            text = text.split(": ")[0]
        if len(text) > room:
            text = text[:room - 3].rsplit(" ", 1)[0].rstrip(",;(") + " ..."
        out.append((indent + head + text).rstrip())
    return "\n".join(out)


def band_summary() -> str:
    """One line: lines per band, e.g. ``core 12,000 · speed and scale 900 · ...``."""
    return " · ".join(f"{b} {n:,}" for b, n in band_lines().items())


def wrapped_summary(indent: str) -> str:
    """:func:`band_summary` after ``lines per band:``, broken between bands to fit WIDTH."""
    out, line = [], "lines per band:"
    for part in band_summary().split(" · "):
        if len(line) + len(part) + 3 > WIDTH:
            out.append(line + " ·")
            line = part
        else:
            line += (" " if line.endswith(":") else " · ") + part
    return "\n".join(indent + text for text in [*out, line])


def doc_block() -> str:
    total = sum(band_lines().values())
    return (f"{DOC_BEGIN}``python tools/module_map.py --write``; {total:,} lines)::\n\n"
            f"{wrapped_summary('    ')}\n\n"
            + render(module_rows(), "    ") + f"\n\n{DOC_END}")


def developer_block() -> str:
    return f"{BEGIN}\nLines per band: {band_summary()}.\n\n```\n{render(module_rows())}\n```\n{END}"


def replace_between(text: str, begin: str, end: str, block: str, where: Path) -> str:
    start, stop = text.find(begin), text.find(end)
    if start < 0 or stop < 0:
        raise SystemExit(f"{where} has no module map markers ({begin!r} ... {end!r})")
    return text[:start] + block + text[stop + len(end):]


def current() -> dict[Path, str]:
    """The files as they would be with an up-to-date map."""
    return {INIT: replace_between(INIT.read_text(), DOC_BEGIN, DOC_END, doc_block(), INIT),
            DEVELOPER: replace_between(DEVELOPER.read_text(), BEGIN, END, developer_block(),
                                       DEVELOPER)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--write", action="store_true", help="update e2vlib/__init__.py and "
                        "docs/developer.md")
    args = parser.parse_args()
    print(render(module_rows()))
    print(f"\nlines per band: {band_summary()}")
    if args.write:
        for path, text in current().items():
            if path.read_text() != text:
                path.write_text(text)
                print(f"updated {path.relative_to(REPO)}")


if __name__ == "__main__":
    main()
