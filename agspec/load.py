"""Load documents from disk and resolve references by name (spec F-DSL, F-IR, F-DIAGNOSTICS).

* :func:`load_document` reads a ``.ag`` file (parse + build) or a ``.json`` IR file and returns
  a :class:`Document` with its IR, source map and diagnostics.  JSON positions come from
  parsing the text with a lark JSON grammar with positions; values come from ``json``.
* :class:`Resolver` finds recipes, profiles and scenarios by name: first among the ``use``
  includes of the document being resolved (transitively), then in the document's directory
  tree (its directory, its ``<kind>s/`` subdirectory and the sibling ``../<kind>s/``), then in
  the search paths (each ``P/`` and ``P/<kind>s/``), finally in the official catalogue
  (``catalogue/<kind>s/``).  A found file must hold a document of that kind and id.
* :func:`check_document` runs the full check: load diagnostics, JSON Schema (AG2xx),
  references (AG005) and semantic validation (``agspec.ir.validate.validate_document``, when
  that module is available).

I/O codes: AG001 file not found, AG002 unreadable (directory, special file), AG003 not valid JSON,
AG006 an F-LIMITS limit exceeded, AG007 not UTF-8,
AG004 unknown document kind or file type, AG005 unresolved include, AG412/AG414 unresolved recipe/profile,
AG000 internal error (a bug in agspec; please file an issue).
"""

from __future__ import annotations

import importlib
import json
import re
from dataclasses import dataclass, field, replace
from functools import lru_cache
from pathlib import Path
from typing import Any, Callable, Iterable, Sequence

from lark import Lark, Token, Tree
from lark.exceptions import UnexpectedInput

from agspec.dsl.build import DSL_SPELLING, build
from agspec.dsl.parse import parse
from agspec.formats import limits, positions
from agspec.formats.diagnostics import Diagnostic, Issue, Span, json_pointer, locate
from agspec.ir.schemas import KINDS, ir_integers, validate_schema
from agspec.resources import catalogue_dir
from agspec.suggest import Change, Fix, closest, line_removal

DOCUMENT_KINDS = ("recipe", "profile", "scenario")  # what can be referenced by name
SUFFIXES = (".ag", ".json")
POSITIONS_MAX_CHARS = 256 * 1024  # JSON texts up to this size get their source map at load time

# A JSON grammar with named terminals, used only for source positions (json.loads gives values).
JSON_GRAMMAR = r"""
?start: value
?value: object | array | string | NUMBER | TRUE | FALSE | NULL
object: LBRACE [pair (COMMA pair)*] RBRACE
array: LBRACK [value (COMMA value)*] RBRACK
pair: string COLON value
string: STRING
STRING: /"(?:[^"\\]|\\.)*"/
NUMBER: /-?(?:0|[1-9][0-9]*)(?:\.[0-9]+)?(?:[eE][+-]?[0-9]+)?/
TRUE: "true"
FALSE: "false"
NULL: "null"
LBRACE: "{"
RBRACE: "}"
LBRACK: "["
RBRACK: "]"
COMMA: ","
COLON: ":"
WS: /[ \t\r\n]+/
%ignore WS
"""


@dataclass(frozen=True)
class UseRef:
    """A ``use "path"`` statement of a DSL file."""

    path: str
    span: Span


@dataclass(frozen=True)
class Document:
    """A loaded document: IR (None if it could not be read/parsed), source map, diagnostics."""

    path: Path | None
    kind: str | None
    ir: dict[str, Any] | None
    srcmap: dict[str, Span]
    text: str | None
    diagnostics: tuple[Diagnostic, ...]
    uses: tuple[UseRef, ...] = field(default_factory=tuple)

    @property
    def file(self) -> str | None:
        return str(self.path) if self.path is not None else None

    @property
    def name(self) -> str | None:
        return self.ir.get("id") if isinstance(self.ir, dict) and isinstance(self.ir.get("id"), str) else None

    @property
    def ok(self) -> bool:
        return self.ir is not None and not any(d.severity == "error" for d in self.diagnostics)


def _diag(code: str, message: str, file: str | None, line: int | None = None, col: int | None = None,
          hint: str | None = None, end_col: int | None = None) -> Diagnostic:
    end = end_col if end_col is not None else (col + 1 if col is not None else None)
    return Diagnostic(code=code, message=message, file=file, line=line, col=col,
                      end_line=line if line is not None else None, end_col=end, hint=hint)


