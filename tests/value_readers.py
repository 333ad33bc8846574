"""The generator of F-VALUES / RES-INTEGRAL-ACTIONS cases for every reader of an action or an integer.

Each reader is given a message or a file it accepts, with every number re-spelt (``6`` as ``6.0``,
``6e0``, ``60e-1``: tests/reply_mutations.py ``respelt``) — its verdict must not change — and the same
message with one action replaced by a value that is not an action (``2.5``, ``true``, ``"2"``) — it
must be refused, by the reader's own error, with the place named.  Readers: a policy's joint action
(``check_joint``), a process policy's reply (tests/fakes/policy_process.py), the requests of
``agspec serve``, trace files, reproducer files, IR files, results bundles and training records.

:func:`cases` yields ``(reader, label, ok)``; tests/test_value_rule.py runs a bounded share,
benchmarks/fuzz_values.py all of them.
"""

from __future__ import annotations

import copy
import json
import random
import shlex
import sys
from pathlib import Path
from typing import Any, Callable, Iterator

from agspec.catalogue import load_instance
from agspec.conform.impl.serve import Server
from agspec.conform.repro import ReproError, load_reproducer, make_reproducer
from agspec.evaluate import Job, run_job
from agspec.formats.protocol import PROTOCOL
from agspec.load import load_document
from agspec.policy.bundle import BundleError, read_bundle
from agspec.policy.contract import PolicyError, parse_policy
from agspec.policy.episode import check_joint
from agspec.trace.read import read_trace
from agspec.train.record import read_record

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from reply_mutations import dump, respelt  # noqa: E402

SCENARIO = "coalition-easy"
NOT_ACTIONS = ["2.5", "true", '"2"', "null", "[2]"]


def spelt(value: Any, rng: random.Random, share: float = 1.0) -> Any:
    """``value`` as a reader gets it after its numbers were written another way (F-VALUES)."""
    return json.loads(dump(respelt(value, rng, share)))


def short_instance(horizon: int = 8, index: int = 0) -> dict:
    inst = load_instance(SCENARIO, index)
    inst["scenario"]["evaluation"]["horizon"] = horizon
    return inst


def _serve(requests: list[dict]) -> list[dict]:
    server = Server()
    return [server.handle(copy.deepcopy(r)) for r in requests]


def _session(instance: dict, ticks: int) -> list[dict]:
    """A start / load / reset / step... session of ``agspec serve`` driven by its masks (highest legal)."""
    server = Server()
    reqs = [{"seq": 1, "cmd": "start", "protocol": PROTOCOL}, {"seq": 2, "cmd": "load", "instance": instance},
            {"seq": 3, "cmd": "reset", "execution_seed": 7}]
    replies = [server.handle(copy.deepcopy(r)) for r in reqs]
    for k in range(ticks):
        masks = replies[-1]["masks"]
        # the highest legal action, and an out-of-range one for the first robot (R-ACTION-VALIDATION: idle)
        acts = {r: max(i for i, ok in enumerate(m) if ok) for r, m in masks.items()}
        acts[next(iter(acts))] = 500 if k == 1 else acts[next(iter(acts))]
        reqs.append({"seq": 4 + k, "cmd": "step", "actions": acts})
        replies.append(server.handle(copy.deepcopy(reqs[-1])))
    return reqs


def _with_action(doc: Any, pointer: tuple, text: str) -> Any:
    doc = copy.deepcopy(doc)
    node = doc
    for key in pointer[:-1]:
        node = node[key]
    node[pointer[-1]] = json.loads(text)
    return doc


