"""Careless-user paths of the CLI: which catalogue `catalogue verify` checks (and `--catalogue DIR`),
a scenario without a `suite` block (RES-SEED-BASES-DEFAULT), `fmt` keeping XOR groups with their
operations (F-DSL-FMT), and seeds outside F-LIMITS-SEEDS."""

from __future__ import annotations

import shutil
from pathlib import Path

from click.testing import CliRunner

from agspec.cli.main import cli
from agspec.resources import catalogue_dir

ROOT = Path(__file__).resolve().parent.parent


def run(*args: str):
    return CliRunner().invoke(cli, list(args), catch_exceptions=False)


def test_catalogue_verify_names_the_copy_and_checks_another_with_catalogue(tmp_path):
    copy = tmp_path / "catalogue"
    shutil.copytree(ROOT / "catalogue", copy)
    scenario = copy / "scenarios" / "flow-easy.ag"
    scenario.write_text(scenario.read_text(encoding="utf-8").replace("horizon 400", "horizon 401"), encoding="utf-8")
    res = run("catalogue", "verify", "--catalogue", str(copy))
    assert res.exit_code == 1 and f"checking the catalogue in {copy}" in res.stderr
    assert "scenario `flow-easy` changed" in res.stderr and str(copy / "lock.json") in res.stderr


def test_catalogue_verify_says_which_copy_it_checks_by_default():
    # the copy agspec resolves: the working tree under an editable install, the wheel's copy otherwise
    res = run("catalogue", "verify")
    assert res.exit_code == 0
    assert f"checking {catalogue_dir()}" in res.stderr and "--catalogue DIR" in res.stderr


def test_a_scenario_without_a_suite_block_runs_at_the_default_index(tmp_path):
    text = (ROOT / "catalogue" / "scenarios" / "flow-easy.ag").read_text(encoding="utf-8")
    lines = [ln for ln in text.splitlines() if not ln.strip().startswith(("suite", "use"))]
    path = tmp_path / "mine.ag"
    path.write_text("\n".join(lines).replace("scenario flow-easy", "scenario mine") + "\n", encoding="utf-8")
    res = run("run", str(path), "--horizon", "3", "--format", "json")
    assert res.exit_code == 0, res.output
    assert '"instance": "mine-s00"' in res.stdout


XOR_FIRST = """recipe r {
    raw A
    xor route = glue | weld
    operation inspect { type check  after route  inputs G -> FINAL  team 1  roles w(G)  duration 1 }
    operation glue { type join  inputs A -> G  team 1  roles w(A)  duration 2 }
    operation weld { type join  inputs A -> G  team 1  roles w(A)  duration 3 }
}
"""


def test_fmt_keeps_an_xor_group_before_its_alternatives_and_the_operations_after_it(tmp_path):
    path = tmp_path / "r.ag"
    path.write_text(XOR_FIRST, encoding="utf-8")
    res = run("fmt", str(path))
    assert res.exit_code == 0, res.output
    text = res.stdout
    assert text.index("xor route = glue | weld") < text.index("operation glue") < text.index("operation inspect")
    path.write_text(text, encoding="utf-8")  # F-DSL-FMT: the canonical text is a fixpoint
    assert run("fmt", "--check", str(path)).exit_code == 0


def test_seeds_and_indices_outside_the_exact_json_range_are_usage_errors():
    for args in (["run", "flow-easy", "--generation-seed", str(2**53)], ["instance", "flow-easy", "--index", "-1"],
                 ["export", "flow-easy", "--generation-seed", str(10**30)]):
        res = CliRunner().invoke(cli, args)
        assert res.exit_code == 2 and "is not in the range" in res.output, args
