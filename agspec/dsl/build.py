"""Build IR from the DSL AST, with a source map (spec F-DSL, F-IR, F-DIAGNOSTICS).

``build(source)`` turns a parsed :class:`~agspec.dsl.parse.SourceFile` into the IR of the
contract (plain JSON, ``ir_version`` "agspec-ir/1") in canonical order, with defaults filled
in, plus ``srcmap``: JSON Pointer -> (line, col, end_line, end_col) for every IR node that
came from source text.  Later checks report :class:`~agspec.formats.diagnostics.Issue` objects with
JSON Pointers; :func:`agspec.formats.diagnostics.locate` places them in the file with this map.

Canonical order (F-IR): operations sorted by id; ``inputs``, ``after`` and an operation's
``resources`` sorted; XOR groups sorted by id with sorted alternatives.  ``raw``, ``roles``,
``recipes`` and ``tools`` keep their written order (it is meaningful).

Defaults (F-DSL-DEFAULTS): recipe ``value`` 1.0, ``resources`` {}, ``xor`` []; operation
``after`` [], ``roles`` [], ``resources`` [], ``weight`` 1.0; profile and scenario settings
not given take the v1 constants (paper table "Constants shared by the official
configurations"), see :data:`PROFILE_DEFAULTS` and :data:`SCENARIO_DEFAULTS`.  Fields without
a default (e.g. an operation's ``duration``, a scenario's ``recipes``) stay absent and the
schema check reports them (AG201).

Build diagnostics: AG206 duplicate field or key, AG301 duplicate operation id, AG343
duplicate role name in an operation, AG325 duplicate XOR group.  The duplicate is dropped
(the first one wins), so later checks still run on a sensible IR.  Build never raises on
user input.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from typing import Any, Callable

from agspec import IR_VERSION
from agspec.dsl.parse import Atom, DocumentNode, Field, SourceFile, parse
from agspec.formats.diagnostics import Diagnostic, Span, json_pointer

# v1 defaults: paper table "Constants shared by the official configurations" (abstract-v1).
PROFILE_DEFAULTS: dict[str, Any] = {
    "spacing": 1.0,
    "reach": 1.5,
    "reference_reach": 1.5,
    "reference_time": 1.0,
    "rho_conf": 0.25,
    "clearance": 0.1,
    "role_target_offset": 0.12,
    "retreat_fraction": 0.25,
    "speed": 1.0,
    "joint_speed": 1.0,
    "payload": 10.0,
    "robot_model": "generic_ur",
    "tools": ["gripper"],
    "durations": {"pick": 2, "handoff": 1, "deliver": 2},
    "motion_planning": True,
    "trajectory_conflicts": True,
}

# v1 defaults of a scenario (same table; grid and profile: the official suite base).
# family, level, recipes and release (interval, wip cap) have no default.
SCENARIO_DEFAULTS: dict[str, Any] = {
    "grid": {"rows": 5, "cols": 6, "topology": "moore", "radius": 1},
    "profile": {"id": "abstract-v1", "variant": None},
    "evaluation": {"mode": "continuing", "horizon": 400},
    "shelves": {"capacity": 6, "replenish_interval": 5, "extra_access_probability": 0.3},
    "coordination": {"support_timeout": 3, "switch_lock": 1, "support_visible": True,
                     "bilateral_handoff": True},
    "products": {"mass": [0.5, 2.0], "due_slack": 2.2, "due_slack_jitter": 0.5},
    "resources": {},
}
BATCH_TIMEOUT_DEFAULT = 400  # the original's horizon_T bounds a batch episode

# How a missing IR field is written in the DSL (used as a hint for AG201 on .ag files).
DSL_SPELLING: dict[str, str] = {
    "raw": "raw A, B",
    "operations": "operation NAME { ... }",
    "type": "type NAME",
    "inputs": "inputs A, B -> AB",
    "outputs": "inputs A, B -> AB",
    "arity": "team 2  (or team 2..4)",
    "duration": "duration 3",
    "family": "family NAME",
    "level": "level NAME",
    "recipes": "recipes NAME, ...",
    "release": "release every 5` and `wip 4",
    "interval": "release every 5",
    "wip_cap": "wip 4",
}


@dataclass(frozen=True)
class Built:
    """The result of :func:`build`: IR (None only without a document), source map, diagnostics."""

    ir: dict[str, Any] | None
    srcmap: dict[str, Span]
    diagnostics: tuple[Diagnostic, ...]


Conv = Callable[[Atom], Any]


def _float(atom: Atom) -> Any:
    if isinstance(atom.value, bool) or not isinstance(atom.value, (int, float)):
        return atom.value
    return float(atom.value)


def _int(atom: Atom) -> Any:
    # An integral decimal (3.0) is an integer in JSON Schema; store it as one.  Anything else
    # is kept as written and the schema check reports the type (AG202).
    value = atom.value
    if isinstance(value, float) and value.is_integer():
        return int(value)
    return value


def _plain(atom: Atom) -> Any:
    return atom.value


def _span(a: Span, b: Span) -> Span:
    return (a[0], a[1], b[2], b[3])


class _Builder:
    def __init__(self, file: str | None) -> None:
        self.file = file
        self.srcmap: dict[str, Span] = {}
        self.diags: list[Diagnostic] = []

    # -- bookkeeping -------------------------------------------------------
    def at(self, pointer: str, span: Span | None) -> None:
        if span is not None:
            self.srcmap[pointer] = span

    def error(self, code: str, message: str, span: Span, hint: str | None = None,
              notes: tuple[str, ...] = ()) -> None:
        self.diags.append(Diagnostic(code=code, message=message, file=self.file, line=span[0], col=span[1],
                                     end_line=span[2], end_col=span[3], hint=hint, notes=notes))

    def unique(self, fields: tuple[Field, ...], what: str) -> list[Field]:
        """Drop repeated fields of one block (AG206); the first one wins."""
        seen: dict[str, Field] = {}
        out = []
        for f in fields:
            if f.key in seen and f.key not in ("operation", "xor", "resource", "variant"):
                first = seen[f.key]
                self.error("AG206", f"duplicate {what} `{f.key}`", f.key_span,
                           hint="remove one of them",
                           notes=(f"first given at {first.key_span[0]}:{first.key_span[1]}",))
                continue
            seen.setdefault(f.key, f)
            out.append(f)
        return out

    def value(self, pointer: str, atom: Atom, conv: Conv) -> Any:
        self.at(pointer, atom.span)
        return conv(atom)

    def names(self, pointer: str, atoms: tuple[Atom, ...], *, sort: bool) -> list[str]:
        pairs = [(a.value, a.span) for a in atoms]
        if sort:
            pairs.sort(key=lambda p: p[0])
        for i, (_v, span) in enumerate(pairs):
            self.at(f"{pointer}/{i}", span)
        return [v for v, _s in pairs]

    # -- documents ---------------------------------------------------------
    def document(self, doc: DocumentNode) -> dict[str, Any]:
        self.at("", doc.header_span)
        self.at("/id", doc.name.span)
        ir: dict[str, Any] = {"ir_version": IR_VERSION, "kind": doc.kind, "id": doc.name.value}
        body = self.unique(doc.body, f"{doc.kind} field")
        {"recipe": self.recipe, "profile": self.profile, "scenario": self.scenario}[doc.kind](ir, body)
        return ir

    # -- recipe (RC-*) -----------------------------------------------------
    def recipe(self, ir: dict[str, Any], body: list[Field]) -> None:
        fields = {f.key: f for f in body}
        if "doc" in fields:
            ir["doc"] = self.value("/doc", fields["doc"].args[0], _plain)
        ir["value"] = self.value("/value", fields["value"].args[0], _float) if "value" in fields else 1.0
        if "raw" in fields:
            self.at("/raw", fields["raw"].span)
            ir["raw"] = self.names("/raw", fields["raw"].items, sort=False)
        ir["resources"] = self.resources("/resources", [f for f in body if f.key == "resource"])
        ir["operations"] = self.operations([f for f in body if f.key == "operation"])
        ir["xor"] = self.xor_groups([f for f in body if f.key == "xor"])

    def resources(self, pointer: str, fields: list[Field]) -> dict[str, Any]:
        out: dict[str, Any] = {}
        first: dict[str, Field] = {}
        for f in sorted(fields, key=lambda f: f.name.value):
            name = f.name.value
            if name in first:
                self.error("AG206", f"duplicate resource `{name}`", f.name.span, hint="declare each resource once",
                           notes=(f"first declared at {first[name].span[0]}:{first[name].span[1]}",))
                continue
            first[name] = f
            capacity = f.args[0]
            key = json_pointer(*pointer.strip("/").split("/"), name)
            self.at(key, f.span)
            out[name] = _int(capacity) if capacity is not None else 1
        if fields and first:
            self.at(pointer, min((f.span for f in first.values())))
        return out

    def unique_named(self, fields: list[Field], code: str, what: str, hint: str, verb: str) -> list[Field]:
        """The fields with a first-seen name, sorted by name; every repeated name is an error ``code``."""
        first: dict[str, Field] = {}
        kept = []
        for f in fields:
            name = f.name.value
            if name in first:
                prev = first[name]
                self.error(code, f"duplicate {what} `{name}`", f.name.span, hint=hint,
                           notes=(f"first {verb} at {prev.name.span[0]}:{prev.name.span[1]}",))
                continue
            first[name] = f
            kept.append(f)
        kept.sort(key=lambda f: f.name.value)
        return kept

    def operations(self, fields: list[Field]) -> list[dict[str, Any]]:
        kept = self.unique_named(fields, "AG301", "operation id", "give every operation of a recipe its own id",
                                 "defined")
        if kept:
            self.at("/operations", _span(kept[0].key_span, kept[0].name.span))
        return [self.operation(f"/operations/{i}", f) for i, f in enumerate(kept)]

    def operation(self, ptr: str, block: Field) -> dict[str, Any]:
        assert block.name is not None
        self.at(ptr, _span(block.key_span, block.name.span))
        self.at(f"{ptr}/id", block.name.span)
        op: dict[str, Any] = {"id": block.name.value}
        fields = {f.key: f for f in self.unique(block.body, "operation field")}
        if "doc" in fields:
            op["doc"] = self.value(f"{ptr}/doc", fields["doc"].args[0], _plain)
        if "type" in fields:
            op["type"] = self.value(f"{ptr}/type", fields["type"].args[0], _plain)
        if "inputs" in fields:
            f = fields["inputs"]
            self.at(f"{ptr}/inputs", f.span)
            self.at(f"{ptr}/outputs", f.span)
            op["inputs"] = self.names(f"{ptr}/inputs", f.items, sort=True)
            op["outputs"] = self.names(f"{ptr}/outputs", f.args, sort=False)
        op["after"] = []
        if "after" in fields:
            self.at(f"{ptr}/after", fields["after"].span)
            op["after"] = self.names(f"{ptr}/after", fields["after"].items, sort=True)
        if "team" in fields:
            f = fields["team"]
            lo, hi = f.args
            self.at(f"{ptr}/arity", f.span)
            self.at(f"{ptr}/arity/0", lo.span)
            self.at(f"{ptr}/arity/1", (hi or lo).span)
            op["arity"] = [_int(lo), _int(hi or lo)]
        op["roles"] = self.roles(ptr, fields.get("roles"))
        op["resources"] = []
        if "uses" in fields:
            self.at(f"{ptr}/resources", fields["uses"].span)
            op["resources"] = self.names(f"{ptr}/resources", fields["uses"].items, sort=True)
        if "duration" in fields:
            op["duration"] = self.value(f"{ptr}/duration", fields["duration"].args[0], _int)
        op["weight"] = self.value(f"{ptr}/weight", fields["weight"].args[0], _float) if "weight" in fields else 1.0
        return op

    def roles(self, ptr: str, field: Field | None) -> list[dict[str, Any]]:
        if field is None:
            return []
        self.at(f"{ptr}/roles", field.span)
        out: list[dict[str, Any]] = []
        first: dict[str, Any] = {}
        for role in field.items:
            name = role.name.value
            if name in first:
                prev = first[name]
                self.error("AG343", f"duplicate role `{name}` in one operation", role.name.span,
                           hint="role names of an operation must differ",
                           notes=(f"first listed at {prev[0]}:{prev[1]}",))
                continue
            first[name] = role.name.span
            rp = f"{ptr}/roles/{len(out)}"
            self.at(rp, role.span)
            self.at(f"{rp}/name", role.name.span)
            entry: dict[str, Any] = {"name": name}
            if role.binds is not None:
                self.at(f"{rp}/binds", role.binds.span)
                entry["binds"] = role.binds.value
            out.append(entry)
        return out

    def xor_groups(self, fields: list[Field]) -> list[dict[str, Any]]:
        kept = self.unique_named(fields, "AG325", "XOR group", "declare each XOR group once", "declared")
        if kept:
            self.at("/xor", kept[0].span)
        out = []
        for i, f in enumerate(kept):
            ptr = f"/xor/{i}"
            self.at(ptr, f.span)
            self.at(f"{ptr}/id", f.name.span)
            self.at(f"{ptr}/alternatives", f.span)
            out.append({"id": f.name.value, "alternatives": self.names(f"{ptr}/alternatives", f.items, sort=True)})
        return out

    # -- profile (PR-*) ----------------------------------------------------
    def profile(self, ir: dict[str, Any], body: list[Field]) -> None:
        fields = {f.key: f for f in body}
        if "doc" in fields:
            ir["doc"] = self.value("/doc", fields["doc"].args[0], _plain)
        settings = self.settings("", [f for f in body if f.key not in ("doc", "variant")])
        for key, default in PROFILE_DEFAULTS.items():
            if key in settings and key == "durations":
                ir[key] = {**default, **settings[key]}
            elif key in settings:
                ir[key] = settings[key]
            else:
                ir[key] = copy.deepcopy(default)
        for key, val in settings.items():  # settings the defaults do not know (none in v1)
            ir.setdefault(key, val)
        variants: dict[str, Any] = {}
        first: dict[str, Field] = {}
        for f in [f for f in body if f.key == "variant"]:
            name = f.name.value
            if name in first:
                self.error("AG206", f"duplicate variant `{name}`", f.name.span, hint="declare each variant once",
                           notes=(f"first declared at {first[name].name.span[0]}:{first[name].name.span[1]}",))
                continue
            first[name] = f
            ptr = json_pointer("variants", name)
            self.at(ptr, _span(f.key_span, f.name.span))
            variants[name] = self.settings(ptr, self.unique(f.body, "variant setting"))
        if first:
            self.at("/variants", min(f.span for f in first.values()))
        ir["variants"] = variants

    def settings(self, ptr: str, fields: list[Field]) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for f in fields:
            key = f.key
            p = f"{ptr}/{key}"
            if key == "robot_model":
                out[key] = self.value(p, f.args[0], _plain)
            elif key == "tools":
                self.at(p, f.span)
                out[key] = self.names(p, f.items, sort=False)
            elif key == "durations":
                self.at(p, f.span)
                out[key] = {}
                for sub in self.unique(f.body, "duration"):
                    out[key][sub.key] = self.value(f"{p}/{sub.key}", sub.args[0], _int)
            elif key in ("motion_planning", "trajectory_conflicts"):
                out[key] = self.value(p, f.args[0], _plain)
            else:  # numeric geometry/timing constants
                out[key] = self.value(p, f.args[0], _float)
        return out

    # -- scenario (SC-*) ---------------------------------------------------
    def scenario(self, ir: dict[str, Any], body: list[Field]) -> None:
        f = {fld.key: fld for fld in body}
        if "doc" in f:
            ir["doc"] = self.value("/doc", f["doc"].args[0], _plain)
        for key in ("family", "level"):
            if key in f:
                ir[key] = self.value(f"/{key}", f[key].args[0], _plain)
        ir["grid"] = copy.deepcopy(SCENARIO_DEFAULTS["grid"])
        if "grid" in f:
            rows, cols, topo, radius = f["grid"].args
            self.at("/grid", f["grid"].span)
            ir["grid"]["rows"] = self.value("/grid/rows", rows, _int)
            ir["grid"]["cols"] = self.value("/grid/cols", cols, _int)
            if topo is not None:
                ir["grid"]["topology"] = self.value("/grid/topology", topo, _plain)
            if radius is not None:
                ir["grid"]["radius"] = self.value("/grid/radius", radius, _int)
        if "recipes" in f:
            self.at("/recipes", f["recipes"].span)
            ir["recipes"] = self.names("/recipes", f["recipes"].items, sort=False)
        ir["profile"] = copy.deepcopy(SCENARIO_DEFAULTS["profile"])
        if "profile" in f:
            pid, variant = f["profile"].args
            self.at("/profile", f["profile"].span)
            ir["profile"] = {"id": self.value("/profile/id", pid, _plain),
                             "variant": self.value("/profile/variant", variant, _plain) if variant else None}
        if "release" in f or "wip" in f:
            release: dict[str, Any] = {}
            self.at("/release", (f.get("release") or f["wip"]).span)
            if "release" in f:
                release["interval"] = self.value("/release/interval", f["release"].args[0], _int)
            if "wip" in f:
                release["wip_cap"] = self.value("/release/wip_cap", f["wip"].args[0], _int)
                self.at("/release/wip_cap", f["wip"].span)
            ir["release"] = release
        ir["evaluation"] = copy.deepcopy(SCENARIO_DEFAULTS["evaluation"])
        if "evaluation" in f:
            mode, size, timeout = f["evaluation"].args
            self.at("/evaluation", f["evaluation"].span)
            self.at("/evaluation/mode", mode.span)
            if mode.value == "continuing":
                ir["evaluation"] = {"mode": "continuing", "horizon": self.value("/evaluation/horizon", size, _int)}
            else:
                ir["evaluation"] = {
                    "mode": "batch",
                    "batch_size": self.value("/evaluation/batch_size", size, _int),
                    "timeout": self.value("/evaluation/timeout", timeout, _int) if timeout else BATCH_TIMEOUT_DEFAULT,
                }
        ir["shelves"] = self.group(f.get("shelves"), "/shelves", {
            "capacity": ("capacity", _int), "replenish": ("replenish_interval", _int),
            "extra_access": ("extra_access_probability", _float)})
        ir["coordination"] = self.group(f.get("coordination"), "/coordination", {
            "support_timeout": ("support_timeout", _int), "switch_lock": ("switch_lock", _int),
            "support_visible": ("support_visible", _plain), "bilateral_handoff": ("bilateral_handoff", _plain)})
        ir["products"] = self.group(f.get("products"), "/products", {
            "mass": ("mass", _float), "due_slack": ("due_slack", _float), "jitter": ("due_slack_jitter", _float)})
        ir["resources"] = self.resources("/resources", [fld for fld in body if fld.key == "resource"])
        if "suite" in f:
            official, prefix, gen, exe = f["suite"].args
            self.at("/suite", f["suite"].span)
            suite: dict[str, Any] = {"official": self.value("/suite/official", official, _plain)}
            if prefix is not None:
                suite["prefix"] = self.value("/suite/prefix", prefix, _plain)
            if gen is not None:
                suite["generation_seed_base"] = self.value("/suite/generation_seed_base", gen, _int)
                suite["execution_seed_base"] = self.value("/suite/execution_seed_base", exe, _int)
            ir["suite"] = suite

    def group(self, field: Field | None, ptr: str, table: dict[str, tuple[str, Conv]]) -> dict[str, Any]:
        """An inline settings group (shelves, coordination, products) over its defaults."""
        out = copy.deepcopy(SCENARIO_DEFAULTS[ptr.strip("/")])
        if field is None:
            return out
        self.at(ptr, field.span)
        for sub in self.unique(field.body, "setting"):
            key, conv = table[sub.key]
            p = f"{ptr}/{key}"
            if sub.key == "mass":
                lo, hi = sub.args
                self.at(p, sub.span)
                out[key] = [self.value(f"{p}/0", lo, conv), self.value(f"{p}/1", hi, conv)]
            else:
                out[key] = self.value(p, sub.args[0], conv)
        return out


def build(source: SourceFile) -> Built:
    """AST -> IR in canonical order, with defaults and a source map (F-DSL, F-IR)."""
    if source.document is None:
        return Built(ir=None, srcmap={}, diagnostics=tuple(source.diagnostics))
    builder = _Builder(source.file)
    ir = builder.document(source.document)
    return Built(ir=ir, srcmap=builder.srcmap, diagnostics=tuple(source.diagnostics) + tuple(builder.diags))


def compile_text(text: str, file: str | None = None) -> tuple[SourceFile, Built]:
    """Parse and build in one step; diagnostics of both stages are in the Built result."""
    source = parse(text, file)
    return source, build(source)
