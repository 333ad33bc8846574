"""Golden reference traces (F-GOLDEN, RES-GOLDEN-IDENTITY): reused, never trusted blindly, and never
changing a verdict.

The proof is twofold: every seeded mutant of tests/mutants gets, with a warm golden cache, exactly
the report record it gets live (a golden trace cannot hide a failure or invent one), and an honest
implementation — the reference in process and ``agspec serve`` over the protocol — passes from the
golden trace with the live run's counts.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

from agspec.conform import golden, runner
from agspec.conform.impl import SubprocessImpl, make_impl
from agspec.conform.items import Item
from agspec.conform.run_item import Options
from agspec.formats import golden as fmt
from agspec.formats import jsonl, schemas

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "mutants"))
sys.path.insert(0, str(HERE))

import mutant_registry as registry  # noqa: E402  (tests/mutants/mutant_registry.py)
from test_mutants import sim_spec, timeout_for, workload_item  # noqa: E402

SERVE = f"{sys.executable} -m agspec.cli.main serve"


def episode(scenario: str = "coalition-medium", ticks: int = 25, controller: str = "greedy", seed: int = 0) -> Item:
    from agspec.catalogue import load_scenario_bundle
    from agspec.ir.instance import make_instance

    inst = make_instance(*load_scenario_bundle(scenario), index=0)
    return Item(id=f"e-{scenario}-{controller}", kind="episode", title=scenario, instance=inst,
                execution_seed=inst["seeds"]["execution"], ticks=ticks,
                controller={"name": controller, "seed": seed}, location=f"catalogue:{scenario}:0")


def run(items, spec: str, cache: Path | None, timeout: float = 15.0) -> runner.Summary:
    opts = Options(impl_spec=spec, golden_dir=str(cache) if cache else None)
    return runner.run(items, spec, timeout=timeout, opts=opts)


def stable(record: dict) -> dict:
    """A report record without what legitimately differs between a live and a golden run."""
    out = json.loads(json.dumps(record))
    out.pop("duration_s", None)
    out.get("checks", {}).pop("reference", None)
    return out


def golden_files(cache: Path) -> list[Path]:
    return sorted(cache.glob("*/*.json"))


# --------------------------------------------------------------------------- honest implementations


@pytest.mark.parametrize("spec", ["reference", SERVE])
def test_honest_implementation_passes_from_the_golden_trace_with_the_live_counts(tmp_path, spec):
    items = [episode("coalition-medium", 25), episode("flow-easy", 20, "random", 1)]
    live = run(items, spec, None)
    cold = run(items, spec, tmp_path)  # records
    assert len(golden_files(tmp_path)) == 2
    warm = run(items, spec, tmp_path)
    assert [r.reference for r, _ in live.results] == ["live", "live"]
    assert [r.reference for r, _ in cold.results] == ["live", "live"]
    assert [r.reference for r, _ in warm.results] == ["golden", "golden"]
    assert warm.golden == 2 and warm.exit_code == 0 and warm.footer()["golden_items"] == 2
    for (a, _), (b, _) in zip(live.results, warm.results):
        assert stable(a.record()) == stable(b.record())
        assert a.event_types == b.event_types and a.invariant_checks > 0
    assert {k: v for k, v in live.footer().items() if k not in ("duration_s", "golden_items")} == \
           {k: v for k, v in warm.footer().items() if k not in ("duration_s", "golden_items")}


def test_suite_cases_pass_from_golden_traces_with_their_expectations_counted(tmp_path):
    from agspec.conform.cases import load_suite
    from agspec.conform.items import from_case

    items = [from_case(c) for c in load_suite()]  # every case: scripts with out-of-range actions too
    live = run(items, "reference", None)
    run(items, "reference", tmp_path)
    warm = run(items, "reference", tmp_path)
    assert warm.golden == len(items) and live.expectations > 0
    for (a, oa), (b, ob) in zip(live.results, warm.results):
        assert oa == ob == "pass"
        assert stable(a.record()) == stable(b.record())


def test_golden_file_validates_and_is_keyed_by_everything_the_reference_depends_on(tmp_path):
    item = episode("flow-easy", 12)
    run([item], "reference", tmp_path)
    (path,) = golden_files(tmp_path)
    data = json.loads(path.read_text())
    assert schemas.validate("golden", data) == []
    assert len(data["replies"]) == 13 * 64 and len(data["actions"]) == 12
    assert path == golden.path_of(tmp_path, golden.key(item))
    variants = [episode("flow-easy", 13), episode("flow-easy", 12, seed=3), episode("flow-easy", 12, "random"),
                episode("flow-medium", 12)]
    keys = {json.dumps(golden.key(v), sort_keys=True) for v in variants} | {json.dumps(golden.key(item), sort_keys=True)}
    assert len(keys) == 5
    other_seed = Item(**{**item.__dict__, "execution_seed": (item.execution_seed or 0) + 1})
    assert golden.key(other_seed) != golden.key(item)


def test_a_damaged_golden_file_is_ignored_and_replaced(tmp_path):
    item = episode("flow-easy", 12)
    run([item], "reference", tmp_path)
    (path,) = golden_files(tmp_path)
    good = path.read_text()
    path.write_text(good.replace('"actions":[', '"actions":[{"0,0":1},', 1))  # content changed, digest stale
    with pytest.raises(fmt.GoldenError, match="digest"):
        fmt.load(path, golden.key(item))
    again = run([item], "reference", tmp_path)
    assert again.results[0][0].reference == "live" and again.exit_code == 0
    fmt.load(path, golden.key(item))  # rewritten by the live run: verifies again
    assert run([item], "reference", tmp_path).results[0][0].reference == "golden"


def test_a_wrong_golden_trace_with_a_valid_digest_cannot_fail_an_honest_implementation(tmp_path):
    """A golden trace only ever lets a run skip work: a reply that does not match sends the item live."""
    item = episode("coalition-medium", 15)
    run([item], "reference", tmp_path)
    (path,) = golden_files(tmp_path)
    data = json.loads(path.read_text())
    body = {k: v for k, v in data.items() if k != "digest"}
    body["replies"] = body["replies"][:7 * 64] + "0" * 64 + body["replies"][8 * 64:]  # reply 7's digests
    path.write_text(json.dumps({**body, "digest": fmt._digest(body)}))
    fmt.load(path, golden.key(item))  # a consistent file: it verifies
    result = run([item], "reference", tmp_path).results[0][0]
    assert result.outcome == "pass" and result.reference == "live"


GOLDEN_DAMAGES = {
    "an action that is a string": lambda d: d["actions"][3].update({"0,0": "1"}),
    "an action that is a boolean": lambda d: d["actions"][0].update({"0,0": True}),
    "an action that is a fraction": lambda d: d["actions"][5].update({"0,0": 1.5}),
    "a joint action that is a list": lambda d: d["actions"].__setitem__(2, [1, 2]),
    "actions that are an object": lambda d: d.__setitem__("actions", {"0": {}}),
    "a negative count": lambda d: d["summary"]["invariant_checks_by_reply"].__setitem__(4, -1),
    "a count that is a string": lambda d: d["summary"]["expectations_by_reply"].__setitem__(1, "0"),
    "counts missing": lambda d: d["summary"].pop("expectations_by_reply"),
    "a summary that is a list": lambda d: d.__setitem__("summary", []),
    "a short digest string": lambda d: d.__setitem__("replies", d["replies"][:-1]),
    "an unknown member": lambda d: d.__setitem__("extra", 1),
    "a key without its policy": lambda d: d["key"].pop("policy"),
}


@pytest.mark.parametrize("damage", sorted(GOLDEN_DAMAGES))
def test_a_golden_file_against_its_schema_is_refused_with_the_schema_s_first_problem(tmp_path, damage):
    """The golden file's schema check passes the long arrays in one plain pass (formats.golden): every
    document the schema refuses is still refused, with the problem the whole schema names first."""
    item = episode("flow-easy", 12)
    run([item], "reference", tmp_path)
    (path,) = golden_files(tmp_path)
    data = json.loads(path.read_text())
    body = {k: v for k, v in data.items() if k != "digest"}
    GOLDEN_DAMAGES[damage](body)
    doc = {**body, "digest": fmt._digest(body)}
    path.write_text(json.dumps(doc))
    (problem,) = schemas.validate("golden", doc, limit=1)
    with pytest.raises(fmt.GoldenError) as raised:
        fmt.load(path, body["key"])  # the key it holds: the schema decides
    assert str(raised.value).endswith(f"not a valid golden trace: {problem}")


def test_a_golden_file_the_schema_accepts_is_accepted_in_any_spelling_it_accepts(tmp_path):
    """An integral float is an integer to the schema (F-VALUES): the plain pass leaves it to the schema,
    which accepts it — no document the schema accepts is refused."""
    item = episode("flow-easy", 12)
    run([item], "reference", tmp_path)
    (path,) = golden_files(tmp_path)
    body = {k: v for k, v in json.loads(path.read_text()).items() if k != "digest"}
    body["actions"][0]["0,0"] = 1.0
    body["summary"]["invariant_checks_by_reply"][0] = 0.0
    doc = {**body, "digest": fmt._digest(body)}
    assert schemas.validate("golden", doc) == []
    path.write_text(json.dumps(doc))
    assert fmt.load(path, golden.key(item)).actions[0]["0,0"] == 1.0


def test_the_golden_schema_says_of_the_long_arrays_only_what_the_plain_pass_checks():
    """formats.golden checks `actions` and the per-reply counts without the validator when every entry is
    a plain integer (or an object of them); that is sound only while the schema asks nothing more of
    those arrays than what each entry is."""
    schema = schemas.inlined("golden")
    actions = {k: v for k, v in schema["properties"]["actions"].items() if k != "description"}
    assert actions == {"type": "array", "items": {"type": "object", "additionalProperties": {"type": "integer"}}}
    summary = schema["properties"]["summary"]["properties"]
    for name in fmt.BY_REPLY:
        assert summary[name] == {"type": "array", "items": {"type": "integer", "minimum": 0}}
    assert set(schema) <= {"$schema", "$id", "title", "description", "type", "additionalProperties", "required",
                           "properties"}
    assert set(schema["properties"]["summary"]) == {"type", "required", "additionalProperties", "properties"}


def test_without_the_fast_encoder_golden_traces_are_recorded_and_matched_with_json(tmp_path, monkeypatch):
    item = episode("coalition-medium", 15)
    run([item], "reference", tmp_path)  # with orjson
    monkeypatch.setattr(jsonl, "orjson", None)
    assert golden.key(item)["dependencies"]["encoder"] == "json"  # float spellings differ: another key
    first = run([item], "reference", tmp_path).results[0][0]
    second = run([item], "reference", tmp_path).results[0][0]
    assert (first.reference, second.reference) == ("live", "golden") and second.outcome == "pass"
    assert len(golden_files(tmp_path)) == 2


def compact_line(value) -> str:
    return jsonl.compact_bytes(value).decode("utf-8")


def test_line_digest_is_the_text_digest_of_the_reply_the_server_sent():
    reply = {"seq": 7, "ok": True, "t": 3, "state": {"x": [1, 2.5, None, True]}, "done": False}
    line = compact_line(reply)
    assert fmt.line_digest(line, 7) == fmt.text_digest(reply)
    assert fmt.line_digest(line, 8) is None  # another request's reply
    assert fmt.line_digest(compact_line({"ok": True, "seq": 7}), 7) is None  # seq not first: decode it
    assert fmt.value_digest({**reply, "state": {"x": [1, 2.5, None, 1]}}) != fmt.value_digest(reply)  # True is not 1
    assert fmt.value_digest({**reply, "t": 3.0}) != fmt.value_digest(reply)
    shuffled = {"done": False, "state": {"x": [1, 2.5, None, True]}, "t": 3, "ok": True, "seq": 9}
    assert fmt.value_digest(shuffled) == fmt.value_digest(reply)  # a simulator's own key order matches
    with pytest.raises(jsonl.NonFinite):  # a reply with NaN never reaches a digest: the decoder refuses it
        jsonl.loads('{"seq":7,"ok":true,"t":NaN}')


def test_conform_cli_reports_golden_items(tmp_path):
    cmd = [sys.executable, "-m", "agspec.cli.main", "conform", "--impl", "reference", "--no-suite", "--episodes", "1",
           "--horizon", "10", "-k", "e-flow-easy-*", "--format", "json", "--golden-cache", str(tmp_path)]
    first = json.loads(subprocess.run(cmd, capture_output=True, text=True, check=True).stdout)
    second = json.loads(subprocess.run(cmd, capture_output=True, text=True, check=True).stdout)
    assert first["footer"]["golden_items"] == 0 and second["footer"]["golden_items"] == 1
    assert second["results"][0]["checks"]["reference"] == "golden"
    assert stable(first["results"][0]) == stable(second["results"][0])
    off = subprocess.run([*cmd[:-2], "--golden-cache", "off"], capture_output=True, text=True, check=True)
    assert json.loads(off.stdout)["footer"]["golden_items"] == 0
    # F-GOLDEN: where the cache is (null: off)
    assert second["golden_cache"] == str(tmp_path) and json.loads(off.stdout)["golden_cache"] is None
    problems = [p for line in (second["header"], *second["results"], second["footer"])
                for p in schemas.validate("report", line, limit=1)]
    assert problems == []


# --------------------------------------------------------------------------- every mutant, live and golden

# the hard-coding mutants' workload is the whole default run (test_mutants drives them through it);
# the golden-versus-live identity is checked here on the mutants with one workload item each
MUTANTS = [m for m in registry.MUTANTS.values()
           if "nondeterministic" not in m.ids and m.workload.instance != registry.DEFAULT_RUN]


def matched_prefix(m: registry.Mutant, item: Item, cache: Path) -> int | str:
    """How many replies of the mutant had the golden digest before the first that did not."""
    recorded = golden.lookup(cache, item)
    impl = make_impl(sim_spec(m.name), timeout=timeout_for(m))
    try:
        impl.start()
        if not golden.eligible(item, impl, None):
            return "ineligible"
        try:
            at = golden.replay(item, impl, recorded)
        except Exception as exc:  # the mutant failed a request: the replay itself reported it
            return getattr(exc, "failure_tick", -1) + 1
        return len(recorded.replies) if at is None else at[0]
    finally:
        impl.close()


@pytest.fixture(scope="module")
def mutant_pairs(tmp_path_factory) -> dict[str, tuple]:
    cache = tmp_path_factory.mktemp("golden")

    def one(m: registry.Mutant) -> tuple:
        item = workload_item(m)
        warm = run([item], "reference", cache)  # records the golden trace of the workload
        spec = sim_spec(m.name)
        live = run([item], spec, None, timeout_for(m))
        gold = run([item], spec, cache, timeout_for(m))
        return warm.results[0][0], live, gold, matched_prefix(m, item, cache)

    with ThreadPoolExecutor(max_workers=2) as pool:
        return dict(zip([m.name for m in MUTANTS], pool.map(one, MUTANTS)))


@pytest.mark.parametrize("name", [m.name for m in MUTANTS])
def test_every_mutant_gets_the_live_verdict_from_a_warm_golden_cache(name, mutant_pairs):
    reference, live, gold, prefix = mutant_pairs[name]
    assert reference.outcome == "pass"
    assert prefix == "ineligible" or prefix < reference.ticks + 1  # no mutant matches the whole golden trace
    (a, oa), (b, ob) = live.results[0], gold.results[0]
    assert oa == ob != "pass" or registry.MUTANTS[name].outcome == "level"
    assert live.exit_code == gold.exit_code
    ra, rb = stable(a.record(oa)), stable(b.record(ob))
    for r in (ra, rb):  # the simulator's stderr and timings are not part of the verdict
        (r.get("failure") or {}).pop("stderr", None)
    assert ra == rb


def test_the_golden_path_is_exercised_by_the_mutants(mutant_pairs):
    """Most mutants match the golden trace for some replies before their bug shows: the comparison of
    verdicts above covers the replay, not only the live fallback."""
    prefixes = [p for *_, p in mutant_pairs.values() if p != "ineligible"]
    assert sum(1 for p in prefixes if p >= 1) >= 15


def test_a_failing_implementation_is_not_run_twice_through_the_matching_prefix(tmp_path):
    """After the replay stops at the first differing reply (tick 42 here), the live run goes on from
    there (golden.Resumed): the implementation receives the requests of a live run plus at most the
    few the pipeline had in flight — never the matching prefix a second time."""
    item = episode("flow-easy", 60)
    spec = sim_spec("wip-drift")
    run([item], "reference", tmp_path)
    seqs, ticks = {}, {}
    for label, cache in (("live", None), ("golden", tmp_path)):
        impl = make_impl(spec, timeout=15.0)
        try:
            summary = runner.run([item], spec, opts=Options(impl_spec=spec, golden_dir=cache and str(cache)), impl=impl)
            result, outcome = summary.results[0]
            assert outcome == "fail"
            seqs[label], ticks[label] = impl._seq, result.failure["tick"]
        finally:
            impl.close()
    assert ticks["golden"] == ticks["live"] >= 20
    # the item runs twice (F-CONFORM-NONDETERMINISM replays the first failure): twice the slack
    assert seqs["live"] <= seqs["golden"] <= seqs["live"] + 2 * (SubprocessImpl.PIPELINE - 1)


@pytest.mark.parametrize("trace", sorted((HERE.parent / "conformance" / "traces").glob("*.jsonl")), ids=lambda p: p.stem)
def test_only_the_remembering_invariants_keep_memory_across_records(trace):
    """A resumed run skips every check of the known prefix but runs invariants.REMEMBERING on it: that
    is sound only if no other invariant keeps memory across records — and those listed do."""
    from agspec import invariants

    records = [r for r in invariants.read_trace(trace) if r.get("type") in ("header", "tick")]
    ctx = invariants.Context.from_instance(records[0]["instance"])

    def memory():
        return (dict(ctx.lifetime), set(ctx.lifetime_gone), dict(ctx.gone_items))

    changed = set()
    for prev, rec in zip([None, *records[:-1]], records):
        for inv_id, fn in invariants.INVARIANTS:
            before = memory()
            fn(ctx, prev, rec)
            if memory() != before:
                changed.add(inv_id)
    assert changed <= set(invariants.REMEMBERING)
    if "s00-greedy" in trace.stem:  # a long enough episode: every remembering invariant remembers
        assert changed == set(invariants.REMEMBERING)


def test_conform_table_says_where_the_golden_cache_is_and_how_to_move_or_clear_it(tmp_path):
    """F-GOLDEN: one line of the table output names the directory (the default one too), how to move it
    and how to clear it; with the cache off it says so."""
    base = [sys.executable, "-m", "agspec.cli.main", "conform", "--impl", "reference", "--no-suite", "--episodes", "1",
            "--horizon", "5", "-k", "e-flow-easy-*"]
    env = {k: v for k, v in os.environ.items() if k not in ("AGSPEC_GOLDEN_CACHE", "XDG_CACHE_HOME")}
    env["XDG_CACHE_HOME"] = str(tmp_path / "xdg")
    default = subprocess.run(base, capture_output=True, text=True, check=True, env=env).stdout
    where = tmp_path / "xdg" / "agspec" / "golden"
    line = next(ln for ln in default.splitlines() if ln.startswith("golden cache: "))
    assert str(where) in line and "--golden-cache DIR" in line and "delete the directory" in line
    assert where.is_dir()
    named = subprocess.run([*base, "--golden-cache", str(tmp_path / "g")], capture_output=True, text=True, check=True,
                           env=env).stdout
    assert f"golden cache: {tmp_path / 'g'} (" in named
    off = subprocess.run([*base, "--golden-cache", "off"], capture_output=True, text=True, check=True, env=env).stdout
    assert "golden cache: off" in off
