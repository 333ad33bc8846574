"""The generators of F-FIX and F-SUGGEST: mutated documents, and the check that every fix a
diagnostic claims is correct and every misspelt name gets its right suggestion.

Shared by tests/test_fixes.py (a bounded share) and benchmarks/fuzz_fixes.py (all of it).

* :func:`cases` yields :class:`Case` s: the golden corpus of bad DSL and JSON inputs as they are,
  and the catalogue (plus a recipe with an XOR group and a resource) mutated — a precedence dropped
  (AG305), an earlier operation made to consume a later one's output (AG305 whose `after` would be a
  cycle), a name reference or a keyword or a JSON field misspelt by one edit (AG104, AG204, AG302,
  AG321, AG341, AG360, AG412, AG414, AG415), `use` lines that name official catalogue files from an
  empty directory (AG005).
* :func:`check` validates a case, applies each diagnostic's fix to the file, validates again and
  returns what went wrong: a fix that leaves its error or adds one (F-FIX), a misspelt name whose
  diagnostics do not suggest the right name (F-SUGGEST).
"""

from __future__ import annotations

import json
import re
import shutil
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Iterator

from click.testing import CliRunner

from agspec.cli.main import cli
from agspec.formats.diagnostics import Diagnostic
from agspec.dsl.grammar import keywords
from agspec.catalogue import GEOMETRY_MATCHED, OFFICIAL_SCENARIOS
from agspec.controllers import CONTROLLERS
from agspec.load import Resolver, check_document, load_dsl, load_document
from agspec.resources import catalogue_dir
from agspec.spec_index import spec_entries
from agspec.suggest import Edit, Fix, apply_edits
from agspec.train.config import ALGORITHMS

ROOT = Path(__file__).resolve().parents[1]
GOLDEN = ROOT / "tests" / "golden" / "dsl"
MIN_NAME = 4  # F-SUGGEST: one edit of a name this long stays close to it
KEYWORDS = frozenset(keywords().values())

XOR_DEMO = """recipe xor_demo {
    raw A, B
    resource fixture capacity 1
    xor route = weld_ab | glue_ab
    operation weld_ab {
        type join
        inputs A, B -> AB
        team 2
        roles holder_A(A), holder_B(B)
        duration 2
        uses fixture
    }
    operation glue_ab {
        type join
        inputs A, B -> AB
        team 2
        roles holder_A(A), holder_B(B)
        duration 3
    }
    operation finish {
        type inspect
        after route
        inputs AB -> FINAL
        team 1
        roles holder_AB(AB)
        duration 1
    }
}
"""

# pointers whose string value names something declared elsewhere (F-SUGGEST)
REFERENCE = re.compile(r"^/(?:operations/\d+/(?:after/\d+|resources/\d+|roles/\d+/binds)|xor/\d+/alternatives/\d+"
                       r"|recipes/\d+|profile/(?:id|variant))$")


@dataclass(frozen=True)
class Case:
    """One input: ``files`` (relative path -> text) written into a fresh directory, ``target`` the one
    validated; ``expect`` the right name when a name was misspelt on purpose."""

    name: str
    files: tuple[tuple[str, str], ...]
    target: str
    expect: str | None = None


def misspellings(name: str) -> list[str]:
    """Every one-edit misspelling of ``name`` of one kind each per position: deletion, transposition,
    substitution (a letter it does not have)."""
    out = []
    for i in range(len(name)):
        out.append(name[:i] + name[i + 1:])
        if i + 1 < len(name) and name[i] != name[i + 1]:
            out.append(name[:i] + name[i + 1] + name[i] + name[i + 2:])
        sub = next(c for c in "xqzj" if c not in name)
        out.append(name[:i] + sub + name[i + 1:])
    return list(dict.fromkeys(m for m in out if m and m != name))


def _one_edit(a: str, b: str) -> bool:
    """Whether ``b`` is one deletion, insertion, substitution or transposition away from ``a``
    (compared in one pass: the generators ask it for every pair of hundreds of names)."""
    if a == b or abs(len(a) - len(b)) > 1:
        return False
    if len(a) == len(b):
        diff = [i for i, (x, y) in enumerate(zip(a, b)) if x != y]
        return len(diff) == 1 or (len(diff) == 2 and diff[1] == diff[0] + 1
                                  and a[diff[0]] == b[diff[1]] and a[diff[1]] == b[diff[0]])
    short, long_ = (a, b) if len(a) < len(b) else (b, a)
    i = next((k for k, (x, y) in enumerate(zip(short, long_)) if x != y), len(short))
    return short[i:] == long_[i + 1:]


def _catalogue_files() -> dict[str, str]:
    base = catalogue_dir()
    files = {str(p.relative_to(base)): p.read_text(encoding="utf-8") for p in sorted(base.glob("*/*.ag"))}
    files["recipes/xor_demo.ag"] = XOR_DEMO
    return files