def _failed(path: Path | None, text: str | None, *diags: Diagnostic) -> Document:
    return Document(path=path, kind=None, ir=None, srcmap={}, text=text, diagnostics=tuple(diags))


# --------------------------------------------------------------------------- reading


def read_text(path: Path) -> tuple[str | None, Diagnostic | None]:
    """UTF-8 text of a file (a leading BOM dropped), or its AG001/AG002/AG006/AG007 diagnostic (F-LIMITS)."""
    try:
        return limits.read_text(path), None
    except limits.InputError as exc:
        return None, exc.diagnostic()


def io_fault(doc: Document, diags: Sequence[Diagnostic] = ()) -> bool:
    """Whether the document could not be *reached* — missing, not a readable regular file, or of an
    unknown file type — a usage/I/O error (exit 2) rather than invalid content (RES-EXIT-CONTENT)."""
    return any(d.code in limits.IO_CODES for d in (*doc.diagnostics, *diags)) or (
        doc.text is None and any(d.code == "AG004" for d in doc.diagnostics))


def load_document(path: str | Path) -> Document:
    """Load a ``.ag`` or ``.json`` document (F-DSL, F-IR).  Never raises on user input."""
    path = Path(path)
    file = str(path)
    suffix = path.suffix.lower()
    if suffix not in SUFFIXES:
        try:  # F-LIMITS: missing, directory and special files first (AG001/AG002)
            limits.check_file(path)
        except limits.InputError as exc:
            if exc.exit_code == limits.EXIT_USAGE:
                return _failed(path, None, exc.diagnostic())
        return _failed(path, None, _diag("AG004", f"unknown file type `{path.suffix or path.name}`", file,
                                         hint="agspec reads `.ag` (DSL) and `.json` (IR) files"))
    text, problem = read_text(path)
    if problem is not None:
        return _failed(path, None, problem)
    assert text is not None
    return load_dsl(text, file) if suffix == ".ag" else load_json(text, file)


def load_dsl(text: str, file: str | None = None) -> Document:
    """Parse and build DSL text (F-DSL)."""
    try:  # F-LIMITS: a 100,000-character name is refused before the parser and the renderer see it
        limits.check_dsl_text(text, file)
    except limits.InputError as exc:
        return _failed(Path(file) if file else None, text, exc.diagnostic())
    source = parse(text, file)
    built = build(source)
    kind = built.ir.get("kind") if built.ir else None
    uses = tuple(UseRef(u.path.value, u.path.span) for u in source.uses)
    return Document(path=Path(file) if file else None, kind=kind, ir=built.ir, srcmap=built.srcmap, text=text,
                    diagnostics=built.diagnostics, uses=uses)


# --------------------------------------------------------------------------- JSON


@lru_cache(maxsize=1)
def _json_parser() -> Lark:
    return Lark(JSON_GRAMMAR, parser="lalr", lexer="contextual", propagate_positions=True,
                maybe_placeholders=False)


def _srcmap(text: str) -> dict[str, Span]:
    """Source positions of a JSON text, or {} for a large text (F-LIMITS-POSITIONS): the positional parse costs about 200
    times the text's size in memory, so large documents are mapped only when a diagnostic needs it
    (``check_document``)."""
    if len(text) > POSITIONS_MAX_CHARS:
        return {}
    try:
        return json_positions(text)[0]
    except (UnexpectedInput, RecursionError):  # json accepted what the grammar did not: positions unknown
        return {}


def _tok_span(tok: Token) -> Span:
    return (tok.line, tok.column, tok.end_line or tok.line, tok.end_column or tok.column + 1)


def _first_token(node: Any) -> Token:
    if isinstance(node, Token):
        return node
    return next(node.scan_values(lambda v: isinstance(v, Token)))


def _value_span(node: Any) -> Span:
    """A scalar's own span; a container's opening bracket."""
    return _tok_span(_first_token(node))