class Readers:
    """The documents every reader is tried on, built once (``directory``: where files are written)."""

    def __init__(self, directory: Path, fakes: Path):
        self.dir, self.fakes = directory, fakes
        self.instance = short_instance()
        self.requests = _session(self.instance, 5)
        self.replies = _serve(self.requests)
        self.joint = {r: a for r, a in self.requests[-1]["actions"].items()}
        self.agents = list(self.joint)
        self.joint[self.agents[0]] = 113
        self.trace_path = directory / "run.trace.jsonl"
        self.trace_lines = self._trace()
        self.repro = make_reproducer(ident="x", title="x", instance=self.instance, execution_seed=7,
                                     actions=[r["actions"] for r in self.requests[3:]], impl="agspec serve",
                                     failure=None, expectations=[{"after_tick": 2, "state": {}}],
                                     history=[("load", self.instance), ("reset", 3),
                                              ("step", self.requests[3]["actions"])])
        self.repro_seen = self._repro(self.repro)
        self.bundle_text = self._bundle()
        self.bundle_seen = read_bundle(directory / "results.json")

    # ---------------------------------------------------------------- building

    def _trace(self) -> list[dict]:
        from click.testing import CliRunner
        from agspec.cli.main import cli

        out = CliRunner().invoke(cli, ["run", SCENARIO, "--horizon", "5", "--trace", str(self.trace_path)])
        assert out.exit_code == 0, out.output
        return [json.loads(line) for line in self.trace_path.read_text().splitlines() if line.strip()]

    def _bundle(self) -> str:
        from click.testing import CliRunner
        from agspec.cli.main import cli

        out = CliRunner().invoke(cli, ["evaluate", "--controller", "greedy", "--scenario", SCENARIO, "--split",
                                       "catalogue", "--indices", "0", "-o", str(self.dir / "results.json"),
                                       "--format", "json"])
        assert out.exit_code == 0, out.output
        return (self.dir / "results.json").read_text()

    def _repro(self, doc: Any, name: str = "repro.json") -> Any:
        path = self.dir / name
        path.write_bytes(doc if isinstance(doc, bytes) else json.dumps(doc).encode())
        return load_reproducer(path)

    # ---------------------------------------------------------------- the readers, respelt: (label, ok)

    def joint_respelt(self, rng: random.Random) -> tuple[str, bool]:
        got = check_joint(spelt(self.joint, rng), self.agents, 3)
        return "check_joint", got == self.joint and all(type(v) is int for v in got.values())

    def serve_respelt(self, rng: random.Random) -> tuple[str, bool]:
        reqs = [spelt(r, rng) for r in self.requests]
        got = _serve(reqs)
        same = all(json.dumps(a, sort_keys=True) == json.dumps({**b, "seq": a["seq"]}, sort_keys=True)
                   for a, b in zip(self.replies, got))
        return "agspec serve", same

    def trace_respelt(self, rng: random.Random) -> tuple[str, bool]:
        path = self.dir / "spelt.trace.jsonl"
        path.write_bytes(b"\n".join(dump(respelt(r, rng)) for r in self.trace_lines) + b"\n")
        records, diags = read_trace(path)
        return "trace", not diags and [r.get("actions") for r in records] == [r.get("actions") for r in
                                                                                 self.trace_lines] \
            and all(type(v) is int for r in records for v in (r.get("actions") or {}).values())

    def repro_respelt(self, rng: random.Random) -> tuple[str, bool]:
        got = self._repro(dump(respelt(self.repro, rng)))
        return "reproducer", json.dumps(got["actions"]) == json.dumps(self.repro_seen["actions"]) \
            and json.dumps(got["history"]["requests"]) == json.dumps(self.repro_seen["history"]["requests"]) \
            and got["execution_seed"] == 7 and type(got["execution_seed"]) is int \
            and _serve(self.requests[:1] + [{**self.requests[1], "instance": got["instance"]}] + self.requests[2:]) \
            == self.replies

    def ir_respelt(self, rng: random.Random) -> tuple[str, bool]:
        path = self.dir / "spelt.instance.json"
        path.write_bytes(dump(respelt(self.instance, rng)))
        doc = load_document(path)
        replayed = _serve(self.requests[:1] + [{**self.requests[1], "instance": doc.ir}] + self.requests[2:])
        return "IR file", not doc.diagnostics and replayed == self.replies

    def record_respelt(self, rng: random.Random) -> tuple[str, bool]:
        # a training record (T-RECORD) as tests/test_trained_rows.py fakes one: counts are integers
        rows = [{"kind": "header", "schema": "agspec-training-record/1", "budget": 3000}] + [
            {"kind": "progress", "steps": 1000 * k, "episodes": k, "milestone_return": 1.5 * k, "admissions": 1.0,
             "delivered": 2.0 * k, "entropy": 1.0 / k, "explained_variance": 0.1 * k} for k in range(1, 4)]
        path = self.dir / "record.jsonl"
        path.write_bytes(b"\n".join(dump(respelt(r, rng)) for r in rows) + b"\n")
        got = list(read_record(path))
        return "training record", [(r["steps"], type(r["steps"])) for r in got[1:]] == \
            [(r["steps"], int) for r in rows[1:]] and got == rows

    def bundle_respelt(self, rng: random.Random) -> tuple[str, bool]:
        path = self.dir / "spelt.json"
        path.write_bytes(dump(respelt(json.loads(self.bundle_text), rng)))
        got = read_bundle(path)
        ep, ep0 = got["episodes"][0], self.bundle_seen["episodes"][0]
        return "bundle", got == self.bundle_seen and type(ep["index"]) is int and type(ep0["index"]) is int

    def process_respelt(self, rng: random.Random) -> tuple[str, bool]:
        base = run_job(Job(SCENARIO, 0, parse_policy(f"{sys.executable} {self.fakes}/policy_process.py ok"),
                           short_instance(6)))
        got = run_job(Job(SCENARIO, 0, parse_policy(f"{sys.executable} {self.fakes}/policy_process.py respelt"),
                          short_instance(6)))
        return "process policy", got.get("status") == "ok" and got.get("metrics") == base.get("metrics")

    # ---------------------------------------------------------------- the readers, a value that is not an action

    def joint_refuses(self, text: str) -> tuple[str, bool]:
        try:
            check_joint(_with_action(self.joint, (self.agents[1],), text), self.agents, 3)
        except PolicyError as exc:
            return "check_joint", exc.code == "bad_action" and exc.agent == self.agents[1]
        return "check_joint", False

    def serve_refuses(self, text: str) -> tuple[str, bool]:
        robot = self.agents[1]
        reqs = self.requests[:4] + [_with_action(self.requests[4], ("actions", robot), text)]
        got = _serve(reqs)[-1]
        return "agspec serve", got.get("ok") is False and got["error"]["code"] == "bad_actions" \
            and f"/actions/{robot}" in got["error"]["message"]

    def trace_refuses(self, text: str) -> tuple[str, bool]:
        path = self.dir / "bad.trace.jsonl"
        lines = copy.deepcopy(self.trace_lines)
        robot = next(iter(lines[1]["actions"]))
        lines[1]["actions"][robot] = json.loads(text)
        path.write_text("\n".join(json.dumps(r) for r in lines) + "\n")
        _, diags = read_trace(path)
        return "trace", any(d.code.startswith("AG2") and d.line == 2 and d.pointer == f"/actions/{robot}"
                            for d in diags)

    def repro_refuses(self, text: str) -> tuple[str, bool]:
        robot = next(iter(self.repro["actions"][1]))
        ok = True
        for where in (("actions", 1, robot), ("history", "requests", 2, "actions", robot)):
            try:
                self._repro(_with_action(self.repro, where, text), "bad.json")
                ok = False
            except ReproError as exc:
                ok = ok and "/" + "/".join(map(str, where)) in str(exc)
        return "reproducer", ok

    def bundle_refuses(self, text: str) -> tuple[str, bool]:
        doc = json.loads(self.bundle_text)
        doc["episodes"][0]["index"] = json.loads(text)
        path = self.dir / "bad.json"
        path.write_text(json.dumps(doc))
        try:
            read_bundle(path)
        except BundleError as exc:
            return "bundle", "/episodes/0/index" in str(exc)
        return "bundle", False

    def process_refuses(self, text: str) -> tuple[str, bool]:
        got = run_job(Job(SCENARIO, 0, parse_policy(f"{sys.executable} {self.fakes}/policy_process.py {shlex.quote('as:' + text)}"),
                          short_instance(4)))
        err = got.get("error") or {}
        return "process policy", got.get("status") == "error" and err.get("code") == "bad_action" \
            and err.get("tick") == 0


