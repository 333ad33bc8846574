"""The checks of tests/test_architecture.py, as functions of a repository root (so that the tests can plant
an upward import, a circle or a stale module name in a copy and show that each check reports it).

The floors are read from the table in docs/architecture.md ("## Floors"): the table is the one statement
of the layering, and this guard holds the code to it.  Every import counts, top-level and inside
functions (a lazy import is still an arrow).
"""

from __future__ import annotations

import ast
import re
from dataclasses import dataclass
from pathlib import Path

import networkx as nx

FLOOR_ROW = re.compile(r"^\|\s*(\d+)\s*\|[^|]*\|([^|]*)\|")
UNIT = re.compile(r"`([\w.]+?)(?:/|\.py)?`")
DOTTED = re.compile(r"""(?<![\w./-])(agspec(?:\.[A-Za-z_]\w*)+)""")


@dataclass(frozen=True)
class Import:
    source: str  # importing module, dotted
    target: str  # imported module, dotted
    name: str | None  # the name taken from it (``from target import name``), if any
    line: int


def modules(root: Path) -> dict[str, Path]:
    """Every module of the package: dotted name -> file (a package is its ``__init__``)."""
    out = {}
    for path in sorted((root / "agspec").rglob("*.py")):
        parts = list(path.relative_to(root).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


def imports(root: Path) -> list[Import]:
    """Every import of an agspec module by an agspec module, with the names it takes."""
    mods = modules(root)
    out = []
    for name, path in mods.items():
        package = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            pairs: list[tuple[str, str | None]] = []
            if isinstance(node, ast.Import):
                pairs = [(a.name, None) for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = ".".join(package[: len(package) - node.level + 1] + ([node.module] if node.module else [])) \
                    if node.level else node.module or ""
                pairs = [(f"{base}.{a.name}", None) if f"{base}.{a.name}" in mods else (base, a.name)
                         for a in node.names]
            for target, taken in pairs:
                while target not in mods and "." in target:
                    target = target.rsplit(".", 1)[0]
                if target in mods and target != name and target.startswith("agspec"):
                    out.append(Import(name, target, taken, node.lineno))
    return out


def unit(module: str) -> str:
    """The part of the package a module belongs to: its top-level folder or module (``agspec`` itself: the
    package's ``__init__``)."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "agspec"


def floors(root: Path) -> dict[str, int]:
    """unit -> floor, from the floors table of docs/architecture.md."""
    out: dict[str, int] = {}
    in_section = False
    for line in (root / "docs" / "architecture.md").read_text(encoding="utf-8").splitlines():
        if line.startswith("## "):
            in_section = line.strip() == "## Floors"
        m = FLOOR_ROW.match(line) if in_section else None
        if m:
            for u in UNIT.findall(m.group(2)):
                out[u.removeprefix("agspec.").removeprefix("agspec/") or "agspec"] = int(m.group(1))
    return out


def _where(root: Path, imp: Import) -> str:
    return f"{imp.source} (line {imp.line}) -> {imp.target}"


def circles(root: Path) -> list[list[str]]:
    """Strongly connected components of the module import graph (every import, lazy ones too)."""
    graph = nx.DiGraph()
    graph.add_nodes_from(modules(root))
    graph.add_edges_from((i.source, i.target) for i in imports(root))
    return sorted(sorted(c) for c in nx.strongly_connected_components(graph) if len(c) > 1)


def unplaced(root: Path) -> list[str]:
    """Units the floors table does not place (a new folder must say where it stands)."""
    placed = floors(root)
    return sorted({unit(m) for m in modules(root)} - set(placed))


def upward(root: Path) -> list[str]:
    """Imports from one unit to another on the same or a higher floor (arrows run down only)."""
    placed = floors(root)
    out = []
    for imp in imports(root):
        a, b = unit(imp.source), unit(imp.target)
        if a != b and a in placed and b in placed and placed[b] >= placed[a]:
            out.append(f"{_where(root, imp)}: floor {placed[a]} imports floor {placed[b]}")
    return out


def private_names(root: Path) -> list[str]:
    """Imports of a ``_private`` name (or module) of another unit."""
    out = []
    for imp in imports(root):
        if unit(imp.source) == unit(imp.target):
            continue
        hidden = [p for p in imp.target.split(".") if p.startswith("_") and not p.startswith("__")]
        if hidden or (imp.name and imp.name.startswith("_") and not imp.name.startswith("__")):
            out.append(f"{_where(root, imp)}: takes {imp.name or imp.target}")
    return out


def stale_module_names(root: Path, dirs: tuple[str, ...] = ("agspec", "tests", "benchmarks", "docs", "spec"),
                       suffixes: tuple[str, ...] = (".py", ".md", ".toml")) -> list[str]:
    """Dotted ``agspec.…`` names written in code, tests, docs and spec (strings, ``-m`` targets, prose) that
    name no module and no attribute of one: a renamed module leaves no string checking nothing."""
    mods = modules(root)
    out = []
    paths = [root / "pyproject.toml"] + [p for d in dirs for p in sorted((root / d).rglob("*")) if p.suffix in suffixes]
    for path in paths:
        for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            for dotted in DOTTED.findall(line):
                dotted = dotted.rstrip(".")
                if any(part.startswith("__") for part in dotted.split(".")):
                    continue  # module dunders (agspec.__file__, __version__)
                head, rest = dotted, []
                while head not in mods and "." in head:
                    head, tail = head.rsplit(".", 1)
                    rest.insert(0, tail)
                if head not in mods or (rest and not _defines(mods[head], rest[0], mods, head)):
                    out.append(f"{path.relative_to(root)}:{n}: {dotted}")
    return out


def _defines(path: Path, name: str, mods: dict[str, Path], module: str) -> bool:
    """Whether a module defines or imports ``name`` at its top level (an attribute a dotted path may name)."""
    if f"{module}.{name}" in mods:
        return True
    tree = ast.parse(path.read_text(encoding="utf-8"))
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)) and node.name == name:
            return True
        if isinstance(node, (ast.Assign, ast.AnnAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            if any(isinstance(t, ast.Name) and t.id == name for t in targets):
                return True
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            if any((a.asname or a.name.split(".")[0]) == name for a in node.names):
                return True
        if isinstance(node, (ast.If, ast.Try)):  # names bound under a guard (optional extras)
            if any(isinstance(n, (ast.Import, ast.ImportFrom)) and any((a.asname or a.name) == name for a in n.names)
                   for n in ast.walk(node)):
                return True
    return False
