"""Hostile and careless inputs for every command that reads files (F-LIMITS, F-EXIT-CODES).

Shared by the table-driven exit-code test, the hypothesis fuzz test and ``benchmarks/fuzz_cli.py``:

* ``FAMILIES``: the kinds of file agspec reads (DSL, IR JSON, instance JSON, trace, report,
  expectations, reproducer), each with a small valid seed text;
* ``BAD``: one hostile input per fault class and family, with the exit code F-EXIT-CODES gives it;
* ``COMMANDS``: every command that reads a file of a family, as an argv template;
* ``invoke``: run a command in-process through click's CliRunner and classify the result;
* ``mutations``: hypothesis strategies that damage a seed text.
"""

from __future__ import annotations

import json
import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from click.testing import CliRunner
from hypothesis import strategies as st

from agspec.cli.main import cli

ROOT = Path(__file__).resolve().parent.parent
DEEP = 100_000  # nesting far beyond F-LIMITS max_depth and Python's recursion limit
HUGE_DIGITS = 5_000  # beyond Python's int-string limit (4,300) and F-LIMITS max_number_chars


def _instance_text() -> str:
    return (ROOT / "conformance" / "instances" / "pair-1x2-official.json").read_text(encoding="utf-8")


def _trace_text() -> str:
    inst = json.loads(_instance_text())
    from agspec.ir.fingerprint import fingerprint

    header = {"type": "header", "format": "agspec-trace/1", "instance": inst, "fingerprint": fingerprint(inst)}
    return json.dumps(header) + "\n" + json.dumps({"type": "footer", "ticks": 0, "complete": True}) + "\n"


REPORT_SEED = json.dumps({"type": "header", "format": "agspec-conform-report/1", "impl": "reference"}) + "\n"
EXPECT_SEED = "c-0123456789ab:\n  outcome: fail\n  reason: known gap\n"


@dataclass(frozen=True)
class Family:
    name: str
    suffix: str
    seed: Callable[[], str]
    json_lines: bool = False
    yaml: bool = False


FAMILIES = {
    "dsl": Family("dsl", ".ag", lambda: (ROOT / "catalogue" / "recipes" / "pair_assembly.ag").read_text("utf-8")),
    "ir": Family("ir", ".json", lambda: json.dumps(next(iter(json.loads(_instance_text())["recipes"].values())))),
    "instance": Family("instance", ".json", _instance_text),
    "trace": Family("trace", ".jsonl", _trace_text, json_lines=True),
    "report": Family("report", ".jsonl", lambda: REPORT_SEED, json_lines=True),
    "expect": Family("expect", ".yaml", lambda: EXPECT_SEED, yaml=True),
    "reproducer": Family("reproducer", ".json", lambda: json.dumps({"format": "agspec-repro/1"})),
}

# fault class -> (content for JSON families, for JSON Lines, for DSL, for YAML; None: not applicable)
_DEEP_JSON = "[" * DEEP + "]" * DEEP
_BOMB = "a: &a [x, x, x, x, x, x, x, x, x]\n" + "".join(
    f"{c}: &{c} [{', '.join([f'*{p}'] * 9)}]\n" for p, c in zip("abcdefgh", "bcdefghi"))
