"""F-SCHEMAS-SELF: every document agspec writes validates against its own schema.

tests/conftest.py turns self-check mode on for the whole test suite, so every writer (report lines,
traces, golden files, reproducers, results bundles, the lock, check reports, every ``--format json``
output) validates what it writes in every test.  These tests prove that the mode is on and catches a
drift, that every ``--format json`` output names a schema that exists, and that the documents that
drifted before now validate.
"""

from __future__ import annotations

import ast
import json
import os
from pathlib import Path

import pytest
from jsonschema import Draft202012Validator

from agspec.conform import runner
from agspec.conform.impl import SubprocessImpl
from agspec.conform.items import catalogue_episodes
from agspec.formats import report as report_format
from agspec.formats import schemas
from agspec.formats.report import read_report
from agspec.formats.trace import TraceWriter

ROOT = Path(__file__).resolve().parents[1]


def test_self_check_mode_is_on_in_the_test_suite():
    assert os.environ.get(schemas.SELF_CHECK)


def test_a_planted_drift_is_caught_as_it_is_written(tmp_path, monkeypatch):
    """A new field a writer adds without its schema fails at once (the mutant the mode must catch)."""
    header = report_format.header_record({"spec": "x"}, {}, 0, protocol="agspec-protocol/1")
    with report_format.ReportWriter(tmp_path / "r.jsonl") as out:
        out.write(header)
        with pytest.raises(schemas.SchemaDrift, match="unknown field `surprise`"):
            out.write({**header, "surprise": 1})
    with pytest.raises(schemas.SchemaDrift):
        TraceWriter(tmp_path / "t.jsonl")._write({"type": "tick", "t": "one"})
    monkeypatch.delenv(schemas.SELF_CHECK)
    with report_format.ReportWriter(tmp_path / "r2.jsonl") as out:  # outside the tests: written as is
        out.write({**header, "surprise": 1})


def test_every_schema_is_a_valid_draft_2020_12_schema():
    for name, doc in schemas._files().items():
        Draft202012Validator.check_schema(doc)
        assert doc.get("$id"), name


def _emit_json_calls() -> list[tuple[str, int, object]]:
    out = []
    for path in sorted((ROOT / "agspec" / "cli").glob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if isinstance(node, ast.Call) and getattr(node.func, "id", None) == "emit_json":
                schema = node.args[1] if len(node.args) > 1 else None
                out.append((path.name, node.lineno, getattr(schema, "value", None)))
    return out


def test_every_format_json_output_names_a_schema_that_exists():
    calls = _emit_json_calls()
    assert len(calls) >= 15
    for file, line, name in calls:
        assert isinstance(name, str), f"{file}:{line}: emit_json without a schema name"
        schemas.load_schema(name) if not schemas.schema_id(name).startswith("urn:assemblygrid") else None
        assert schemas.validator(name) is not None, f"{file}:{line}: no schema {name}"


def test_a_run_that_gives_up_writes_a_valid_report(tmp_path):
    """The report of a simulator the harness gave up on validates (failure type gave_up)."""
    import shlex
    import sys

    items = catalogue_episodes(1, 2, ["flow-easy", "flow-medium", "flow-hard", "coalition-easy"])
    # a simulator that never starts: the harness gives up once starting failed max_restarts times in a row
    # (RES-GIVE-UP-SCOPE; one failing item alone no longer makes it give up)
    crash = shlex.join([sys.executable, "-c", "import sys; sys.exit(3)"])
    impl = SubprocessImpl(crash, 5.0, max_restarts=1)
    report = tmp_path / "r.jsonl"
    try:
        summary = runner.run(items, "missing", impl=impl, report_path=str(report))
    finally:
        impl.close()
    records, problems = read_report(report)
    assert problems == []
    assert "gave_up" in {(r.get("failure") or {}).get("type") for r in records if r["type"] == "case"}
    assert summary.exit_code == 3


def test_the_documents_of_a_failing_conform_run_validate(tmp_path):
    """A diverging simulator: report, reproducer and the json summary are all schema-valid (they were
    validated as written; read back here as a user would)."""
    from click.testing import CliRunner

    from agspec.cli.main import cli

    fake = ROOT / "tests" / "fakes" / "fake_sim.py"
    import sys

    out = CliRunner().invoke(cli, ["conform", "--impl", f"{sys.executable} {fake} mutate --only flow-easy",
                                   "--no-suite", "--episodes", "1", "--horizon", "4", "-k", "flow-easy",
                                   "-o", str(tmp_path / "r.jsonl"), "--repro-dir", str(tmp_path),
                                   "--format", "json"])
    assert out.exit_code == 1, out.output[-2000:]
    assert schemas.validate("conform", json.loads(out.output)) == []
    assert read_report(tmp_path / "r.jsonl")[1] == []
    repro = next(tmp_path.glob("*/*.repro.json"))  # F-REPRO: {--repro-dir}/{impl}/{id}.repro.json
    assert schemas.validate("repro", json.loads(repro.read_text("utf-8"))) == []


def test_a_traces_later_tick_records_are_held_to_the_schemas_shape(tmp_path):
    writer = TraceWriter(tmp_path / "t.jsonl")
    writer.ticks = 10  # past the records validated whole
    with pytest.raises(schemas.SchemaDrift, match="shape"):
        writer._write({"type": "tick", "t": 10, "actions": {}, "events": [], "state": {"t": "eleven"}})