def json_positions(text: str) -> tuple[dict[str, Span], list[tuple[str, Span]]]:
    """Source map of a JSON text: pointer -> span, and duplicate keys (pointer, span).

    Scalars map to ``"key": value`` (or the value in an array); objects and arrays to their
    key (or opening bracket); an object in an array to its ``"id"`` member when it has one.
    """
    tree = _json_parser().parse(text)
    srcmap: dict[str, Span] = {}
    duplicates: list[tuple[str, Span]] = []

    def walk(node: Any, ptr: str, key_tok: Token | None) -> None:
        container = isinstance(node, Tree) and node.data in ("object", "array")
        if key_tok is not None:
            if container:
                srcmap[ptr] = _tok_span(key_tok)
            else:
                end = _value_span(node)
                start = _tok_span(key_tok)
                srcmap[ptr] = (start[0], start[1], end[2], end[3])
        else:
            srcmap[ptr] = _value_span(node)
        if not isinstance(node, Tree):
            return
        if node.data == "object":
            seen: set[str] = set()
            for pair in node.children:
                if not isinstance(pair, Tree) or pair.data != "pair":
                    continue
                key_node, value = pair.children[0], pair.children[2]
                tok = _first_token(key_node)
                key = json.loads(str(tok))
                child = ptr + json_pointer(key)
                if key in seen:
                    duplicates.append((child, _tok_span(tok)))
                    continue
                seen.add(key)
                walk(value, child, tok)
            if key_tok is None and "id" in seen and ptr:
                srcmap[ptr] = srcmap[ptr + "/id"]
        elif node.data == "array":
            values = [c for c in node.children if not isinstance(c, Token)
                      or c.type in ("NUMBER", "TRUE", "FALSE", "NULL")]
            for i, child_node in enumerate(values):
                walk(child_node, f"{ptr}/{i}", None)

    walk(tree, "", None)
    return srcmap, duplicates


def load_json(text: str, file: str | None = None) -> Document:
    """Read a JSON IR document (F-IR); positions from the lark JSON grammar."""
    path = Path(file) if file else None
    try:  # F-LIMITS: depth, number and string limits; duplicate keys and NaN are refused here
        ir = limits.parse_json(text, file)
    except limits.InputError as exc:
        return _failed(path, text, exc.diagnostic())
    srcmap = _srcmap(text)
    diags: list[Diagnostic] = []
    if not isinstance(ir, dict):
        diags.append(_diag("AG004", "an IR document must be a JSON object", file, 1, 1))
        return Document(path=path, kind=None, ir=None, srcmap=srcmap, text=text, diagnostics=tuple(diags))
    kind = ir.get("kind")
    if kind not in KINDS:
        issue = Issue("AG004", f"unknown document kind {json.dumps(kind)}", "/kind" if "kind" in ir else "",
                      hint="`kind` must be one of " + ", ".join(KINDS))
        diags.append(locate(issue, file, srcmap))
        kind = None
    ir_integers(ir)  # F-VALUES, RES-INTEGRAL-NUMBERS: `"radius": 1.0` is the radius 1
    return Document(path=path, kind=kind, ir=ir, srcmap=srcmap, text=text, diagnostics=tuple(diags))


# --------------------------------------------------------------------------- resolver