CONTENT: dict[str, tuple[bytes | None, bytes | None, bytes | None, bytes | None]] = {
    "not-utf8": (b'{"kind": "\xff"}', b'{"type": "\xff"}\n', b"recipe r { value \xff }", b"a: \xff\n"),
    "truncated": (b'{"kind": "instance", "id": "x', b'{"type": "header"', b"recipe r {\n  raw A\n", b"a: [1, 2\n"),
    "deep": (_DEEP_JSON.encode(), _DEEP_JSON.encode() + b"\n", None, ("[" * DEEP).encode()),
    "huge-number": (b'{"kind": "instance", "n": ' + b"9" * HUGE_DIGITS + b"}",
                    b'{"type": "header", "t": ' + b"9" * HUGE_DIGITS + b"}\n",
                    b"recipe r { value " + b"9" * HUGE_DIGITS + b" }", b"a: " + b"9" * HUGE_DIGITS + b"\n"),
    "huge-name": (None, None, b"recipe " + b"a" * 100_000 + b" { raw A }", None),
    "duplicate-key": (b'{"kind": "recipe", "kind": "recipe"}', b'{"type": "header", "type": "tick"}\n', None,
                      b"a: 1\na: 2\n"),
    "nan": (b'{"kind": "instance", "x": NaN}', b'{"type": "header", "t": NaN}\n', None, b"a: .nan\n"),
    "type-confusion": (b"[1, 2, 3]", b'[1]\n"x"\n', b'recipe r { value "one" }', b"- 1\n- 2\n"),
    "empty": (b"", b"", b"", None),
    "alias-bomb": (None, None, None, _BOMB.encode()),
}
# special paths: exit 2 (RES-EXIT-CONTENT), whatever the family
SPECIAL = ("missing", "directory", "fifo", "dev-zero")


def expected_exit(kind: str) -> int:
    return 2 if kind in SPECIAL else 1


def content(kind: str, family: Family) -> bytes | None:
    json_c, lines_c, dsl_c, yaml_c = CONTENT[kind]
    if family.suffix == ".ag":
        return dsl_c
    if family.json_lines:
        return lines_c
    if family.yaml:
        return yaml_c
    return json_c


def materialize(kind: str, family: Family, where: Path) -> Path | None:
    """A path holding the hostile input ``kind`` for ``family`` (None: the class does not apply)."""
    path = where / f"{kind}-{family.name}{family.suffix}"
    if kind == "missing":
        return path
    if kind == "directory":
        path.mkdir(exist_ok=True)
        return path
    if kind == "fifo":
        if not path.exists():
            os.mkfifo(path)
        return path
    if kind == "dev-zero":
        return Path("/dev/zero")
    data = content(kind, family)
    if data is None:
        return None
    path.write_bytes(data)
    return path


# command -> (family, argv template; {} is the file)
COMMANDS: dict[str, tuple[str, tuple[str, ...]]] = {
    "validate": ("dsl", ("validate", "{}")),
    "validate-json": ("ir", ("validate", "{}")),
    "compile": ("dsl", ("compile", "{}")),
    "fmt": ("dsl", ("fmt", "{}")),
    "fingerprint": ("ir", ("fingerprint", "{}")),
    "fingerprint-dsl": ("dsl", ("fingerprint", "{}")),
    "instance": ("instance", ("instance", "{}")),
    "export": ("instance", ("export", "{}")),
    "run": ("instance", ("run", "{}", "--horizon", "2", "--format", "json")),
    "evaluate": ("dsl", ("evaluate", "--scenario", "{}", "--indices", "0", "--controller", "greedy")),
    "diff": ("instance", ("diff", "--impl", "reference", "--impl", "reference", "--scenario", "{}", "--horizon", "2",
                         "-o", "{out}/agspec-diff")),
    "check": ("trace", ("check", "{}")),
    "trace-validate": ("trace", ("trace", "validate", "{}")),
    "render": ("trace", ("render", "{}", "-o", "{out}/replay.html")),
    "render-record": ("instance", ("render", "--impl", "reference", "--scenario", "{}", "--horizon", "2",
                                   "-o", "{out}/rec.html")),
    "render-diff": ("report", ("render", "--diff", "{}", "-o", "{out}/diff.html")),
    "conform-expect": ("expect", ("conform", "--impl", "reference", "--no-suite", "--episodes", "1", "--horizon", "1",
                                  "--expect", "{}")),
    "conform-replay": ("reproducer", ("conform", "--impl", "reference", "--replay", "{}")),
    "train": ("dsl", ("train", "--algorithm", "ippo", "--scenario", "{}", "--seed", "0", "-o", "{out}/run",
                      "--print-config")),
    "train-settings": ("expect", ("train", "--algorithm", "ippo", "--scenario", "flow-easy", "--seed", "0",
                                  "-o", "{out}/run", "--config", "{}", "--print-config")),
}


