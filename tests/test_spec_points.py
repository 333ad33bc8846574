"""Spec points an outside author asked about, each settled in spec/ and held here to the code:

* S-RESOURCES: a resource name with `:` (an implicit resource such as `shelf:0:A` or `product:0`)
  is refused by `load` (`invalid_instance`, AG207), `agspec run` and the IR validator;
* RES-SLOT-OVERFLOW-LOAD: the reference refuses an instance whose s_0 overflows at `load`;
* RES-IN-EPOCH-EXPIRY: an in-epoch removal is always `invalid`;
* T-RESUME: `--resume` into a directory without a checkpoint says that a new run starts;
* F-TRACE: tick t's `observations` are I_t (of s_t, the state the actions were chosen in);
* the protocol definitions need no file of agspec/ or tests/ (the spec alone defines them).
"""

from __future__ import annotations

import copy
import json
import re

import pytest
from click.testing import CliRunner

from agspec.catalogue import load_instance
from agspec.cli.main import cli
from agspec.conform.impl.serve import Server
from agspec.evaluate import run_episode
from agspec.interp import observe, rules
from agspec.interp.tick import Simulator
from agspec.ir.schemas import validate_schema
from agspec.resources import conformance_dir
from agspec.spec_index import spec_entry
from agspec.checkpoint.rundir import RunDirError

try:  # the training extra (PyTorch) is optional
    from agspec.train import api as train_api
except ImportError:
    train_api = None

INSTANCES = conformance_dir() / "instances"


def _instance(name: str = "solo-1x2-wip1-flat") -> dict:
    return json.loads((INSTANCES / f"{name}.json").read_text(encoding="utf-8"))


def _load(instance: dict) -> dict:
    server = Server()
    assert server.handle({"cmd": "start", "seq": 1, "protocol": "agspec-protocol/1"})["ok"]
    return server.handle({"cmd": "load", "seq": 2, "instance": instance})


# --------------------------------------------------------------------------- S-RESOURCES


@pytest.mark.parametrize("name", ["shelf:0:A", "product:0", "robot:0,1"])
def test_s_resources_an_implicit_resource_cannot_be_overridden(tmp_path, name):
    inst = _instance()
    inst["scenario"]["resources"][name] = 0
    reply = _load(inst)
    assert not reply["ok"] and reply["error"]["code"] == "invalid_instance" and "AG207" in reply["error"]["message"]
    assert [(i.code, i.pointer) for i in validate_schema(inst["scenario"])] == [("AG207", "/resources")]
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(inst), encoding="utf-8")
    result = CliRunner().invoke(cli, ["run", str(path), "--horizon", "3"])
    assert result.exit_code == 1 and "AG207" in result.output


def test_s_resources_a_recipe_resource_name_holds_no_colon():
    inst = _instance("pair-1x2-official")
    recipe = next(iter(inst["recipes"].values()))
    recipe["resources"]["shelf:0:A"] = 1
    assert ("AG207", "/resources") in [(i.code, i.pointer) for i in validate_schema(recipe)]
    assert _load(inst)["error"]["code"] == "invalid_instance"
    plain = copy.deepcopy(_instance())
    plain["scenario"]["resources"]["fixture"] = 2  # a name without `:` is accepted
    assert _load(plain)["ok"]


# --------------------------------------------------------------------------- RES-SLOT-OVERFLOW-LOAD


def test_res_slot_overflow_load_the_reference_refuses_at_load(monkeypatch):
    monkeypatch.setattr(observe, "PICK_SLOTS", 0)  # every pick option of s_0 overflows
    inst = _instance()
    with pytest.raises(observe.SlotOverflow, match="t=0"):
        Simulator(inst)
    reply = _load(inst)
    assert reply["error"]["code"] == "invalid_instance" and "SlotOverflow" in reply["error"]["message"]


# --------------------------------------------------------------------------- RES-IN-EPOCH-EXPIRY


def test_res_in_epoch_expiry_an_in_epoch_removal_is_invalid(monkeypatch):
    reasons: list[str] = []
    original = rules.expire_invalid_proposals

    def spy(state, valid_ids, events):
        before = len(events)
        original(state, valid_ids, events)
        reasons.extend(e.get("reason", "abandoned") for e in events[before:])

    monkeypatch.setattr(rules, "expire_invalid_proposals", spy)
    for scenario, controller in (("coalition-medium", "random"), ("coalition-hard", "greedy"),
                                 ("concurrency-medium", "parallel-aware")):
        run_episode(load_instance(scenario, 0, None), controller, horizon=150)
    assert reasons, "no in-epoch removal happened: the test would be vacuous"
    assert "expired" not in reasons


# --------------------------------------------------------------------------- T-RESUME


def test_t_resume_without_a_checkpoint_says_a_new_run_starts(tmp_path, monkeypatch):
    if train_api is not None:  # with the training extra, stop before any training: only the message is tested
        def no_training(*_args, **_kwargs):
            raise RunDirError("stopped by the test")

        monkeypatch.setattr(train_api, "train", no_training)
    # without it the command stops at the missing extra, after the message
    out = tmp_path / "fresh"
    result = CliRunner().invoke(cli, ["train", "--algorithm", "ippo", "--scenario", "flow-easy", "--seed", "0",
                                      "-o", str(out), "--resume"])
    assert "holds no checkpoint to continue; a new run starts from step 0" in result.output


# --------------------------------------------------------------------------- F-TRACE observations


def test_f_trace_tick_t_carries_the_observations_of_s_t(tmp_path):
    path = tmp_path / "obs.jsonl"
    result = CliRunner().invoke(cli, ["run", "flow-easy", "--trace", str(path), "--horizon", "3", "--observations"])
    assert result.exit_code == 0, result.output
    records = [json.loads(line) for line in path.read_text(encoding="utf-8").splitlines()]
    sim = Simulator(records[0]["instance"])
    for rec in records[1:-1]:
        assert rec["observations"] == json.loads(json.dumps(sim.observe())), rec["t"]  # I_t, of s_t
        sim.step(rec["actions"])


# --------------------------------------------------------------------------- the spec alone


@pytest.mark.parametrize("ident", ["F-TRACE-EMISSION", "F-PROTOCOL-LINES", "F-PROTOCOL-SHAPE", "F-EVENT-DIFF",
                                   "F-PROTOCOL-ERRORS", "F-TRACE", "F-TRACE-CLAIMS"])
def test_the_protocol_definitions_name_no_file_of_agspec_or_tests(ident):
    entry = spec_entry(ident)
    assert entry is not None
    assert not re.findall(r"`(?:agspec|tests)/[^`]*`", entry.text), entry.text