def _replace_span(text: str, span: tuple[int, int, int, int], new: str) -> str:
    lines = text.split("\n")
    line = lines[span[0] - 1]
    lines[span[0] - 1] = line[:span[1] - 1] + new + line[span[3] - 1:]
    return "\n".join(lines)


def _mutations(rel: str, text: str, valid_names: dict[str, list[str]], every: int) -> Iterator[tuple[str, str, str | None]]:
    """(label, mutated text, expected name) of one catalogue file."""
    doc = load_document_text(rel, text)
    if doc is None:
        return
    ir, srcmap = doc
    # names misspelt where they are referenced
    for ptr, span in sorted(srcmap.items()):
        if not REFERENCE.match(ptr) or span[0] != span[2]:
            continue
        value = _at(ir, ptr)
        if not isinstance(value, str) or len(value) < MIN_NAME:
            continue
        line = text.split("\n")[span[0] - 1]
        if line[span[1] - 1:span[3] - 1] != value:
            continue
        others = [n for n in valid_names.get(_kind_of(ptr), _local_names(ir)) if n != value]
        for k, bad in enumerate(misspellings(value)):
            if k % every or any(_one_edit(o, bad) for o in others):
                continue
            yield f"{ptr}={bad}", _replace_span(text, span, bad), value
    # keywords misspelt where a field starts
    for n, line in enumerate(text.split("\n"), start=1):
        m = re.match(r"^(\s+)([a-z_]{%d,})\b" % MIN_NAME, line)
        if not m or m.group(2) in ("operation",):
            continue
        word = m.group(2)
        for k, bad in enumerate(misspellings(word)):
            if k % (every * 3) or bad in KEYWORDS:  # `recipes` -> `recipe` is a misplaced keyword, not a typo
                continue
            yield f"{n}:{word}={bad}", _replace_span(text, (n, len(m.group(1)) + 1, n, m.end() + 1), bad), word
    # precedence dropped, and an earlier operation consuming a later one's output
    for n, line in enumerate(text.split("\n"), start=1):
        if re.match(r"^\s+after\s", line):
            lines = text.split("\n")
            yield f"{n}:drop-after", "\n".join(lines[:n - 1] + lines[n:]), None
    ops = [op for op in ir.get("operations", []) if isinstance(op, dict)]
    for i, early in enumerate(ops):
        for late in ops[i + 1:]:
            if early["id"] in late.get("after", []):
                yield from _consume_later(text, srcmap, i, early, late)


def _consume_later(text: str, srcmap, i: int, early: dict, late: dict) -> Iterator[tuple[str, str, None]]:
    span = srcmap.get(f"/operations/{i}/inputs/{len(early['inputs']) - 1}")
    if span is None:
        return
    yield (f"{early['id']}<-{late['id']}", _replace_span(text, (span[0], span[3], span[0], span[3]),
                                                          f", {late['outputs'][0]}"), None)


def _local_names(ir: dict) -> list[str]:
    """The names a reference inside a recipe may mean: operations, XOR groups, tokens, resources."""
    ops = [op for op in ir.get("operations", []) if isinstance(op, dict)]
    names = [op.get("id") for op in ops] + [g.get("id") for g in ir.get("xor", [])]
    names += [t for op in ops for t in op.get("inputs", []) + op.get("outputs", [])] + list(ir.get("resources", {}))
    return [n for n in names if isinstance(n, str)]


def _at(ir, ptr: str):
    node = ir
    for part in ptr.strip("/").split("/"):
        node = node[int(part)] if isinstance(node, list) else node.get(part)
    return node


def _kind_of(ptr: str) -> str:
    if ptr.startswith("/recipes/"):
        return "recipe"
    if ptr == "/profile/id":
        return "profile"
    if ptr == "/profile/variant":
        return "variant"
    return "local"


def load_document_text(rel: str, text: str):
    """(IR, source map) of a catalogue text."""
    doc = load_dsl(text, rel)
    return (doc.ir, doc.srcmap) if doc.ir is not None else None


