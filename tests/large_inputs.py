"""Large and dense inputs for every command that reads files (F-LIMITS: bounded time, not only memory).

Shared by ``tests/test_large_inputs.py`` (small sizes, with the limits lowered through their
environment variables) and ``benchmarks/fuzz_limits.py`` (the sizes of a real attack, e.g. a
48 MB document holding 12 million numbers, with the default limits).

A *shape* makes one family's valid seed text large in one direction:

* ``wide-array`` — an array of ``n`` numbers, as an extra field (the document is then invalid, so
  the diagnostics path runs) and in place of the seed's longest array (shaped like a real field);
* ``many-keys`` — an object of ``n`` keys;
* ``long-strings`` — ``n`` characters spread over strings at the string limit;
* ``many-lines`` — ``n`` records of a JSON Lines file, ``n`` entries of a YAML file, ``n``
  operations of a DSL recipe, or ``n`` blank lines in a JSON document.

Every command must answer within a bound with the documented exit code (0 or 1 for content,
F-EXIT-CODES) and a located message when it refuses.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Callable

from hostile_inputs import COMMANDS as HOSTILE_COMMANDS
from hostile_inputs import FAMILIES as HOSTILE_FAMILIES
from hostile_inputs import Family

MAX_CHARS = 300 * 10**6  # a little over F-LIMITS max_bytes (256 MiB)
SHAPES = ("wide-array", "wide-array-inside", "many-keys", "long-strings", "many-lines")

BUNDLE = Path(__file__).resolve().parent / "fixtures" / "results-small.json"  # a valid results bundle


def _bundle_text() -> str:
    return BUNDLE.read_text(encoding="utf-8")


FAMILIES: dict[str, Family] = {**HOSTILE_FAMILIES, "bundle": Family("bundle", ".json", _bundle_text)}

COMMANDS: dict[str, tuple[str, tuple[str, ...]]] = {
    **{name: spec for name, spec in HOSTILE_COMMANDS.items() if name not in ("diff", "render-record", "run", "export",
                                                                             "instance", "evaluate")},
    "evaluate-from": ("bundle", ("evaluate", "--from", "{}")),
    "report": ("bundle", ("report", "{}", "--to", "latex", "-o", "{out}/table.tex")),
}


def _longest_array_path(value, prefix=()):
    """The path of the longest array in ``value`` (None if it has none)."""
    best: tuple[int, tuple] | None = None
    stack = [(value, prefix)]
    while stack:
        node, path = stack.pop()
        if isinstance(node, list):
            if best is None or len(node) > best[0]:
                best = (len(node), path)
            stack.extend((v, path + (i,)) for i, v in enumerate(node))
        elif isinstance(node, dict):
            stack.extend((v, path + (k,)) for k, v in node.items())
    return None if best is None else best[1]


def _set(doc, path, new):
    node = doc
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = new


def _numbers(n: int) -> str:
    return "[" + ",".join(["1.5"] * n) + "]"


def _keys(n: int) -> str:
    return "{" + ",".join(f'"k{i}":1' for i in range(n)) + "}"


def _strings(chars: int, each: int) -> str:
    count = max(1, chars // each)
    return "[" + ",".join(['"' + "a" * each + '"'] * count) + "]"


def _with_extra(text: str, extra: str) -> str:
    """A JSON object text with one more field ``"x": extra`` (a non-object seed is wrapped)."""
    text = text.strip()
    if text.startswith("{") and text.endswith("}"):
        return text[:-1] + (', "x": ' if text[1:-1].strip() else '"x": ') + extra + "}"
    return '{"x": ' + extra + "}"


def _json_doc(shape: str, seed: str, n: int, string_limit: int) -> str | None:
    if shape == "wide-array":
        return _with_extra(seed, _numbers(n))
    if shape == "wide-array-inside":
        doc = json.loads(seed)
        path = _longest_array_path(doc)
        if not path:
            return None
        element = doc_at(doc, path)[0] if doc_at(doc, path) else 1
        first = json.dumps(element)
        copies = max(1, n // _values(element))  # about n values in all, whatever the element's size
        marker = "\u2063wide\u2063"
        _set(doc, path, marker)
        return json.dumps(doc).replace(json.dumps(marker), "[" + ",".join([first] * copies) + "]", 1)
    if shape == "many-keys":
        return _with_extra(seed, _keys(n))
    if shape == "long-strings":
        return _with_extra(seed, _strings(n, string_limit))
    if shape == "many-lines":
        return seed.strip() + "\n" * n
    return None


def _values(value) -> int:
    """The number of JSON values in ``value`` (itself included)."""
    if isinstance(value, dict):
        return 1 + sum(_values(v) for v in value.values())
    if isinstance(value, list):
        return 1 + sum(_values(v) for v in value)
    return 1


def doc_at(doc, path):
    for key in path:
        doc = doc[key]
    return doc


def _json_lines(shape: str, seed: str, n: int, string_limit: int) -> str | None:
    first, _, rest = seed.partition("\n")
    if shape == "many-lines":
        lines = [line for line in rest.splitlines() if line.strip()] or [first]
        body = lines[0] + "\n"
        return first + "\n" + body * n + rest
    one = _json_doc(shape, first, n, string_limit)
    return None if one is None else one + "\n" + rest


def _dsl(shape: str, seed: str, n: int, string_limit: int) -> str | None:
    if shape == "many-lines":
        ops = "".join(f"    operation op{i} {{\n        type assemble\n        inputs A, B -> P{i}\n"
                      f"        team 2\n        duration 1\n    }}\n" for i in range(n))
        return "recipe big {\n    value 1.0\n    raw A, B\n" + ops + "}\n"
    if shape == "wide-array":
        return "recipe big {\n    value 1.0\n    raw " + ", ".join(f"R{i}" for i in range(n)) + "\n}\n"
    if shape == "long-strings":
        return seed + "\n" + "#" + "a" * n + "\n"
    return None


def _yaml(shape: str, seed: str, n: int, string_limit: int) -> str | None:
    if shape == "many-lines":
        return "".join(f"c-{i:012x}:\n  outcome: fail\n  reason: r\n" for i in range(n))
    if shape == "wide-array":
        return seed + "x: [" + ", ".join(["1"] * n) + "]\n"
    if shape == "long-strings":
        return seed + "".join(f"y{i}: " + "a" * string_limit + "\n" for i in range(max(1, n // string_limit)))
    return None


def build(family: Family, shape: str, n: int, string_limit: int = 1024 ** 2) -> bytes | None:
    """The seed of ``family`` made large in ``shape`` with size parameter ``n`` (None: not applicable)."""
    seed = family.seed()
    maker: Callable[[str, str, int, int], str | None]
    if family.suffix == ".ag":
        maker = _dsl
    elif family.yaml:
        maker = _yaml
    elif family.json_lines:
        maker = _json_lines
    else:
        maker = _json_doc
    probe = maker(shape, seed, 1000, string_limit)
    if probe is None:
        return None
    # beyond F-LIMITS max_bytes a file is refused by its size alone: no need to build a larger one
    unit = max(1, (len(probe) - len(seed)) // 1000)
    text = maker(shape, seed, min(n, max(1, MAX_CHARS // unit)), string_limit)
    return None if text is None else text.encode()


__all__ = ["SHAPES", "FAMILIES", "COMMANDS", "build"]