class Resolver:
    """Find recipes, profiles and scenarios by name (see the module docstring for the order).

    ``resolver.bind(doc)`` returns a resolver that searches from ``doc`` (its ``use``
    includes and directory tree); ``recipe(name)``, ``profile(name)``, ``scenario(name)``
    return IR dicts (None when not found).  Loaded files are cached per resolver family.
    """

    def __init__(self, search_paths: Iterable[str | Path] = (), *, catalogue: bool = True,
                 origin: Document | None = None, _cache: dict[Path, Document] | None = None) -> None:
        self.search_paths = tuple(Path(p) for p in search_paths)
        self.catalogue = catalogue
        self.origin = origin
        self._cache: dict[Path, Document] = {} if _cache is None else _cache

    def bind(self, origin: Document | None) -> "Resolver":
        return Resolver(self.search_paths, catalogue=self.catalogue, origin=origin, _cache=self._cache)

    # -- loading -----------------------------------------------------------
    def load_path(self, path: Path) -> Document:
        key = path.resolve()
        if key not in self._cache:
            self._cache[key] = load_document(path)
        return self._cache[key]

    def includes(self, origin: Document) -> list[Document]:
        """Documents reachable through ``use`` statements, depth first, each once."""
        out: list[Document] = []
        seen: set[Path] = set()

        def visit(doc: Document) -> None:
            if doc.path is None:
                return
            for use in doc.uses:
                target = (doc.path.parent / use.path)
                if target.suffix.lower() not in SUFFIXES or not target.is_file():
                    continue
                key = target.resolve()
                if key in seen:
                    continue
                seen.add(key)
                included = self.load_path(target)
                out.append(included)
                visit(included)

        visit(origin)
        return out

    def _dirs(self, kind: str, origin: Document | None) -> list[Path]:
        plural = f"{kind}s"
        dirs: list[Path] = []
        if origin is not None and origin.path is not None:
            here = origin.path.parent
            dirs += [here, here / plural, here.parent / plural]
        for base in self.search_paths:
            dirs += [base, base / plural]
        if self.catalogue:
            dirs.append(catalogue_dir() / plural)
        return dirs

    def names(self, kind: str, origin: Document | None = None) -> list[str]:
        """The names a reference of ``kind`` could mean from ``origin`` (F-SUGGEST): the documents
        of its includes and the file names of the directories searched."""
        origin = origin if origin is not None else self.origin
        found = [d.name for d in self.includes(origin) if d.kind == kind and d.name] if origin is not None else []
        for d in self._dirs(kind, origin):
            if d.is_dir():
                found += [p.stem for p in d.iterdir() if p.suffix.lower() in SUFFIXES]
        return sorted(set(found))

    def _candidates(self, kind: str, name: str, origin: Document | None) -> Iterable[Path]:
        seen: set[Path] = set()
        for d in self._dirs(kind, origin):
            for suffix in SUFFIXES:
                p = d / f"{name}{suffix}"
                key = p.resolve() if p.exists() else p
                if key not in seen:
                    seen.add(key)
                    yield p

    def load(self, kind: str, name: str, origin: Document | None = None) -> Document | None:
        """The document of ``kind`` with id ``name``, or None."""
        origin = origin if origin is not None else self.origin
        if origin is not None:
            for doc in self.includes(origin):
                if doc.kind == kind and doc.name == name:
                    return doc
        for path in self._candidates(kind, name, origin):
            if not path.is_file():
                continue
            doc = self.load_path(path)
            if origin is not None and origin.path is not None and doc.path is not None \
                    and doc.path.resolve() == origin.path.resolve():
                continue
            if doc.kind == kind and doc.name == name:
                return doc
        return None

    def find(self, kind: str, name: str, origin: Document | None = None) -> Path | None:
        doc = self.load(kind, name, origin)
        return doc.path if doc is not None else None

    def get(self, kind: str, name: str, origin: Document | None = None) -> dict[str, Any] | None:
        doc = self.load(kind, name, origin)
        return doc.ir if doc is not None else None

    def recipe(self, name: str) -> dict[str, Any] | None:
        return self.get("recipe", name)

    def profile(self, name: str) -> dict[str, Any] | None:
        return self.get("profile", name)

    def scenario(self, name: str) -> dict[str, Any] | None:
        return self.get("scenario", name)

    def resolve_scenario_name(self, name: str) -> Path | None:
        """Path of the scenario called ``name`` (e.g. "coalition-medium" -> catalogue file)."""
        return self.find("scenario", name)

    # -- reference checks (AG005 files, AG412 recipes, AG414 profiles) ------------------
    def check_references(self, doc: Document) -> list[Diagnostic]:
        """AG005 for ``use`` files that do not exist and names no search finds."""
        diags: list[Diagnostic] = []
        if doc.path is not None:
            for use in doc.uses:
                target = doc.path.parent / use.path
                where = dict(file=doc.file, line=use.span[0], col=use.span[1], end_line=use.span[2],
                             end_col=use.span[3])
                if not target.is_file():
                    diags.append(self._missing_use(doc, use, where))
                    continue
                used = self.load_path(target)
                errors = sum(1 for d in used.diagnostics if d.severity == "error")
                if errors or used.kind not in DOCUMENT_KINDS:
                    what = f"has {errors} error(s)" if errors else "is not a recipe, profile or scenario"
                    diags.append(Diagnostic(code="AG005", message=f"cannot use `{use.path}`: it {what}",
                                            hint=f"run `agspec validate {target}`", **where))
        ir = doc.ir
        if doc.kind != "scenario" or not isinstance(ir, dict):
            return diags
        refs: list[tuple[str, Any, str]] = []
        for i, rid in enumerate(ir.get("recipes") or []):
            refs.append(("recipe", rid, f"/recipes/{i}"))
        profile = ir.get("profile")
        if isinstance(profile, dict):
            refs.append(("profile", profile.get("id"), "/profile/id"))
        for kind, name, ptr in refs:
            if not isinstance(name, str) or self.load(kind, name, doc) is not None:
                continue
            # F-CODES: a name in the product mix is AG412, the profile AG414; AG005 is for `use` files
            code, what = ("AG412", "unknown recipe") if kind == "recipe" else ("AG414", "unknown geometry profile")
            match = closest(name, self.names(kind, doc))
            if match:  # F-SUGGEST: a misspelt name is corrected in place (F-FIX)
                issue = Issue(code, f"{what} `{name}`: no file declares it; did you mean `{match[0]}`?", ptr,
                              hint=f"write `{match[0]}`",
                              change=Change("replace", ptr, match[0], f"replace `{name}` by `{match[0]}`"))
            else:
                issue = Issue(code, f"{what} `{name}`: no file declares it", ptr,
                              hint=f"add `use \"path/{name}.ag\"`, put {name}.ag next to this file or in "
                                   f"a `{kind}s/` directory, or pass a search path")
            diags.append(locate(issue, doc.file, doc.srcmap, _fix_text(doc), _is_dsl(doc)))
        return diags

    def _missing_use(self, doc: Document, use: UseRef, where: dict[str, Any]) -> Diagnostic:
        """AG005 for a `use` file that does not exist.  A path naming an official catalogue file
        (`…/recipes/pair_assembly.ag`) is not needed at all: official names resolve from the
        installed catalogue without `use` (F-DSL-USE), so the fix deletes the line."""
        used = Path(use.path)
        kind = used.parent.name[:-1] if used.parent.name.endswith("s") else ""
        official = kind in DOCUMENT_KINDS and self.catalogue and (catalogue_dir() / used.parent.name / used.name).is_file()
        message = f"cannot find the used file `{use.path}`"
        if official and doc.text is not None:
            return Diagnostic(code="AG005", message=message, **where,
                              hint=f"`{used.stem}` is an official {kind}: official names resolve from the installed "
                                   "catalogue without `use` (F-DSL-USE); delete this line",
                              fix=Fix("delete this `use` line", (line_removal(doc.text, use.span[0]),)))
        return Diagnostic(code="AG005", message=message, **where,
                          hint=f"paths are relative to the file's directory ({doc.path.parent if doc.path else '.'}); "
                               "official names resolve without `use`")


