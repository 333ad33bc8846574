"""Proof that the harness can fail: seeded mutant simulators must all be caught (F-CONFORM).

Every mutant of tests/mutants/mutant_registry.py runs as a subprocess simulator
(``python tests/mutants/sim.py --mutant NAME``) through the conformance runner
(agspec.conform.runner.run — what ``agspec conform`` uses) on its small workload, and must be
reported with the right outcome class (``fail`` vs ``error``) and the right identification: an
invariant ID the harness reports, the JSON Pointer prefix of the first divergence, or the protocol
error kind/code.  The mutation score is printed and must be 100 %.  The same adapter without a
mutant must pass the whole conformance suite and lockstep catalogue episodes.
"""

from __future__ import annotations

import fnmatch
import functools
import json
import os
import shlex
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

from agspec.conform import runner
from agspec.conform.items import Item, catalogue_episodes, from_case

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "mutants"))

import mutant_registry as registry  # noqa: E402  (tests/mutants/mutant_registry.py)

SIM = HERE / "mutants" / "sim.py"
TIMEOUT = 1.0  # --timeout of the hang mutant: it costs one second
PATIENT = 15.0  # every other mutant: a loaded machine must not turn a slow reply into a timeout


def timeout_for(m: registry.Mutant) -> float:
    return TIMEOUT if "timeout" in m.ids else PATIENT


def sim_spec(mutant: str | None = None) -> str:
    return shlex.join([sys.executable, str(SIM)] + (["--mutant", mutant] if mutant else []))


def workload_item(m: registry.Mutant) -> Item:
    w = m.workload
    if w.path() is not None:
        inst = json.loads(w.path().read_text(encoding="utf-8"))
    else:
        from agspec.catalogue import load_scenario_bundle
        from agspec.ir.instance import make_instance

        _, scenario, index = w.instance.split(":")
        sc, recipes, profile = load_scenario_bundle(scenario)
        inst = make_instance(sc, recipes, profile, index=int(index))
    return Item(id=f"mutant-{m.name}", kind="episode", title=f"{m.name} on {inst['id']} ({w.controller})",
                instance=inst, execution_seed=inst["seeds"]["execution"], ticks=w.ticks,
                controller={"name": w.controller, "seed": w.seed}, tags=("mutant",), location=w.instance)


@functools.lru_cache(maxsize=1)
def default_run() -> tuple[Item, ...]:
    """The items of `agspec conform --impl SIM` with its default options (suite cases, catalogue episodes)."""
    from agspec.conform.cases import load_suite
    from agspec.conform.items import default_run as items

    return tuple(items(load_suite()))


def workload_items(m: registry.Mutant) -> list[Item]:
    """A hard-coding mutant (``reads``): the items of the default run whose instance it changes — on every
    other item it is the reference itself, so the default run fails it iff these fail it."""
    if m.workload.instance != registry.DEFAULT_RUN:
        return [workload_item(m)]
    return [it for it in default_run() if m.reads(it.instance) != it.instance]


def reported_ids(failure: dict | None) -> list[str]:
    """Everything the harness reported that identifies a failure."""
    if not failure:
        return []
    out: list[str] = []
    kind = failure.get("type")
    if kind in ("crash", "timeout", "protocol"):
        out += [kind, f"{kind}/{failure.get('code')}"]
    if failure.get("path"):
        out.append(failure["path"])
    out += list(failure.get("ids") or [])
    return out


def matches(pattern: str, ident: str) -> bool:
    """An invariant ID or error kind matches exactly; a pointer pattern matches a prefix of the reported
    pointer, token by token, ``*`` standing for one token."""
    if not pattern.startswith("/"):
        return pattern == ident
    if not ident.startswith("/"):
        return False
    want, got = pattern.split("/")[1:], ident.split("/")[1:]
    return len(got) >= len(want) and all(fnmatch.fnmatchcase(g, w) for w, g in zip(want, got))


# F-EXIT-CODES of each outcome class: "level" = proved less than --require; a nondeterministic fail is 5
WANT_EXIT = {"fail": 1, "error": 3, "level": 1}


def want_exit(m: registry.Mutant) -> int:
    return runner.EXIT_NONDETERMINISTIC if "nondeterministic" in m.ids else WANT_EXIT[m.outcome]


