"""The checks of tests/test_spec_guard.py, as functions of a repository root (so that the tests can
plant a drift in a copy and show that each check reports it)."""

from __future__ import annotations

import ast
import re
from pathlib import Path

# `### R-PICK — picks`: the headings that define IDs (agspec.spec_index reads the same form)
HEADING = re.compile(r"^###\s+([A-Z][A-Z0-9]*(?:-[A-Z0-9]+)+)\s+(?:—|-{1,2})\s+")
DEFINING = re.compile(r"^#{2,4}\s+([A-Z][A-Z0-9]*(?:-[A-Z0-9]+)+)\s+(?:—|-{1,2})\s+")  # also `## F-CODES`, `#### F-…`
RESOLUTION = re.compile(r"Resolution ((?:RES|DIV|DEV)-[A-Z0-9]+(?:-[A-Z0-9]+)*)")
NUMBERED = re.compile(r"^(\d+)\.\s+(.*)$")
STEP = re.compile(r"#\s*step\s+(\d+):\s*(.*)$")
ID_IN_TEXT = r"[A-Z][A-Z0-9]*(?:-[A-Z0-9]+)+"
ISSUE = re.compile(r"\bissues?\s+#?\d+|\bissue\s+#\d+|#\d{2,}\b", re.IGNORECASE)
FILE_REF = re.compile(r"(?<![\w./-])((?:[\w.-]+/)*[\w-]+\.(?:md|py|json|yaml|yml|ag|lark|toml))(?![\w/])")
NORMATIVE = ("R-", "INV-", "M-", "T-")
GUARD_FILES = ("spec_guard.py", "test_spec_guard.py")  # every such ID must be implemented (cited by code) and tested


def defined_ids(root: Path) -> set[str]:
    """IDs the spec defines: `## … ####  ID — …` headings and `Resolution ID` markers."""
    out: set[str] = set()
    for path in sorted((root / "spec").glob("*.md")):
        for line in path.read_text(encoding="utf-8").splitlines():
            m = DEFINING.match(line)
            if m:
                out.add(m.group(1))
            out.update(RESOLUTION.findall(line))
    return out


def normative_ids(root: Path) -> list[str]:
    out = []
    for path in sorted((root / "spec").glob("*.md")):
        for line in path.read_text(encoding="utf-8").splitlines():
            m = HEADING.match(line)
            if m and m.group(1).startswith(NORMATIVE) and m.group(1) not in out:
                out.append(m.group(1))
    return out


def _prefixes(ids: set[str]) -> list[str]:
    return sorted({i.split("-")[0] for i in ids}, key=len, reverse=True)


def citations(root: Path, dirs: tuple[str, ...], ids: set[str], globs: tuple[str, ...] = ("*.py",),
              skip: tuple[str, ...] = ()) -> dict[str, list[str]]:
    """ID-shaped tokens with a spec prefix cited under ``dirs``: ID -> [file:line]."""
    paths = [path for d in dirs for glob in globs for path in sorted((root / d).rglob(glob)) if path.name not in skip]
    return _cited_in(root, paths, ids)


def _cited_in(root: Path, paths: list[Path], ids: set[str]) -> dict[str, list[str]]:
    # not inside a regular expression's character class (``[A-Z0-9]``)
    pattern = re.compile(rf"(?<![\w\[-])((?:{'|'.join(_prefixes(ids))})-[A-Z][A-Z0-9]*(?:-[A-Z0-9]+)*)(?![\w\]-])")
    out: dict[str, list[str]] = {}
    for path in paths:
        for lineno, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
            for m in pattern.finditer(line):
                out.setdefault(m.group(1), []).append(f"{path.relative_to(root)}:{lineno}")
    return out


def undefined_citations(root: Path) -> list[str]:
    """Cited in code or tests but defined nowhere in the spec."""
    ids = defined_ids(root)
    cited = citations(root, ("agspec", "tests"), ids)
    return sorted(f"{ident} ({where[0]})" for ident, where in cited.items() if ident not in ids)


def undefined_doc_citations(root: Path) -> list[str]:
    """IDs the user documentation (docs/*.md, README.md) cites to say where a behaviour is specified,
    but that the spec does not define."""
    ids = defined_ids(root)
    pages = sorted((root / "docs").glob("*.md")) + [p for p in (root / "README.md",) if p.is_file()]
    cited = _cited_in(root, pages, ids)
    return sorted(f"{ident} ({where[0]})" for ident, where in cited.items() if ident not in ids)


def uncited(root: Path) -> list[str]:
    """Normative IDs (R-, INV-, M-) not cited by the code that implements them, or by any test
    (tests/ or a conformance case)."""
    ids = defined_ids(root)
    code = citations(root, ("agspec",), ids)
    tests = citations(root, ("tests",), ids, skip=GUARD_FILES)  # the guard's own lists are not tests
    tests.update(citations(root, ("conformance/cases",), ids, ("*.yaml", "*.yml")))
    out = []
    for ident in normative_ids(root):
        if ident not in code:
            out.append(f"{ident}: no code cites it")
        if ident not in tests:
            out.append(f"{ident}: no test cites it")
    return out


