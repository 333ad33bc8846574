"""Every command that stops on a document with errors prints its diagnostics as F-DIAGNOSTICS renders
them: the header `FILE:LINE:COL: error[AGnnn]: ...` names the severity itself, so no `error: ` is put
in front of it (agspec.cli.common.fail, the one place the CLI prints a failure)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from click.testing import CliRunner

from agspec.cli.common import fail
from agspec.cli.main import cli

ROOT = Path(__file__).resolve().parent.parent
DOUBLED = re.compile(r"\berror: [^\n]*\b(?:error|warning)\[AG\d+\]")
HEADER = re.compile(r"^bad\.ag:\d+:\d+: error\[AG454\]: ", re.M)

# every command that loads a scenario or instance document given on its command line
COMMANDS = [
    ["run", "bad.ag"],
    ["run", "bad.ag", "--format", "json"],
    ["instance", "bad.ag"],
    ["export", "bad.ag"],
    ["fingerprint", "bad.ag"],
    ["render", "--impl", "reference", "--scenario", "bad.ag", "-o", "x.html"],
    ["evaluate", "--scenario", "bad.ag", "--indices", "0"],
    ["diff", "--impl", "reference", "--impl", "reference", "--scenario", "bad.ag"],
    ["train", "--scenario", "bad.ag", "--algorithm", "ippo", "--seed", "0", "-o", "run"],
    ["compile", "bad.ag"],
    ["validate", "bad.ag"],
]


@pytest.fixture
def bad(tmp_path: Path, monkeypatch) -> Path:
    """coalition-medium on a line grid: AG454 (an operation whose inputs no coalition can gather)."""
    text = (ROOT / "catalogue" / "scenarios" / "coalition-medium.ag").read_text(encoding="utf-8")
    text = text.replace('use "../', f'use "{ROOT / "catalogue"}/').replace("moore radius 1", "line radius 1")
    (tmp_path / "bad.ag").write_text(text, encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    return tmp_path / "bad.ag"


@pytest.mark.parametrize("args", COMMANDS, ids=lambda a: " ".join(a[:3]))
def test_a_diagnostic_is_printed_once_without_a_second_prefix(bad: Path, args: list[str]):
    res = CliRunner().invoke(cli, args)
    out = res.output + (res.stderr if res.stderr_bytes is not None else "")
    if res.exit_code == 2 and "No such option" in out:
        pytest.fail(f"agspec {' '.join(args)}: {out}")
    assert res.exit_code == 1, out
    assert HEADER.search(out) or re.search(r": bad\.ag:\d+:\d+: error\[AG454\]: ", out), out
    assert not DOUBLED.search(out), out


@pytest.mark.parametrize("message, shown", [
    ("m3.ag:15:22: error[AG416]: no such thing\n    |\n 15 | x", "m3.ag:15:22: error[AG416]: no such thing"),
    ("<input>: warning[AG424]: claims suite official", "<input>: warning[AG424]: claims suite official"),
    ("--scenario m3.ag: m3.ag:1:2: error[AG410]: rows", "--scenario m3.ag: m3.ag:1:2: error[AG410]: rows"),
    ("file not found: m3.ag", "error: file not found: m3.ag"),
    ("bad [AG416] bracket", "error: bad [AG416] bracket"),
])
def test_fail_prefixes_only_what_is_not_a_diagnostic(capsys, message: str, shown: str):
    with pytest.raises(SystemExit):
        fail(message)
    err = capsys.readouterr().err
    assert err.splitlines()[0] == shown