RESPELT: list[Callable] = [Readers.joint_respelt, Readers.serve_respelt, Readers.trace_respelt,
                           Readers.repro_respelt, Readers.ir_respelt, Readers.bundle_respelt,
                           Readers.record_respelt]
REFUSES: list[Callable] = [Readers.joint_refuses, Readers.serve_refuses, Readers.trace_refuses,
                           Readers.repro_refuses, Readers.bundle_refuses]


_NAMES = {"record": "training record", "ir": "IR file", "joint": "check_joint", "serve": "agspec serve", "trace": "trace", "repro": "reproducer",
          "bundle": "bundle", "process": "process policy"}


def cases(readers: Readers, n: int, seed: int, process: bool = True) -> Iterator[tuple[str, str, bool]]:
    """``n`` respellings of every reader's documents and every non-action in every reader: (reader, case, ok)."""
    rng = random.Random(seed)
    for k in range(n):
        for fn in RESPELT:
            yield _tried(fn, readers, rng, f"respelt #{k}")
    if process:
        yield _tried(Readers.process_respelt, readers, rng, "respelt")
    for text in NOT_ACTIONS:
        for fn in REFUSES + ([Readers.process_refuses] if process else []):
            yield _tried(fn, readers, text, f"refuses {text}")


def _tried(fn: Callable, readers: Readers, arg: Any, label: str) -> tuple[str, str, bool]:
    """One case; an exception the reader should not raise is a wrong verdict, named in the label."""
    try:
        name, ok = fn(readers, arg)
    except Exception as exc:  # the reader's verdict was an exception it should not raise
        return _NAMES[fn.__name__.split("_")[0]], f"{label}: {type(exc).__name__}: {str(exc)[:80]}", False
    return name, label, ok


__all__ = ["Readers", "cases", "spelt", "NOT_ACTIONS"]