def spec_tick_order(root: Path) -> list[tuple[int, list[str]]]:
    """R-TICK-ORDER's numbered list: (number, the IDs that step names), in the spec's order."""
    text = (root / "spec" / "05-transition.md").read_text(encoding="utf-8").splitlines()
    start = next(i for i, line in enumerate(text) if line.startswith("### R-TICK-ORDER"))
    steps: list[tuple[int, str]] = []
    for line in text[start + 1:]:
        if line.startswith("### "):
            break
        m = NUMBERED.match(line)
        if m:
            steps.append((int(m.group(1)), m.group(2)))
        elif steps and line.startswith("   ") and line.strip():
            steps[-1] = (steps[-1][0], steps[-1][1] + " " + line.strip())
        elif steps and not line.strip():
            if any(n for n, _ in steps) and steps[-1][0] >= 15:
                break
    return [(n, _ids_of(body)) for n, body in steps]


def _ids_of(text: str) -> list[str]:
    out: list[str] = []
    for ident in re.findall(ID_IN_TEXT, text):
        if ident.startswith(("R-", "M-")) and ident not in out:
            out.append(ident)
    return out


def code_tick_order(root: Path) -> list[tuple[int, list[str]]]:
    """The ``# step N: IDs`` markers of ``Simulator.step`` in agspec/interp/tick.py, in source order."""
    source = (root / "agspec" / "interp" / "tick.py").read_text(encoding="utf-8")
    tree = ast.parse(source)
    step = next(n for n in ast.walk(tree) if isinstance(n, ast.FunctionDef) and n.name == "step")
    lines = source.splitlines()[step.lineno - 1: step.end_lineno]
    out: list[tuple[int, str]] = []
    for line in lines:
        m = STEP.search(line)
        if m:
            out.append((int(m.group(1)), m.group(2)))
        elif out and re.match(r"\s*#\s*R-", line):  # a marker continued on the next comment line
            out[-1] = (out[-1][0], out[-1][1] + " " + line.strip().lstrip("#"))
    return [(n, _ids_of(body)) for n, body in out]


def tick_order_drift(root: Path) -> list[str]:
    spec, code = spec_tick_order(root), code_tick_order(root)
    out = []
    if [n for n, _ in code] != [n for n, _ in spec]:
        out.append(f"step numbers: spec {[n for n, _ in spec]}, tick.py {[n for n, _ in code]}")
    for (n, want), (m, got) in zip(spec, code):
        if n == m and sorted(want) != sorted(got):
            out.append(f"step {n}: spec names {want}, tick.py names {got}")
    return out


def _comments_and_docstrings(path: Path) -> list[tuple[int, str]]:
    source = path.read_text(encoding="utf-8")
    out = [(i, line.split("#", 1)[1]) for i, line in enumerate(source.splitlines(), start=1)
           if "#" in line and line.lstrip().startswith("#") or "  # " in line]
    tree = ast.parse(source)
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            doc = ast.get_docstring(node, clean=False)
            if doc:
                first = node.body[0].lineno if node.body else 1
                out += [(first + k, text) for k, text in enumerate(doc.splitlines())]
    return out


def stale_references(root: Path, dirs: tuple[str, ...] = ("agspec", "tests")) -> list[str]:
    """Comments and docstrings that name an issue number or a file that does not exist."""
    known = {p.name for p in root.rglob("*") if ".git" not in p.parts} | {
        str(p.relative_to(root)) for p in root.rglob("*") if ".git" not in p.parts}
    out = []
    for d in dirs:
        for path in sorted((root / d).rglob("*.py")):
            rel = path.relative_to(root)
            for lineno, text in _comments_and_docstrings(path):
                if ISSUE.search(text):
                    out.append(f"{rel}:{lineno}: names an issue: {text.strip()[:80]}")
                if "original" in text or " --" in text:  # the original release's files; command examples
                    continue
                for ref in FILE_REF.findall(text):
                    name = ref.split("/")[-1]
                    if ref not in known and name not in known and not _placeholder(ref):
                        out.append(f"{rel}:{lineno}: names a missing file {ref}")
    return out


def _placeholder(ref: str) -> bool:
    """Example or pattern file names (``x.jsonl``, ``cm.jsonl``, ``FILE.json``) are not references."""
    stem = ref.split("/")[-1].rsplit(".", 1)[0]
    return len(stem) <= 3 or stem.isupper() or stem in {"example", "my_sim", "file", "out", "trace", "report",
                                                        "path", "module", "pkg", "policy", "case", "cases"}