def run_mutant(m: registry.Mutant) -> dict:
    start = time.perf_counter()
    # a level mutant must fail `--require` of the level it only pretends to reach (F-CONFORM-LEVELS)
    require = tuple(i.split(":", 1)[1] for i in m.ids if i.startswith("level:"))
    items = workload_items(m)
    summary = runner.run(items, sim_spec(m.name), timeout=timeout_for(m), require=require, max_fail=1)
    if not summary.results:
        return {"name": m.name, "breaks": m.breaks, "want": m.outcome, "outcome": "none", "ids": [], "hit": None,
                "killed": False, "exit": summary.exit_code, "tick": None, "seconds": time.perf_counter() - start,
                "message": "no item of the default run has an instance the mutant reads differently", "item": None}
    result, outcome = next(((r, o) for r, o in summary.results if o != "pass"), summary.results[0])
    ids = reported_ids(result.failure) + [f"level:{p}" for p in summary.missing]
    if summary.nondeterministic is not None:
        ids.append("nondeterministic")
    if summary.missing and outcome == "pass":
        outcome = "level"
    hit = next((i for p in m.ids for i in ids if matches(p, i)), None)
    return {"name": m.name, "breaks": m.breaks, "want": m.outcome, "outcome": outcome, "ids": ids, "hit": hit,
            "killed": outcome == m.outcome and hit is not None and summary.exit_code == want_exit(m),
            "exit": summary.exit_code,
            "tick": (result.failure or {}).get("tick"), "seconds": time.perf_counter() - start,
            "message": result.message, "item": result.item.id}


@pytest.fixture(scope="module")
def mutant_results(tmp_path_factory) -> dict[str, dict]:
    # the nondeterministic mutant's first process (and only that one) diverges: a coin of this run
    os.environ[registry.COIN_ENV] = str(tmp_path_factory.mktemp("coin"))
    with ThreadPoolExecutor(max_workers=2) as pool:  # -j 2 across mutants
        rows = list(pool.map(run_mutant, registry.MUTANTS.values()))
    return {row["name"]: row for row in rows}


def test_enough_mutants():
    assert len(registry.MUTANTS) >= 17
    assert {m.outcome for m in registry.MUTANTS.values()} == {"fail", "error", "level"}


@pytest.mark.parametrize("name", list(registry.MUTANTS))
def test_mutant_is_killed(name, mutant_results):
    row = mutant_results[name]
    m = registry.MUTANTS[name]
    assert row["outcome"] == m.outcome, f"{name}: outcome {row['outcome']} ({row['message']}), want {m.outcome}"
    assert row["hit"] is not None, f"{name}: reported {row['ids']}, none matches {m.ids}"
    assert row["exit"] == want_exit(m)  # F-EXIT-CODES


# --------------------------------------------------------------------------- through the CLI


CLI_MUTANTS = [m.name for m in registry.MUTANTS.values() if m.workload.instance == "catalogue:flow-easy:0"]


@pytest.mark.parametrize("name", CLI_MUTANTS)
def test_mutant_through_agspec_conform(name, tmp_path):
    """`agspec conform --impl "python tests/mutants/sim.py --mutant NAME"` on the flow-easy catalogue episode:
    the categorical exit code, the outcome class and the identification in the JSON report."""
    from click.testing import CliRunner

    from agspec.cli.main import cli

    m = registry.MUTANTS[name]
    args = ["conform", "--impl", sim_spec(name), "--no-suite", "--episodes", "1", "--horizon", str(m.workload.ticks),
            "-k", "e-flow-easy-greedy", "--timeout", str(timeout_for(m)), "--format", "json", "--repro-dir",
            str(tmp_path)]
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == want_exit(m), result.output
    report = json.loads(result.stdout)
    (record,) = report["results"]
    assert record["outcome"] == m.outcome
    ids = reported_ids(record["failure"])
    assert any(matches(p, i) for p in m.ids for i in ids), ids
    assert report["footer"]["states_compared"] >= 1  # not vacuous


# --------------------------------------------------------------------------- the invariant checker alone


def own_trace(m: registry.Mutant) -> list[dict]:
    """The mutant's own F-TRACE records, its controller acting on its own observations — no reference
    anywhere (the offline mode: a simulator writes a trace, ``agspec check`` validates it)."""
    from agspec.conform.impl import make_impl
    from agspec.controllers import make_controller

    item = workload_item(m)
    impl = make_impl(sim_spec(m.name), timeout=timeout_for(m))
    try:
        impl.start()
        impl.load(item.instance)
        reply = impl.reset(item.execution_seed)
        records = [{"type": "header", "instance": item.instance, "execution_seed": item.execution_seed,
                    "state": reply["state"], "events": reply["events"]}]
        ctl = make_controller(item.controller["name"], item.controller["seed"])
        ctl.reset(item.controller["seed"])
        obs = reply["observations"]
        for t in range(item.ticks):
            try:
                chosen = {r: int(a) for r, a in ctl.act(obs).items() if int(a)}
            except Exception:  # a controller confused by a malformed observation idles
                chosen = {}
            reply = impl.step(chosen)
            records.append({"type": "tick", "t": t, "actions": reply.get("applied", chosen), "chosen": chosen,
                            "events": reply["events"], "state": reply["state"], "observations": obs})
            obs = reply["observations"]
            if reply["done"]:
                break
        records.append({"type": "footer", "ticks": len(records) - 1, "complete": True, "metrics": {}})
        return records
    finally:
        impl.close()