def _is_dsl(doc: Document) -> bool:
    return doc.path is not None and doc.path.suffix.lower() == ".ag"


def _fix_text(doc: Document) -> str | None:
    """The text fixes are placed in (F-FIX): only a file's, whose format (.ag or .json) is known, and
    that has its full source map — a large JSON text is mapped to points, not spans
    (F-LIMITS-POSITIONS), so no edit could be placed exactly."""
    if doc.path is None or doc.path.suffix.lower() not in SUFFIXES or not doc.srcmap:
        return None
    return doc.text


def resolve_scenario_name(name: str, search_paths: Sequence[str | Path] = ()) -> Path | None:
    """Path of the scenario called ``name`` in the search paths or the official catalogue."""
    return Resolver(search_paths).resolve_scenario_name(name)


def resolve_argument(arg: str, search_paths: Sequence[str | Path] = ()) -> Path:
    """A command-line argument: an existing file, else a document name (scenario first)."""
    path = Path(arg)
    if path.exists() or path.suffix.lower() in SUFFIXES or "/" in arg:
        return path
    resolver = Resolver(search_paths)
    for kind in ("scenario", "recipe", "profile"):
        found = resolver.find(kind, arg)
        if found is not None:
            return found
    return path


# --------------------------------------------------------------------------- full check


SemanticValidator = Callable[[dict[str, Any], Any], list[Issue]]


