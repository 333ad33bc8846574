"""A suite case is shown by its name — the title its file gives it — and its place in the suite
(`conformance/cases/handoff.yaml:5`), wherever the suite is installed and whatever the working
directory; its content hash (`c-…`) stays the stable id of reports, reproducers and --expect files."""

from __future__ import annotations

import json
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

from agspec.conform.cases.suite import load_suite
from agspec.conform.items import from_case
from agspec.resources import conformance_dir

ROOT = Path(__file__).resolve().parents[1]
SIM = ROOT / "tests" / "mutants" / "sim.py"


def test_case_location_is_relative_to_its_suite_wherever_it_lies(tmp_path: Path, monkeypatch):
    copy = tmp_path / "elsewhere" / "mysuite"
    shutil.copytree(conformance_dir(), copy)
    monkeypatch.chdir(tmp_path / "elsewhere")
    shipped = {c.id: c for c in load_suite()}
    for case in load_suite(copy):  # the same cases, named from their own suite
        file, line = case.location.rsplit(":", 1)
        assert file.startswith("mysuite/cases/") and file.endswith(".yaml") and int(line) >= 1
        assert (copy.parent / file).read_text(encoding="utf-8").splitlines()[int(line) - 1].lstrip().startswith("- title:")
        assert shipped[case.id].location == "conformance/" + case.location.split("/", 1)[1]
        item = from_case(case)
        assert item.name == f"{case.title} ({case.location})" and item.heading == f"{case.title} [{case.id}]"


def test_conform_shows_a_failing_case_by_name_and_keeps_its_id(tmp_path: Path):
    spec = shlex.join([sys.executable, str(SIM), "--mutant", "dup-handoff"])
    cmd = [sys.executable, "-m", "agspec.cli.main", "conform", "--impl", spec, "--episodes", "0", "-k",
           "handoff and not radius and not parallel", "--golden-cache", "off", "-o", "r.jsonl", "--repro-dir", "repro"]
    proc = subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 1, proc.stdout + proc.stderr
    records = [json.loads(line) for line in (tmp_path / "r.jsonl").read_text(encoding="utf-8").splitlines()]
    failed = [r for r in records if r.get("type") == "case" and r["outcome"] == "fail"]
    assert failed
    for r in failed:
        assert r["id"].startswith("c-")  # the stable id is the content hash
        assert r["location"].startswith("conformance/cases/")  # never site-packages, never an absolute path
        assert f"FAIL {r['title']} [{r['id']}]" in proc.stdout
        assert f"case at {r['location']}" in proc.stdout
        assert (tmp_path / "repro").exists()
    places = [ln.strip() for ln in proc.stdout.splitlines() if ln.startswith(("  case at ", "  expectation "))]
    assert places and all(ln.split(" ", 2)[-1 if ln.startswith("case") else 1].startswith("conformance/cases/")
                          for ln in places), places  # never site-packages, never an absolute path
    first = failed[0]
    table_row = next(line for line in proc.stdout.splitlines() if line.lstrip("│ ").startswith("fail"))
    assert first["title"][:20] in table_row  # the table's first failure by name, not by hash
    # --expect files keep naming the case by its id
    (tmp_path / "expect.json").write_text(json.dumps({r["id"]: {"outcome": "fail"} for r in failed}), encoding="utf-8")
    again = subprocess.run([*cmd, "--expect", "expect.json"], cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert again.returncode == 0, again.stdout + again.stderr