def argv(command: str, path: Path, out: Path) -> list[str]:
    return [a.replace("{out}", str(out)).replace("{}", str(path)) for a in COMMANDS[command][1]]


@dataclass(frozen=True)
class Outcome:
    exit_code: int
    output: str
    crashed: bool  # an exception escaped the command: the real entry point would print a traceback (exit 4)


def invoke(args: list[str]) -> Outcome:
    """Run ``agspec ARGS`` in-process; stdout and stderr together."""
    res = CliRunner().invoke(cli, args, catch_exceptions=True)
    crashed = res.exception is not None and not isinstance(res.exception, SystemExit)
    output = res.output + (res.stderr if res.stderr_bytes is not None else "")
    return Outcome(res.exit_code, output, crashed)


# --------------------------------------------------------------------------- mutations (hypothesis)

_PLACEHOLDER = "\u2063hostile\u2063"
RAW_TOKENS = ("NaN", "Infinity", "-Infinity", "1e999", "9" * HUGE_DIGITS, "[" * 5000, '"' + "x" * 2_000_000 + '"')


def _paths(value, prefix=()):
    yield prefix
    if isinstance(value, dict):
        for k, v in value.items():
            yield from _paths(v, prefix + (k,))
    elif isinstance(value, list):
        for i, v in enumerate(value[:8]):
            yield from _paths(v, prefix + (i,))


def _replace(value, path, new):
    if not path:
        return new
    head, rest = path[0], path[1:]
    if isinstance(value, dict):
        return {**value, head: _replace(value[head], rest, new)}
    out = list(value)
    out[head] = _replace(out[head], rest, new)
    return out


@st.composite
def json_value_swaps(draw, text: str) -> bytes:
    """A JSON document with one value replaced: type confusion, a raw hostile token, deep nesting."""
    doc = json.loads(text)
    paths = list(_paths(doc))
    path = draw(st.sampled_from(paths))
    new = draw(st.one_of(
        st.sampled_from([None, True, 0, -1, 2**63, 1.5, "", "x" * 300, [], {}, [[[]]], {"kind": "scenario"}]),
        st.just(_PLACEHOLDER),
    ))
    out = json.dumps(_replace(doc, path, new))
    if new == _PLACEHOLDER:
        out = out.replace(json.dumps(_PLACEHOLDER), draw(st.sampled_from(RAW_TOKENS)), 1)
    return out.encode()


@st.composite
def byte_damage(draw, text: str) -> bytes:
    """Truncation, a bad UTF-8 byte, a duplicated span, or inserted punctuation."""
    data = text.encode()
    n = len(data)
    at = draw(st.integers(0, n))
    how = draw(st.sampled_from(["truncate", "bad-byte", "duplicate", "insert"]))
    if how == "truncate":
        return data[:at]
    if how == "bad-byte":
        return data[:at] + draw(st.sampled_from([b"\xff", b"\xc3", b"\xed\xa0\x80", b"\x00"])) + data[at:]
    if how == "duplicate":
        end = draw(st.integers(at, min(n, at + 200)))
        return data[:end] + data[at:end] + data[end:]
    return data[:at] + draw(st.sampled_from([b"{", b"}", b"[", b"]", b",", b":", b'"', b"\n", b"#", b"&a *a"])) + data[at:]


def mutations(family: Family) -> st.SearchStrategy[bytes]:
    text = family.seed()
    strategies = [byte_damage(text)]
    if family.suffix == ".json":
        strategies.append(json_value_swaps(text))
    if family.json_lines:
        first, _, rest = text.partition("\n")
        strategies.append(json_value_swaps(first).map(lambda b: b + b"\n" + rest.encode()))
    return st.one_of(*strategies)


TRACEBACK = re.compile(r"Traceback \(most recent call last\)")
