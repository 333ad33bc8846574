"""CLI: `instance`, `fingerprint`, `export`, `catalogue` (loader replaced by the test catalogue)."""

from __future__ import annotations

import copy
import json

import pytest
from click.testing import CliRunner

from agspec.catalogue import CatalogueError, lock_entries, write_lock
from agspec.cli import instance_cmds
from agspec.ir.fingerprint import fingerprint
from agspec.ir.instance import make_instance
from conftest_ir import bundle, official_ir


def _fake_load(name):
    if name not in official_ir()["scenarios"]:
        raise CatalogueError(f"unknown scenario `{name}`")
    return bundle(name)


@pytest.fixture(autouse=True)
def fake_loader(monkeypatch):
    monkeypatch.setattr(instance_cmds, "load_scenario_bundle", _fake_load)


def run(command, *args):
    return CliRunner().invoke(command, list(args), catch_exceptions=False)


def test_instance_prints_the_instance_ir():
    res = run(instance_cmds.instance, "coalition-medium", "--index", "1000")
    assert res.exit_code == 0
    assert json.loads(res.stdout) == make_instance(*bundle("coalition-medium"), index=1000)


def test_instance_writes_a_file(tmp_path):
    out = tmp_path / "inst.json"
    res = run(instance_cmds.instance, "flow-easy", "--generation-seed", "5", "--execution-seed", "6", "-o", str(out))
    assert res.exit_code == 0
    inst = json.loads(out.read_text(encoding="utf-8"))
    assert inst["id"] == "flow-easy-g5" and inst["seeds"] == {"index": None, "generation": 5, "execution": 6}
    assert fingerprint(inst) in res.stderr


def test_instance_user_errors_exit_2():
    res = run(instance_cmds.instance, "no-such-scenario")
    assert res.exit_code == 2 and "unknown scenario `no-such-scenario`" in res.stderr
    assert run(instance_cmds.instance, "flow-easy", "--index", "-3").exit_code == 2
    assert run(instance_cmds.instance, "flow-easy", "--index", "x").exit_code == 2
    res = run(instance_cmds.instance, "flow-easy", "--index", "1", "--generation-seed", "2")
    assert res.exit_code == 2 and "either --index or --generation-seed" in res.stderr


def test_fingerprint_of_json_files_and_names(tmp_path):
    recipe = official_ir()["recipes"]["pair_assembly"]
    path = tmp_path / "pair.json"
    path.write_text(json.dumps(recipe, indent=4), encoding="utf-8")
    res = run(instance_cmds.fingerprint, str(path), "coalition-easy")
    assert res.exit_code == 0
    lines = res.stdout.splitlines()
    assert lines[0] == f"{fingerprint(recipe)}  {path}"
    assert lines[1] == f"{fingerprint(bundle('coalition-easy')[0])}  coalition-easy"
    res = run(instance_cmds.fingerprint, "--format", "json", str(path))
    assert json.loads(res.stdout) == [{"path": str(path), "kind": "recipe", "id": "pair_assembly",
                                       "fingerprint": fingerprint(recipe)}]


