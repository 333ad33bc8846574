"""IR -> canonical DSL text (spec F-DSL).

``format_ir(ir)`` writes one canonical text per IR: DSL -> IR -> DSL -> IR is a fixpoint
(the IR is equal and the text stable).  The canonical layout:

* the file's leading comment block (header) kept verbatim, then ``use`` lines, then the
  document, each separated by one blank line; 4-space indentation; LF line ends;
* every field written explicitly, in a fixed order, except empty lists/maps that default
  to empty (``after``, ``roles``, ``uses``, resources, XOR groups);
* operations in topological order of ``after`` (ties by id), so a recipe reads as a process;
  resources and variants sorted by name;
* floats in the shortest form that reads back to the same value (``0.3``, ``1.0``), never with
  an exponent; names bare when they are identifiers and not keywords, else quoted.

Comments other than the header are not part of the IR and are dropped by the formatter;
:func:`format_source` counts them so the CLI can warn.  ``fmt --check`` passes iff the
canonical text equals the file text.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from decimal import Decimal
from typing import Any, Iterable, Mapping, Sequence

from agspec.dsl.build import PROFILE_DEFAULTS, build
from agspec.dsl.parse import keywords, parse
from agspec.formats.diagnostics import Diagnostic

INDENT = "    "
_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*(?:[.\-][A-Za-z0-9_]+)*")
_PROFILE_NUMBERS = ("spacing", "reach", "reference_reach", "reference_time", "rho_conf", "clearance",
                    "role_target_offset", "retreat_fraction", "speed", "joint_speed", "payload")
_PROFILE_ORDER = tuple(PROFILE_DEFAULTS)


@dataclass(frozen=True)
class Formatted:
    """Result of :func:`format_source`: canonical text (None on errors), diagnostics, lost comments."""

    text: str | None
    diagnostics: tuple[Diagnostic, ...]
    dropped_comments: int = 0


# --------------------------------------------------------------------------- atoms


def name(value: Any) -> str:
    """A name, bare if it is an identifier that is not a keyword, else a JSON string."""
    text = str(value)
    if _NAME.fullmatch(text) and text not in set(keywords().values()):
        return text
    return json.dumps(text, ensure_ascii=False)


def number(value: Any) -> str:
    """An int as is; a float in its shortest round-trip form without exponent (0.3, 1.0)."""
    if isinstance(value, bool):
        return "1" if value else "0"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        text = repr(value)
        if "e" in text or "E" in text:
            text = format(Decimal(text), "f")
        if "." not in text and text.lstrip("-").isdigit():
            text += ".0"
        return text
    return str(value)


def boolean(value: Any) -> str:
    return "on" if value else "off"


def string(value: Any) -> str:
    return json.dumps(str(value), ensure_ascii=False)


def names(values: Iterable[Any]) -> str:
    return ", ".join(name(v) for v in values)


# --------------------------------------------------------------------------- recipe


def _op_order(ops: Sequence[Mapping[str, Any]], xor: Sequence[Mapping[str, Any]]) -> list[Mapping[str, Any]]:
    """Topological order of operations by ``after`` (an XOR group stands for its alternatives)."""
    groups = {g.get("id"): list(g.get("alternatives", [])) for g in xor}
    by_id = {}
    for op in ops:
        by_id.setdefault(op.get("id"), op)
    deps = {}
    for oid, op in by_id.items():
        pre = set()
        for p in op.get("after", []) or []:
            pre.update(groups.get(p, [p]))
        deps[oid] = {p for p in pre if p in by_id and p != oid}
    done: list[Any] = []
    remaining = sorted(by_id, key=str)
    while remaining:
        ready = [o for o in remaining if deps[o] <= set(done)]
        pick = ready[0] if ready else remaining[0]  # a cycle: fall back to id order
        done.append(pick)
        remaining.remove(pick)
    ordered = [by_id[o] for o in done]
    # duplicate ids (invalid IR) keep their place after the first
    extra = [op for op in ops if not any(op is o for o in ordered)]
    return ordered + extra


def _operation(op: Mapping[str, Any]) -> list[str]:
    lines = [f"operation {name(op.get('id'))} {{"]
    body = []
    if "doc" in op:
        body.append(f"doc {string(op['doc'])}")
    if "type" in op:
        body.append(f"type {name(op['type'])}")
    if op.get("after"):
        body.append(f"after {names(op['after'])}")
    if "inputs" in op or "outputs" in op:
        ins = names(op.get("inputs", []))
        outs = names(op.get("outputs", []))
        body.append(" ".join(p for p in ("inputs", ins, "->", outs) if p))
    arity = op.get("arity")
    if isinstance(arity, Sequence) and len(arity) == 2:
        lo, hi = arity
        body.append(f"team {number(lo)}" if lo == hi and type(lo) is type(hi) else f"team {number(lo)}..{number(hi)}")
    if op.get("roles"):
        roles = []
        for role in op["roles"]:
            binds = role.get("binds")
            roles.append(name(role.get("name")) + (f"({name(binds)})" if binds is not None else ""))
        body.append("roles " + ", ".join(roles))
    if op.get("resources"):
        body.append(f"uses {names(op['resources'])}")
    if "duration" in op:
        body.append(f"duration {number(op['duration'])}")
    if "weight" in op:
        body.append(f"weight {number(op['weight'])}")
    lines += [INDENT + b for b in body]
    lines.append("}")
    return lines


def _resources(resources: Mapping[str, Any]) -> list[str]:
    return [f"resource {name(k)} capacity {number(resources[k])}" for k in sorted(resources)]


def _recipe(ir: Mapping[str, Any]) -> list[list[str]]:
    head = []
    if "doc" in ir:
        head.append(f"doc {string(ir['doc'])}")
    if "value" in ir:
        head.append(f"value {number(ir['value'])}")
    if "raw" in ir:
        head.append(f"raw {names(ir['raw'])}")
    head += _resources(ir.get("resources") or {})
    sections = [head]
    # F-DSL-FMT: an XOR group is written just before the first of its alternatives, so that it stays
    # with the operations it groups and before any operation that runs `after` it
    groups = sorted(ir.get("xor", []) or [], key=lambda g: str(g.get("id")))
    placed: set[int] = set()
    for op in _op_order(ir.get("operations", []) or [], ir.get("xor", []) or []):
        here = [i for i, g in enumerate(groups) if i not in placed and op.get("id") in (g.get("alternatives") or [])]
        if here:
            sections.append([_xor(groups[i]) for i in here])
            placed.update(here)
        sections.append(_operation(op))
    sections.append([_xor(g) for i, g in enumerate(groups) if i not in placed])  # alternatives that are no operation
    return sections


def _xor(group: Mapping[str, Any]) -> str:
    return f"xor {name(group.get('id'))} = " + " | ".join(name(a) for a in group.get("alternatives", []))


# --------------------------------------------------------------------------- profile


def _settings(values: Mapping[str, Any]) -> list[str]:
    out = []
    order = [k for k in _PROFILE_ORDER if k in values] + sorted(k for k in values if k not in _PROFILE_ORDER)
    for key in order:
        val = values[key]
        if key in ("variants", "variant"):
            continue
        if key == "robot_model":
            out.append(f"robot_model {name(val)}")
        elif key == "tools":
            out.append(f"tools {names(val)}".rstrip())
        elif key == "durations":
            subs = [f"{k} {number(val[k])}" for k in ("pick", "handoff", "deliver") if k in val]
            out.append("durations " + " ".join(subs))
        elif key in ("motion_planning", "trajectory_conflicts"):
            out.append(f"{key} {boolean(val)}")
        elif key in _PROFILE_NUMBERS:
            out.append(f"{key} {number(val)}")
    return out


def _profile(ir: Mapping[str, Any]) -> list[list[str]]:
    head = [f"doc {string(ir['doc'])}"] if "doc" in ir else []
    head += _settings({k: v for k, v in ir.items() if k not in ("ir_version", "kind", "id", "doc")})
    variants = []
    for vname in sorted(ir.get("variants") or {}):
        settings = _settings(ir["variants"][vname])
        if len(settings) <= 1:
            variants.append(f"variant {name(vname)} {{ {' '.join(settings)} }}".replace("{  }", "{ }"))
        else:
            variants += [f"variant {name(vname)} {{"] + [INDENT + s for s in settings] + ["}"]
    return [head, variants]


# --------------------------------------------------------------------------- scenario


def _scenario(ir: Mapping[str, Any]) -> list[list[str]]:
    lines = []
    if "doc" in ir:
        lines.append(f"doc {string(ir['doc'])}")
    for key in ("family", "level"):
        if key in ir:
            lines.append(f"{key} {name(ir[key])}")
    grid = ir.get("grid")
    if isinstance(grid, Mapping):
        text = f"grid {number(grid.get('rows'))} x {number(grid.get('cols'))}"
        if "topology" in grid:
            text += f" {grid['topology']}"
        if "radius" in grid:
            text += f" radius {number(grid['radius'])}"
        lines.append(text)
    if "recipes" in ir:
        lines.append(f"recipes {names(ir['recipes'])}")
    profile = ir.get("profile")
    if isinstance(profile, Mapping) and "id" in profile:
        text = f"profile {name(profile['id'])}"
        if profile.get("variant") is not None:
            text += f" variant {name(profile['variant'])}"
        lines.append(text)
    release = ir.get("release")
    if isinstance(release, Mapping):
        if "interval" in release:
            lines.append(f"release every {number(release['interval'])}")
        if "wip_cap" in release:
            lines.append(f"wip {number(release['wip_cap'])}")
    evaluation = ir.get("evaluation")
    if isinstance(evaluation, Mapping):
        if evaluation.get("mode") == "batch":
            text = f"evaluation batch {number(evaluation.get('batch_size'))}"
            if "timeout" in evaluation:
                text += f" timeout {number(evaluation['timeout'])}"
            lines.append(text)
        elif "horizon" in evaluation:
            lines.append(f"evaluation continuing horizon {number(evaluation['horizon'])}")
    lines += _group(ir.get("shelves"), "shelves", [
        ("capacity", "capacity", number), ("replenish_interval", "replenish", number),
        ("extra_access_probability", "extra_access", number)])
    lines += _group(ir.get("coordination"), "coordination", [
        ("support_timeout", "support_timeout", number), ("switch_lock", "switch_lock", number),
        ("support_visible", "support_visible", boolean), ("bilateral_handoff", "bilateral_handoff", boolean)])
    products = ir.get("products")
    if isinstance(products, Mapping) and products:
        parts = []
        mass = products.get("mass")
        if isinstance(mass, Sequence) and len(mass) == 2:
            parts.append(f"mass {number(mass[0])}..{number(mass[1])}")
        if "due_slack" in products:
            parts.append(f"due_slack {number(products['due_slack'])}")
        if "due_slack_jitter" in products:
            parts.append(f"jitter {number(products['due_slack_jitter'])}")
        if parts:
            lines.append("products " + " ".join(parts))
    lines += _resources(ir.get("resources") or {})
    suite = ir.get("suite")
    if isinstance(suite, Mapping):
        text = "suite " + ("official" if suite.get("official") else "unofficial")
        if "prefix" in suite:
            text += f" prefix {name(suite['prefix'])}"
        if "generation_seed_base" in suite and "execution_seed_base" in suite:
            text += (f" seeds generation {number(suite['generation_seed_base'])}"
                     f" execution {number(suite['execution_seed_base'])}")
        lines.append(text)
    return [lines]


def _group(values: Any, keyword: str, table: list[tuple[str, str, Any]]) -> list[str]:
    if not isinstance(values, Mapping):
        return []
    parts = [f"{word} {conv(values[key])}" for key, word, conv in table if key in values]
    return [f"{keyword} " + " ".join(parts)] if parts else []


# --------------------------------------------------------------------------- entry points


def format_ir(ir: Mapping[str, Any], *, uses: Sequence[str] = (), header: str = "") -> str:
    """Canonical DSL text of a recipe, profile or scenario IR (expects schema-valid IR)."""
    kind = ir.get("kind")
    render = {"recipe": _recipe, "profile": _profile, "scenario": _scenario}.get(str(kind))
    if render is None:
        raise ValueError(f"cannot format IR of kind {kind!r} as DSL (recipe, profile or scenario only)")
    sections = [s for s in render(ir) if s]
    body: list[str] = []
    for i, section in enumerate(sections):
        if i:
            body.append("")
        body += section
    doc = [f"{kind} {name(ir.get('id'))} {{"] + [INDENT + line if line else "" for line in body] + ["}"]
    blocks = []
    if header.strip():
        blocks.append(header.strip("\n"))
    if uses:
        blocks.append("\n".join(f"use {string(u)}" for u in uses))
    blocks.append("\n".join(doc))
    return "\n\n".join(blocks) + "\n"


def header_of(text: str) -> str:
    """The leading comment block of a file (comment and blank lines before anything else)."""
    lines = []
    for line in text.splitlines():
        stripped = line.strip()
        if stripped and not stripped.startswith("#"):
            break
        lines.append(line.rstrip())
    while lines and not lines[-1]:
        lines.pop()
    while lines and not lines[0]:
        lines.pop(0)
    return "\n".join(lines)


def format_source(text: str, file: str | None = None) -> Formatted:
    """Parse, build and re-emit ``text`` canonically, keeping its header and ``use`` lines."""
    source = parse(text, file)
    built = build(source)
    errors = tuple(d for d in built.diagnostics if d.severity == "error")
    if built.ir is None or errors:
        return Formatted(text=None, diagnostics=built.diagnostics)
    header = header_of(text)
    header_lines = header.count("\n") + 1 if header else 0
    first_line = next((i for i, ln in enumerate(text.splitlines(), 1) if ln.strip()), 1)
    header_end = first_line + header_lines - 1 if header else 0
    dropped = sum(1 for c in source.comments if c.span[0] > header_end)
    out = format_ir(built.ir, uses=[u.path.value for u in source.uses], header=header)
    return Formatted(text=out, diagnostics=built.diagnostics, dropped_comments=dropped)
