"""S-RULE-VARIANTS: options that change a rule are declared once, read once, and never ignored."""

from __future__ import annotations

import copy
import re
from pathlib import Path

import pytest
from click.testing import CliRunner

import ir_fixtures as F
from agspec.catalogue import load_scenario_bundle
from agspec.cli.main import cli
from agspec.controllers import make_controller
from agspec.interp.tick import Simulator
from agspec.ir import variants
from agspec.ir.instance import make_instance
from agspec.ir.validate import validate_profile, validate_scenario
from agspec.resources import schemas_dir
from agspec.spec_index import spec_ids

ROOT = Path(__file__).resolve().parents[1]


def test_bilateral_handoff_false_is_rejected_not_ignored():  # S-RULE-VARIANTS, R-HANDOFF
    sc = F.scenario("coalition-easy")
    sc["coordination"]["bilateral_handoff"] = False
    found = [(i.code, i.pointer) for i in validate_scenario(sc, F.official_resolver())]
    assert ("AG423", "/coordination/bilateral_handoff") in found
    sc["coordination"]["bilateral_handoff"] = True
    assert all(i.code != "AG423" for i in validate_scenario(sc, F.official_resolver()))


def test_unsupported_profile_value_is_rejected(monkeypatch):
    """A planted option whose ``false`` the interpreter does not implement is reported on the profile."""
    narrowed = tuple(variants.Option(o.document, o.path, o.rule, o.default, (True,), o.meaning)
                     if o.name == "motion_planning" else o for o in variants.OPTIONS)
    monkeypatch.setattr(variants, "OPTIONS", narrowed)
    profile = F.resolved_profile()
    profile["motion_planning"] = False
    assert ("AG423", "/motion_planning") in {(i.code, i.pointer) for i in validate_profile(profile)}


def test_dsl_reports_the_option_at_its_source(tmp_path):
    text = (ROOT / "catalogue" / "scenarios" / "coalition-easy.ag").read_text(encoding="utf-8")
    text = text.replace("bilateral_handoff on", "bilateral_handoff off")
    text = re.sub(r'use "\.\./', f'use "{ROOT / "catalogue"}/', text)
    path = tmp_path / "bh.ag"
    path.write_text(text, encoding="utf-8")
    result = CliRunner().invoke(cli, ["validate", str(path)])
    assert result.exit_code == 1, result.output
    assert "AG423" in result.output and "bilateral_handoff" in result.output


def test_every_option_is_a_schema_field_and_cites_a_spec_rule():
    known = spec_ids(("R-", "O-", "G-"))
    for option in variants.OPTIONS:
        assert option.rule in known, option
        schema = (schemas_dir() / f"{option.document}.schema.json").read_text(encoding="utf-8")
        assert f'"{option.name}"' in schema, option
        assert option.default in option.supported


@pytest.mark.parametrize("name", [o.name for o in variants.OPTIONS if o.supported == (True, False)])
def test_each_implemented_variant_changes_the_run(name):
    """Flipping an implemented option changes the reference's behaviour on an official instance."""
    sc, recipes, profile = load_scenario_bundle("coalition-medium")
    base = make_instance(sc, recipes, profile, index=0)
    flipped = copy.deepcopy(base)
    option = variants.BY_NAME[name]
    doc = flipped["scenario"] if option.document == "scenario" else flipped["profile"]
    for key in option.path[:-1]:
        doc = doc[key]
    doc[option.path[-1]] = not option.default

    def trace(inst):
        sim = Simulator(inst)
        sim.reset(inst["seeds"]["execution"])
        ctl = make_controller("greedy", 0)
        ctl.reset(0)
        out = []
        for _ in range(60):
            obs = sim.observe()
            out.append(obs)
            sim.step(ctl.act(obs))
        return out, sim.state

    assert trace(base) != trace(flipped)


def test_geometry_off_control_has_no_geometry_delay():  # M-GEOMETRY-DELAY, G-MOTION
    sc, recipes, profile = load_scenario_bundle("coalition-medium")
    delays = {}
    for planning in (True, False):
        inst = make_instance(sc, recipes, profile, index=0)
        inst["profile"]["motion_planning"] = planning
        sim = Simulator(inst)
        ctl = make_controller("greedy", 0)
        ctl.reset(0)
        for _ in range(60):
            sim.step(ctl.act(sim.observe()))
        delays[planning] = sim.final_metrics()["geometry_delay_ticks"]
    assert delays[False] == 0 < delays[True]


def test_interpreter_reads_options_only_through_the_table():
    """Guard: no module of the interpreter, the invariant checker or the controllers reads a rule-variant option directly (planted drift below)."""
    for package in ("interp", "conform", "controllers"):
        assert direct_reads(ROOT / "agspec" / package) == []


def test_direct_read_guard_catches_a_planted_read(tmp_path):
    (tmp_path / "rule.py").write_text('segments = bool(model.profile.get("trajectory_conflicts", True))\n')
    assert direct_reads(tmp_path) == [f"{tmp_path / 'rule.py'}:1: trajectory_conflicts"]


def direct_reads(root: Path) -> list[str]:
    names = "|".join(re.escape(o.name) for o in variants.OPTIONS)
    pattern = re.compile(rf"""(?:\.get\(\s*|\[\s*)["']({names})["']""")
    out = []
    for path in sorted(root.rglob("*.py")):
        for lineno, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
            for m in pattern.finditer(line):
                out.append(f"{path}:{lineno}: {m.group(1)}")
    return out