def test_fingerprint_errors(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text("{not json", encoding="utf-8")
    res = run(instance_cmds.fingerprint, str(bad))
    assert res.exit_code == 1 and "error[AG003]: not valid JSON" in res.stderr
    res = run(instance_cmds.fingerprint, str(tmp_path / "missing.json"))
    assert res.exit_code == 2 and "error[AG001]: file not found" in res.stderr


def test_export_writes_the_original_definition(tmp_path):
    out = tmp_path / "def.json"
    res = run(instance_cmds.export, "flow-easy", "--index", "0", "--to", "assemblygrid-instance-v1", "-o", str(out))
    assert res.exit_code == 0
    assert res.stdout.split() == ["b87822087ece44957a53d8a1e973373f9083eaa835aeade0b1daae99d482c10d",
                                  "ag32-flow-easy-s00"]
    assert json.loads(out.read_text(encoding="utf-8"))["schema"] == "assemblygrid-instance-v1"


def test_export_of_an_instance_file_and_unexportable_instances(tmp_path):
    inst = make_instance(*bundle("coalition-hard"), index=0)
    path = tmp_path / "inst.json"
    path.write_text(json.dumps(inst), encoding="utf-8")
    res = run(instance_cmds.export, str(path))
    assert res.exit_code == 0 and "52fa73667ae777aa55dd371a9a5b8208d0a8391aad3a38b4dcd9e8938e23df34" in res.stderr
    changed = copy.deepcopy(inst)
    changed["recipes"]["standard_abc"]["operations"][0]["duration"] = 9
    path.write_text(json.dumps(changed), encoding="utf-8")
    res = run(instance_cmds.export, str(path))
    assert res.exit_code == 1 and "standard_abc" in res.stderr


def test_catalogue_list_json():
    res = run(instance_cmds.catalogue, "list", "--format", "json")
    rows = json.loads(res.stdout)
    assert [r["name"] for r in rows][:3] == ["flow-easy", "flow-medium", "flow-hard"] and len(rows) == 12
    assert rows[4]["grid"] == "5x6" and rows[4]["wip_cap"] == 4 and rows[4]["interval"] == 5
    res = run(instance_cmds.catalogue, "list")
    assert res.exit_code == 0 and "supported_insert" in res.stdout


def test_catalogue_verify_and_update(tmp_path, monkeypatch):
    computed = lock_entries(bundle)  # the CLI recomputes the lock on every call; compute it once here
    monkeypatch.setattr(instance_cmds, "lock_entries", lambda load_fn: copy.deepcopy(computed))
    lock = tmp_path / "lock.json"
    assert run(instance_cmds.catalogue, "verify", "--lock", str(lock)).exit_code == 2  # no lock yet
    res = run(instance_cmds.catalogue, "verify", "--update", "--lock", str(lock))
    assert res.exit_code == 0 and "9 scenarios, 45 realizations" in res.stdout
    assert run(instance_cmds.catalogue, "verify", "--lock", str(lock)).exit_code == 0

    stale = copy.deepcopy(computed)
    stale["scenarios"]["coalition-easy"]["fingerprint"] = "sha256:" + "0" * 64
    write_lock(stale, lock)
    res = run(instance_cmds.catalogue, "verify", "--lock", str(lock))
    assert res.exit_code == 1
    assert "catalogue drift" in res.stderr and "scenario `coalition-easy` changed" in res.stderr
    assert run(instance_cmds.catalogue, "lock", "--lock", str(lock)).exit_code == 0
    assert run(instance_cmds.catalogue, "verify", "--lock", str(lock)).exit_code == 0


def test_run_rejects_bad_instance_files_with_location_and_exit_code(tmp_path):
    """agspec.catalogue.load_instance through `agspec run` (F-EXIT-CODES): not JSON -> 1 located,
    schema-invalid -> 1 with the JSON Pointer, unknown scenario -> 2; a valid file runs."""
    from agspec.cli.main import cli

    def run_cli(*args):
        return CliRunner().invoke(cli, ["run", *args, "--horizon", "3", "--format", "json"])

    inst = make_instance(*bundle("flow-easy"), index=0)
    good = tmp_path / "good.json"
    good.write_text(json.dumps(inst), encoding="utf-8")
    res = run_cli(str(good))
    assert res.exit_code == 0 and json.loads(res.stdout)["instance"] == inst["id"]
    broken = tmp_path / "broken.json"
    broken.write_text("{not json", encoding="utf-8")
    res = run_cli(str(broken))
    assert res.exit_code == 1 and f"{broken}:1:2: error[AG003]: not valid JSON" in res.stderr
    invalid = tmp_path / "invalid.json"
    invalid.write_text(json.dumps({**inst, "seeds": "none"}), encoding="utf-8")
    res = run_cli(str(invalid))
    assert res.exit_code == 1 and f"{invalid}/seeds" in res.stderr and "error[AG2" in res.stderr
    res = run_cli("no-such-scenario")
    assert res.exit_code == 2 and "unknown scenario" in res.stderr