def cases(every: int = 1) -> Iterator[Case]:
    """Every case; ``every`` > 1 keeps one misspelling in ``every`` (the bounded share of the tests)."""
    for p in sorted(GOLDEN.iterdir()):
        if p.suffix in (".ag", ".json"):
            yield Case(f"golden/{p.name}", ((p.name, p.read_text(encoding="utf-8")),), p.name)
    files = _catalogue_files()
    valid = {"recipe": [Path(r).stem for r in files if r.startswith("recipes/")],
             "profile": [Path(r).stem for r in files if r.startswith("profiles/")],
             "variant": ["conflict-low", "conflict-medium", "conflict-high", "spacing-0.75", "spacing-1.25"]}
    for rel, text in files.items():
        for label, mutated, expect in _mutations(rel, text, valid, every):
            yield Case(f"{rel}:{label}", tuple({**files, rel: mutated}.items()), rel, expect)
        doc = load_document_text(rel, text)
        if doc is not None:
            yield from _json_cases(rel, doc[0], files, every)
    for rel, text in files.items():  # official names `use`d by a path from an empty directory
        if rel.startswith("scenarios/"):
            uses = re.findall(r'^use "\.\./(.*)"$', text, re.M)
            moved = re.sub(r'^use "\.\./(.*)"$', r'use "catalogue/\1"', text, flags=re.M)
            if uses:
                yield Case(f"{rel}:official-use", ((Path(rel).name, moved),), Path(rel).name)


def _json_cases(rel: str, ir: dict, files: dict[str, str], every: int) -> Iterator[Case]:
    target = str(Path(rel).with_suffix(".json"))
    base = {k: v for k, v in files.items() if k != rel}

    def keys(node, ptr=""):
        if isinstance(node, dict):
            for k, v in node.items():
                yield ptr, k
                yield from keys(v, f"{ptr}/{k}")
        elif isinstance(node, list):
            for n, v in enumerate(node):
                yield from keys(v, f"{ptr}/{n}")

    for k, (ptr, key) in enumerate(keys(ir)):
        if len(key) < MIN_NAME or k % (every * 2) or "/variants" in ptr or ptr.startswith("/resources"):
            continue
        parent = _at(ir, ptr) if ptr else ir
        bad = next((b for b in misspellings(key) if not any(_one_edit(o, b) for o in parent if o != key)), None)
        if bad is None:
            continue
        mutated = _rename(ir, ptr, key, bad)
        yield Case(f"{target}:{ptr}/{key}={bad}", (*base.items(), (target, json.dumps(mutated, indent=2) + "\n")),
                   target, key)


def _rename(ir: dict, ptr: str, key: str, new: str) -> dict:
    copy = json.loads(json.dumps(ir))
    parent = _at(copy, ptr) if ptr else copy
    items = list(parent.items())
    parent.clear()
    parent.update({(new if k == key else k): v for k, v in items})
    return copy


# --------------------------------------------------------------------------- command-line names


def cli_cases(every: int = 1) -> Iterator[tuple[list[str], str]]:
    """(argv, the name it must suggest): every name a command line takes — a controller, an algorithm,
    a scenario, a spec ID — misspelt by one edit, when no other valid name is one edit away."""
    ids = sorted({e.id for e in spec_entries() if "-" in e.id})
    kinds = [
        (CONTROLLERS, lambda bad: ["run", "flow-easy", "--controller", bad, "--horizon", "1"]),
        (ALGORITHMS, lambda bad: ["train", "--algorithm", bad, "--scenario", "flow-easy", "-o", "unused"]),
        ((*OFFICIAL_SCENARIOS, *GEOMETRY_MATCHED), lambda bad: ["run", bad, "--horizon", "1"]),
        (ids[::7], lambda bad: ["explain", "--", bad]),
    ]
    n = 0
    for names, argv in kinds:
        valid = ids if names is not CONTROLLERS and names and names[0] in ids else names
        by_length: dict[int, list[str]] = {}  # one edit changes a length by at most one
        for other in valid:
            by_length.setdefault(len(other), []).append(other)
        for name in names:
            for bad in misspellings(name):
                near = [o for n in (len(bad) - 1, len(bad), len(bad) + 1) for o in by_length.get(n, ()) if o != name]
                if len(bad) < MIN_NAME or bad.upper() == name.upper() or any(
                        _one_edit(o.upper(), bad.upper()) for o in near):
                    continue
                n += 1
                if n % every == 0:
                    yield argv(bad), name


def check_cli(argv: list[str], name: str) -> bool:
    """Whether the command names ``name`` in its "did you mean" (and fails); for `explain`, a prefix of
    an ID may instead list the entries it starts (F-EXPLAIN), which names it too."""
    result = CliRunner().invoke(cli, argv, env={"COLUMNS": "300"})  # a long ID on one line of a table
    out = result.output
    if argv[0] == "explain" and "starting with" in out:
        return re.search(rf"(?<![\w-]){re.escape(name)}(?![\w-])", out) is not None
    return result.exit_code != 0 and re.search(rf"did you mean [`']?([\w.-]+, )*{re.escape(name)}(?![\w-])", out) is not None


# --------------------------------------------------------------------------- the check