@pytest.fixture(scope="module")
def invariant_results() -> dict[str, list[str]]:
    from agspec.invariants import check_trace

    out = {}
    for m in registry.MUTANTS.values():
        if m.outcome == "fail" and m.invariant:
            out[m.name] = sorted({v.invariant for v in check_trace(own_trace(m)).violations})
    return out


@pytest.mark.parametrize("name", [m.name for m in registry.MUTANTS.values() if m.invariant])
def test_invariant_checker_alone_catches_invariant_mutants(name, invariant_results):
    """Mutants that break an invariant are caught by `agspec check` on their own trace, no reference needed."""
    assert registry.MUTANTS[name].invariant in invariant_results[name], invariant_results[name]


def test_mutation_score(mutant_results, invariant_results, capsys):
    rows = list(mutant_results.values())
    killed = sum(r["killed"] for r in rows)
    lines = ["", f"{'mutant':<29} {'breaks':<37} {'outcome':<7} {'tick':>4}  {'identified by (conform)':<32} "
                 "invariants alone (own trace)", "-" * 132]
    for r in rows:
        mark = "" if r["killed"] else "  SURVIVED"
        alone = ", ".join(invariant_results.get(r["name"], [])) or ("-" if r["want"] == "fail" else "n/a")
        lines.append(f"{r['name']:<29} {r['breaks']:<37} {r['outcome']:<7} {str(r['tick']):>4}  "
                     f"{str(r['hit'] or r['ids']):<32} {alone}{mark}")
    lines.append("-" * 132)
    lines.append(f"mutation score: {killed}/{len(rows)} = {100.0 * killed / len(rows):.0f} % "
                 f"(outcome class and identification both right)")
    with capsys.disabled():
        print("\n".join(lines))
    assert killed == len(rows)


# --------------------------------------------------------------------------- the adapter without a mutant


def test_unmutated_adapter_passes_the_suite_and_episodes():
    """tests/mutants/sim.py (no mutant) is conformant: every case of the suite and a lockstep episode per
    official scenario (greedy), compared state by state with the reference."""
    from agspec.conform.cases import load_suite

    cases = load_suite()
    items = [from_case(c) for c in cases] + catalogue_episodes(1, 12)
    summary = runner.run(items, sim_spec(), timeout=10.0, jobs=2)
    bad = [(r.item.id, r.item.title, outcome, r.message) for r, outcome in summary.results if outcome != "pass"]
    assert bad == []
    assert summary.exit_code == 0 and not summary.vacuous
    assert summary.counts["pass"] == len(items) and len(cases) > 0
    assert summary.states >= len(items)


def test_workloads_pass_without_the_mutant():
    """No false alarm: every mutant's workload passes on the unmutated adapter, so a kill is the mutant's doing.
    (Suite cases of the default-run workloads are left to test_unmutated_adapter_passes_the_suite_and_episodes,
    which runs every case on the same adapter.)"""
    items = [it for m in registry.MUTANTS.values() for it in workload_items(m) if it.kind != "case"]
    unique = list({it.id: it for it in items}.values())
    summary = runner.run(unique, sim_spec(), timeout=10.0)
    assert [(r.item.id, o, r.message) for r, o in summary.results if o != "pass"] == []
    assert summary.exit_code == 0


def test_topology_cases_fail_a_simulator_that_ignores_the_topology():
    """The suite's topology cases judge the relation, not the grid: every case off the official Moore
    radius 1 fails the topology-ignored mutant (D-TOPOLOGY, O-MASK, O-OBSERVATION, R-CANDIDATES),
    and the Moore radius-1 case, where that mutant behaves like the reference, passes."""
    from agspec.conform.cases import load_suite

    cases = [c for c in load_suite() if "topology" in c.tags]
    grids = {c.id: c.instance["scenario"]["grid"] for c in cases}
    assert {(g["topology"], g["radius"]) for g in grids.values()} == {(t, r) for t in ("moore", "von_neumann", "line")
                                                                      for r in (1, 2)}
    summary = runner.run([from_case(c) for c in cases], sim_spec("topology-ignored"), timeout=PATIENT)
    outcomes = {r.item.id: outcome for r, outcome in summary.results}
    for case in cases:
        official = (grids[case.id]["topology"], grids[case.id]["radius"]) == ("moore", 1)
        assert outcomes[case.id] == ("pass" if official else "fail"), (case.title, outcomes[case.id])


def test_mutant_instances_are_current():
    import make_instances  # tests/mutants/make_instances.py

    assert make_instances.main(["--check"]) == 0, "run python tests/mutants/make_instances.py"


def test_unknown_mutant_is_a_usage_error():
    import subprocess

    proc = subprocess.run([sys.executable, str(SIM), "--mutant", "no-such-bug"], capture_output=True, text=True,
                          timeout=30)
    assert proc.returncode == 2 and "unknown mutant" in proc.stderr
