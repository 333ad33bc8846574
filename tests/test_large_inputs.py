"""Large and dense inputs get an early, located refusal from every command (F-LIMITS: bounded time).

The generator (tests/large_inputs.py) makes each family's seed large in each shape — a wide array,
many keys, long strings, many lines — and every command that reads the family runs on it.  Here the
limits are lowered through their variables so that the documents stay small; the real sizes (a
48 MB document holding 12 million numbers) run in benchmarks/fuzz_limits.py.  The property: past a
limit, the answer is the limit's diagnostic (AG006, naming the limit), located, with the documented
exit code, never a traceback; within the limits, the command answers normally.
"""

from __future__ import annotations

import pytest

from agspec.formats import limits
from hostile_inputs import TRACEBACK, invoke
from large_inputs import COMMANDS, FAMILIES, SHAPES, build

# lowered limits, still above every seed document (the bundle seed holds 773 values, the DSL seed 18 lines)
LOW = {"AGSPEC_MAX_NODES": "2000", "AGSPEC_MAX_RECORDS": "300", "AGSPEC_MAX_DSL_TOKENS": "2000",
       "AGSPEC_MAX_YAML_NODES": "1000", "AGSPEC_MAX_STRING_CHARS": "20000", "AGSPEC_MAX_BYTES": "8M"}
OVER = 20_000  # past every lowered limit
BUNDLE_EXIT = 2  # results bundles: BundleError is a usage error (spec/13 F-POLICY-BUNDLE)


def _argv(command, path, out):
    return [a.replace("{out}", str(out)).replace("{}", str(path)) for a in COMMANDS[command][1]]


def _past_a_limit(family, shape: str) -> bool:
    """Whether the shape at size OVER is past a limit: blank lines in one JSON document are not."""
    plain_json = family.suffix == ".json"
    return build(family, shape, 10) is not None and not (plain_json and shape == "many-lines")


CASES = [(c, s) for c in COMMANDS for s in SHAPES if _past_a_limit(FAMILIES[COMMANDS[c][0]], s)]


@pytest.mark.parametrize("command, shape", CASES)
def test_past_a_limit_every_command_refuses_early_and_says_where(command, shape, tmp_path, monkeypatch):
    for var, value in LOW.items():
        monkeypatch.setenv(var, value)
    family = FAMILIES[COMMANDS[command][0]]
    data = build(family, shape, OVER, string_limit=int(LOW["AGSPEC_MAX_STRING_CHARS"]) + 1)
    path = tmp_path / f"big{family.suffix}"
    path.write_bytes(data)
    out = invoke(_argv(command, path, tmp_path))
    assert not out.crashed and not TRACEBACK.search(out.output), out.output[-2000:]
    assert out.exit_code == (BUNDLE_EXIT if family.name == "bundle" else 1), out.output[-2000:]
    assert str(path) in out.output
    # the refusal is a limit's (AG006) — or, for a shape whose extra field the schema rejects before
    # any limit is reached, the schema's located diagnostic
    assert "AG006" in out.output, out.output[-2000:]
    assert "AG006" in out.output or "limit" in out.output or "unknown field" in out.output \
        or f"{path}:" in out.output, out.output[-2000:]


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_within_the_limits_the_large_shapes_are_read(command, tmp_path, monkeypatch):
    for var in LOW:  # the default limits: never refuse a document of a realistic size
        monkeypatch.delenv(var, raising=False)
    family = FAMILIES[COMMANDS[command][0]]
    for shape in SHAPES:
        data = build(family, shape, 100)
        if data is None:
            continue
        path = tmp_path / f"{shape}{family.suffix}"
        path.write_bytes(data)
        out = invoke(_argv(command, path, tmp_path))
        assert not out.crashed and not TRACEBACK.search(out.output), out.output[-2000:]
        assert out.exit_code in (0, 1, 2)
        assert "AG006" not in out.output, (shape, out.output[-2000:])


def test_the_value_count_is_an_upper_bound_that_ignores_strings():
    text = '{"a,b": [1, 2, {"c": "x\\"y,["}], "d": []}'
    assert limits.count_values(text) == 8 >= 7  # 7 values; an empty container's bracket counts once more
    assert limits.count_values(text, bound=100) >= limits.count_values(text)
    with pytest.raises(limits.InputError) as err:
        limits.parse_json("[" + ",".join(["1"] * 50) + "]", "f.json", limits.Limits(max_nodes=10))
    assert err.value.limit == "max_nodes" and err.value.file == "f.json" and err.value.line == 1


def test_records_and_dsl_tokens_are_counted_where_they_are(tmp_path):
    path = tmp_path / "t.jsonl"
    path.write_text("{}\n" * 20)
    got = list(limits.iter_json_lines(path, limits.Limits(max_records=5)))
    assert len(got) == 6 and isinstance(got[-1][1], limits.InputError) and got[-1][0] == 6
    with pytest.raises(limits.InputError) as err:
        limits.check_dsl_text("raw " + ", ".join(f"R{i}" for i in range(100)), "r.ag", limits.Limits(max_dsl_tokens=50))
    assert err.value.limit == "max_dsl_tokens" and err.value.line == 1 and err.value.col > 1


def test_a_large_document_is_located_by_the_pointer_of_its_diagnostic(tmp_path):
    """F-LIMITS-POSITIONS: the positions of a large document come from one walk to the pointers needed."""
    big = '{"ir_version": "agspec-ir/1", "kind": "recipe",\n "x": [' + ",".join(["1.5"] * 200_000) + "]}"
    out = invoke(["validate", str(tmp_path / "r.json")]) if (tmp_path / "r.json").write_text(big) else None
    assert out is not None and f"{tmp_path / 'r.json'}:2:2" in out.output
    assert max(len(line) for line in out.output.splitlines()) < 400  # the long line is shown as a window