def _stage(code: str) -> int:
    """The S-VALIDATION stage of a code: syntax, schema, references, semantics (a later stage runs only
    when the earlier ones leave a usable document)."""
    return {"1": 1, "2": 2}.get(code[2], 3 if code in ("AG005", "AG412", "AG414") else 4 if code[2] in "345" else 0)


def _identity(d: Diagnostic) -> tuple:
    # by message, not pointer: `.ag` operations are numbered in precedence order, so an edit of
    # `after` renumbers them
    return (d.code, d.message)


def diagnose(where: Path, target: str) -> tuple[list[Diagnostic], str]:
    doc = load_document(where / target)
    return check_document(doc, Resolver()), doc.text or ""


def materialize(case: Case, where: Path) -> None:
    if where.exists():
        shutil.rmtree(where)
    for rel, text in case.files:
        path = where / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text, encoding="utf-8")


@dataclass
class Outcome:
    fixes: int = 0  # fixes applied
    wrong_fixes: list[str] | None = None
    named: bool | None = None  # for a misspelt name: whether the right name was suggested


def hint_fix(d: Diagnostic, text: str) -> Fix | None:
    """The edit a reader makes from a prose hint "add `after X` to `Y`" or "did you mean `X`?" —
    how fixes were measured before diagnostics carried them (benchmarks/fuzz_fixes.py --from-hints)."""
    m = re.search(r"add `after (\S+)` to `([^`]+)`", d.hint or "")
    if m and d.file and d.file.endswith(".ag"):
        head = re.search(r"^([ \t]*)operation %s \{[ \t]*$" % re.escape(m.group(2)), text, re.M)
        if head is None:
            return None
        line = text.count("\n", 0, head.end()) + 1
        col = len(head.group(0)) + 1
        return Fix(d.hint, (Edit(line, col, line, col, f"\n{head.group(1)}    after {m.group(1)}"),))
    m = re.search(r"did you mean `([^`]+)`", f"{d.message} {d.hint or ''}")
    if m and d.line and d.end_line == d.line and d.end_col:
        return Fix(f"write {m.group(1)}", (Edit(d.line, d.col, d.line, d.end_col, m.group(1)),))
    return None


def check(case: Case, where: Path, from_hints: bool = False) -> Outcome:
    """Validate ``case`` in ``where``; apply every fix and validate again (F-FIX); look for the right
    suggestion of a misspelt name (F-SUGGEST).  ``from_hints``: the fixes are read from the hints'
    prose instead (:func:`hint_fix`)."""
    materialize(case, where)
    before, text = diagnose(where, case.target)
    out = Outcome(wrong_fixes=[])
    if case.expect is not None:
        out.named = any(case.expect in closest_named(d) for d in before)
    blocking = min((_stage(d.code) for d in before if d.severity == "error" and _stage(d.code) in (1, 2)), default=9)
    for d in before:
        if from_hints:
            d = replace(d, fix=hint_fix(d, text)) if "fix" in Diagnostic.__dataclass_fields__ else _Fixed(d, hint_fix(d, text))
        if d.fix is None:
            continue
        out.fixes += 1
        (where / case.target).write_text(apply_edits(text, d.fix.edits), encoding="utf-8")
        after, _ = diagnose(where, case.target)
        (where / case.target).write_text(text, encoding="utf-8")
        old = {_identity(x) for x in before}
        left = [x for x in after if _identity(x) == _identity(d)]
        added = [x for x in after if x.severity == "error" and _identity(x) not in old
                 and not _revealed(x, d, blocking)]
        if left or added:
            out.wrong_fixes.append(f"{case.name}: {d.code} fix `{d.fix.description}` -> "
                                   + "; ".join(f"{x.code} {x.message}" for x in left + added))
    return out


def closest_named(d: Diagnostic) -> set[str]:
    """The names a diagnostic suggests: its fix's replacement text and its "did you mean"."""
    named = set(re.findall(r"did you mean [`']([^`']+)[`']", f"{d.message} {d.hint or ''}"))
    if getattr(d, "fix", None) is not None:
        named |= {e.text.strip().strip('"') for e in d.fix.edits}
    return named


@dataclass(frozen=True)
class _Fixed:
    """A diagnostic of a version without ``fix``, with the fix read from its hint."""

    diagnostic: Diagnostic
    fix: Fix | None

    def __getattr__(self, name: str):
        return getattr(self.diagnostic, name)


def _revealed(new: Diagnostic, fixed: Diagnostic, blocking: int) -> bool:
    """A finding of a stage the fixed error kept from running (S-VALIDATION): the schema after a
    syntax error, the semantic checks after a schema error, a check of the name the fix resolved (F-FIX)."""
    if _stage(new.code) > blocking:
        return True
    return bool(fixed.pointer and new.pointer and new.pointer.startswith(fixed.pointer))


__all__ = ["Case", "Outcome", "cases", "check", "misspellings"]