def semantic_validator() -> SemanticValidator | None:
    """``agspec.ir.validate.validate_document`` if that module provides it, else None."""
    try:
        module = importlib.import_module("agspec.ir.validate")
    except ImportError:
        return None
    func = getattr(module, "validate_document", None)
    if not callable(func):
        return None
    try:  # scenarios also get the realizability checks, which need the geometry model (S-FEASIBILITY)
        module = importlib.import_module("agspec.interp.realizability")
        full, payload = module.validate_scenario_full, module.check_payload
    except (ImportError, AttributeError):
        return func

    def validate(ir, resolver):
        if isinstance(ir, dict) and ir.get("kind") == "scenario":
            return full(ir, resolver)
        issues = func(ir, resolver)
        if isinstance(ir, dict) and ir.get("kind") == "instance" and isinstance(ir.get("scenario"), dict) \
                and isinstance(ir.get("profile"), dict):  # AG459 on the embedded scenario and profile too
            issues += [replace(i, pointer="/scenario" + i.pointer) for i in payload(ir["scenario"], ir["profile"])]
        return issues

    return validate


def _dsl_hint(doc: Document, issue: Issue) -> Issue:
    """Say how to write a missing field in the DSL (AG201 on `.ag` files)."""
    if issue.code != "AG201" or issue.hint or doc.path is None or doc.path.suffix != ".ag":
        return issue
    match = re.search(r"`([^`]+)`", issue.message)
    spelling = DSL_SPELLING.get(match.group(1)) if match else None
    return replace(issue, hint=f"add `{spelling}`") if spelling else issue


def _positions(doc: Document) -> Callable[[Iterable[str]], dict[str, Span]]:
    """The document's source map for the pointers of some diagnostics.  A large JSON text, loaded
    without one (``_srcmap``), is mapped only for those pointers and their ancestors, by one walk
    over its tokens that stops when it has found them (F-LIMITS-POSITIONS): time linear in the text,
    memory bounded by its depth."""
    cache: dict[str, Span] = dict(doc.srcmap)
    large = not doc.srcmap and doc.text is not None and len(doc.text) > POSITIONS_MAX_CHARS and doc.kind is not None
    tried: set[str] = set()

    def srcmap(pointers: Iterable[str]) -> dict[str, Span]:
        if not large:
            return cache
        wanted: set[str] = set()
        for ptr in pointers:
            while ptr not in wanted:
                wanted.add(ptr)
                if not ptr:
                    break
                ptr = ptr.rsplit("/", 1)[0]
        wanted -= tried
        if wanted:
            tried.update(wanted)
            text = doc.text or ""
            for ptr, offset in positions.pointer_offsets(text, wanted).items():
                line, col = positions.offset_position(text, offset)
                cache[ptr] = (line, col, line, col + 1)
        return cache

    return srcmap


def check_document(doc: Document, resolver: Resolver | None = None, *, semantic: bool = True) -> list[Diagnostic]:
    """All diagnostics of a loaded document: load/syntax/build, schema, references, semantics.

    Later stages run only when earlier ones leave a usable IR: schema checks need an IR of a
    known kind; reference and semantic checks need a schema-valid IR.
    """
    diags = list(doc.diagnostics)
    if doc.ir is None or doc.kind is None:
        return diags
    srcmap = _positions(doc)
    issues = validate_schema(doc.ir)
    if issues:  # F-CODES: a bad value gets its rule's code; the semantic checks load only when needed
        issues = importlib.import_module("agspec.ir.validate").rule_codes(doc.ir, issues)
    issues = [_dsl_hint(doc, i) for i in issues]
    where = srcmap(i.pointer for i in issues) if issues else {}
    diags += [locate(i, doc.file, where, _fix_text(doc), _is_dsl(doc)) for i in issues]
    if any(i.severity == "error" for i in issues):
        return diags
    resolver = (resolver or Resolver()).bind(doc)
    references = resolver.check_references(doc)
    diags += references
    validate = semantic_validator() if semantic else None
    if validate is not None:
        try:
            found = validate(doc.ir, resolver)
        except Exception as exc:  # a bug in agspec, not a user error (F-DIAGNOSTICS)
            diags.append(Diagnostic(code="AG000", message=f"internal error in semantic validation: {exc!r}",
                                    file=doc.file, hint="this is a bug in agspec; please file an issue"))
        else:
            # an unresolved name is reported once, by the reference check with the search hint
            unresolved = {d.pointer for d in references if d.pointer}
            found = [i for i in found or [] if i.pointer not in unresolved]
            where = srcmap(i.pointer for i in found) if found else {}
            diags += [locate(i, doc.file, where, _fix_text(doc), _is_dsl(doc)) for i in found]
    return diags
