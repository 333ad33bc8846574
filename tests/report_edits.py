"""Generators of the failure-report classes (F-EVENT-DIFF, F-CONFORM-KNOWN, RES-ASSERTION-LEVEL) and
their oracles, shared by tests/test_conform_reports.py (bounded) and benchmarks/fuzz_reports.py (long).

Each class has a hypothesis strategy of inputs and an oracle that returns what was misreported
(None: reported right).  The oracles read only what every build of agspec exposes (a divergence's
``expected``, ``actual``, ``pointer``, ``message``; a result's outcome), plus the newer fields when
present, so the long run can count violations of an older build too.

* **event edits** — one edit of a real reply's event list (from the suite's golden traces): an
  event dropped, inserted, two neighbours swapped, or a value field changed.  The divergence must
  name that edit: the dropped event as missing, the inserted one as extra, the swap as reordered,
  the changed field at its pointer — never a field of a neighbour.
* **known divergence** — the replies of the suite case where the reference loses a release for
  raw material and a simulator behaving like the original release releases it anyway
  (DIV-RELEASE-STOCK), compared over a drawn set of parts, with or without one further
  perturbation of the implementation's reply.  The failure is named iff nothing else differs.
* **assertion levels** — a suite case run against the reference declaring a drawn subset of the
  parts: every assertion on a declared part is evaluated and the case passes; only a case none of
  whose assertions is on a declared part is skipped.
"""

from __future__ import annotations

import contextlib
import copy
import json
from functools import lru_cache
from pathlib import Path
from typing import Any, Iterator

from hypothesis import strategies as st

ROOT = Path(__file__).resolve().parents[1]
TRACES = sorted((ROOT / "conformance" / "traces").glob("*.jsonl"))
# F-TRACE-EVENTS: the value fields of an event (the others say which event it is)
VALUE_FIELDS = ("end", "latency", "expires_at", "shelf_row", "action")
IDENTITY = ("type", "robot", "sender", "receiver", "candidate", "from", "to", "product", "item", "token",
            "activity", "operation", "reason", "cause", "kind")


def identity(ev: dict[str, Any]) -> str:
    return json.dumps([[k, ev[k]] for k in IDENTITY if k in ev], sort_keys=True)


@lru_cache(maxsize=1)
def event_lists() -> tuple[tuple[dict[str, Any], ...], ...]:
    """The event list of every header and tick record of the suite's traces (non-empty ones)."""
    out = []
    for path in TRACES:
        for line in path.read_text(encoding="utf-8").splitlines():
            rec = json.loads(line)
            if rec.get("type") in ("header", "tick") and rec.get("events"):
                out.append(tuple(rec["events"]))
    return tuple(out)


@lru_cache(maxsize=1)
def event_pool() -> tuple[dict[str, Any], ...]:
    return tuple(e for events in event_lists() for e in events)


# ============================================================================================ event edits


@st.composite
def event_edits(draw) -> tuple[list, list, tuple]:
    """(expected events, actual events, edit): one edit of a real event list."""
    events = [dict(e) for e in draw(st.sampled_from(event_lists()))]
    ids = [identity(e) for e in events]
    kinds = ["drop", "insert"]
    swaps = [k for k in range(len(events) - 1) if ids[k] != ids[k + 1]]
    changes = [(k, f) for k, e in enumerate(events) for f in VALUE_FIELDS
               if isinstance(e.get(f), int) and not isinstance(e.get(f), bool)]
    kinds += ["swap"] * bool(swaps) + ["change"] * bool(changes)
    kind = draw(st.sampled_from(kinds))
    if kind == "drop":
        k = draw(st.integers(0, len(events) - 1))
        return events, events[:k] + events[k + 1:], ("drop", k, events[k])
    if kind == "insert":  # an event of another reply, about something this list does not mention
        x = dict(draw(st.sampled_from([e for e in event_pool() if identity(e) not in ids][:400])))
        k = draw(st.integers(0, len(events)))
        return events, events[:k] + [x] + events[k:], ("insert", k, x)
    if kind == "swap":
        k = draw(st.sampled_from(swaps))
        actual = list(events)
        actual[k], actual[k + 1] = actual[k + 1], actual[k]
        return events, actual, ("swap", k, events[k])
    k, f = draw(st.sampled_from(changes))
    actual = copy.deepcopy(events)
    actual[k][f] += draw(st.integers(1, 5))
    return events, actual, ("change", k, f)


def misnamed_edit(edit: tuple, div: Any) -> str | None:
    """What the divergence of an edited event list gets wrong (None: it names the edit)."""
    from agspec.formats.pointer import MISSING

    kind = edit[0]
    if div is None or div.where != "events":
        return f"{kind}: no events divergence ({div})"
    rows = getattr(div, "events", None)
    if rows is not None:
        bad = [r for r in rows["rows"] if r["op"] != "same"]
        if len(bad) != 1:
            return f"{kind}: {len(bad)} differing events reported for one edit"
    if kind == "drop":
        ok = div.actual is MISSING and isinstance(div.expected, dict) and identity(div.expected) == identity(edit[2])
        return None if ok else f"drop of {edit[2]['type']} #{edit[1]} reported as {div.pointer}: " \
                                f"expected {div.expected!r}, actual {div.actual!r}"
    if kind == "insert":
        ok = div.expected is MISSING and div.actual == edit[2]
        return None if ok else f"insert of {edit[2]['type']} at #{edit[1]} reported as {div.pointer}: " \
                                f"expected {div.expected!r}, actual {div.actual!r}"
    if kind == "swap":
        ok = "reordered" in (div.message or "")
        return None if ok else f"swap of #{edit[1]} and #{edit[1] + 1} reported as {div.pointer} ({div.message!r})"
    ok = div.pointer == f"/{edit[1]}/{edit[2]}"
    return None if ok else f"change of #{edit[1]}/{edit[2]} reported as {div.pointer}"


# ====================================================================================== known divergence

STOCK_CASE = "raw-material availability"  # conformance/cases/release.yaml: a release lost for raw material


@contextlib.contextmanager
def releasing_despite_stock() -> Iterator[None]:
    """R-RELEASE as the original release has it (DIV-RELEASE-STOCK), for the ``with`` block only."""
    from agspec.interp import rules

    original = rules.release_product

    def release(state, model, events, forced=False):
        saved = [dict(shelf) for shelf in state.shelves]
        for shelf in state.shelves:
            for token in shelf:
                shelf[token] = max(1, shelf[token])
        try:
            original(state, model, events, forced)
        finally:
            for shelf, before in zip(state.shelves, saved):
                shelf.update(before)

    rules.release_product = release
    try:
        yield
    finally:
        rules.release_product = original


@lru_cache(maxsize=1)
def stock_replies() -> tuple[dict[str, Any], dict[str, Any]]:
    """(the reference's reply, the original-like reply) to the step where the reference loses the release."""
    from agspec.conform.cases import load_suite
    from agspec.conform.impl.serve import Server

    case = next(c for c in load_suite() if STOCK_CASE in c.title)

    def replies(patched: bool) -> list[dict[str, Any]]:
        server, out = Server(observations=False, masks=False), []
        with releasing_despite_stock() if patched else contextlib.nullcontext():
            server.handle({"cmd": "start", "seq": 1, "protocol": "agspec-protocol/1"})
            server.handle({"cmd": "load", "seq": 2, "instance": case.instance})
            out.append(server.handle({"cmd": "reset", "seq": 3, "execution_seed": case.execution_seed}))
            for k, joint in enumerate(case.actions):
                out.append(server.handle({"cmd": "step", "seq": 4 + k, "actions": joint}))
        return out

    expected, actual = replies(False), replies(True)
    k = next(i for i, r in enumerate(expected) if any(e.get("reason") == "raw_material" for e in r["events"]))
    return expected[k], actual[k]


def _leaves(doc: Any, pointer: str = "") -> Iterator[tuple[str, Any]]:
    if isinstance(doc, dict):
        for key in sorted(doc):
            yield from _leaves(doc[key], f"{pointer}/{key}")
    elif isinstance(doc, list):
        for i, x in enumerate(doc):
            yield from _leaves(x, f"{pointer}/{i}")
    else:
        yield pointer, doc


def _set(doc: Any, pointer: str, value: Any) -> None:
    tokens = pointer.split("/")[1:]
    for tok in tokens[:-1]:
        doc = doc[int(tok)] if isinstance(doc, list) else doc[tok]
    if isinstance(doc, list):
        doc[int(tokens[-1])] = value
    else:
        doc[tokens[-1]] = value


def _changed(value: Any) -> Any:
    if isinstance(value, bool):
        return not value
    if isinstance(value, (int, float)):
        return value + 1
    if isinstance(value, str):
        return value + "x"
    return 0


@st.composite
def stock_failures(draw) -> tuple[dict, dict, list[str], str | None]:
    """(expected reply, actual reply, parts compared, perturbation or None)."""
    from agspec.conform.lockstep.compare import behavioural

    expected, actual = copy.deepcopy(stock_replies()[0]), copy.deepcopy(stock_replies()[1])
    parts = draw(st.sampled_from([["t", "done", "state", "events"], ["t", "done", "state"], ["t", "done", "events"]]))
    kind = draw(st.sampled_from(["none", "state", "event"] if "state" in parts and "events" in parts else
                                ["none", "state" if "state" in parts else "event"]))
    if kind == "none":
        return expected, actual, parts, None
    if kind == "state":
        # any behavioural field the reference has too (the extra product is the divergence itself)
        leaves = [(p, v) for p, v in _leaves(behavioural(actual["state"])) if not p.startswith("/products/1")]
        pointer, value = draw(st.sampled_from(leaves))
        _set(actual["state"], pointer, _changed(value))
        return expected, actual, parts, f"state {pointer}"
    events = actual["events"]
    others = [k for k, e in enumerate(events) if e.get("type") != "release"]  # not the divergence's own event
    how = draw(st.sampled_from(["drop", "insert", "change"] if others else ["insert"]))
    if how == "insert":
        ids = {identity(e) for e in events}
        x = dict(draw(st.sampled_from([e for e in event_pool() if identity(e) not in ids][:200])))
        events.insert(draw(st.integers(0, len(events))), x)
        return expected, actual, parts, f"event inserted: {x['type']}"
    k = draw(st.sampled_from(others))
    if how == "drop":
        return expected, actual, parts, f"event dropped: {events.pop(k)['type']}"
    field = draw(st.sampled_from(sorted(f for f in events[k] if f != "type")))
    events[k][field] = _changed(events[k][field])
    return expected, actual, parts, f"event #{k} /{field} changed"


def misnamed_stock(expected: dict, actual: dict, parts: list[str], perturbation: str | None) -> str | None:
    """What the harness gets wrong naming the failure (None: named iff nothing else differs)."""
    from agspec.conform.lockstep.compare import compare_reply

    try:
        from agspec.conform.known import match
    except ImportError:  # a build that names no known divergence
        def match(*_args):
            return None
    div = compare_reply(1, expected, actual, parts)
    if div is None:
        return f"{perturbation}: no divergence found over {parts}"
    named = match(div, expected, actual, parts)
    if perturbation is None and (named is None or named["id"] != "DIV-RELEASE-STOCK"):
        return f"the DIV-RELEASE-STOCK failure over {'+'.join(parts)} is not named ({div.where} {div.pointer})"
    if perturbation is not None and named is not None:
        return f"named {named['id']} although {perturbation} over {'+'.join(parts)}"
    return None


# ======================================================================================= assertion levels

PARTS = ("state", "events", "observations", "masks")


@st.composite
def level_runs(draw) -> tuple[Any, frozenset[str]]:
    """(a suite case, the parts the simulator declares: state or events among them)."""
    from agspec.conform.cases import load_suite

    case = draw(st.sampled_from(_suite(load_suite)))
    parts = draw(st.sets(st.sampled_from(PARTS), min_size=1).filter(lambda s: "state" in s or "events" in s))
    return case, frozenset(parts)


_SUITE: list = []


def _suite(load) -> list:
    if not _SUITE:
        _SUITE.extend(c for c in load() if c.expectations)
    return _SUITE


def allowed_assertions(case: Any, parts: frozenset[str]) -> int:
    """The case's assertions a simulator declaring ``parts`` can be judged on (counted from the case
    file alone: state and absent pointers need the state, event patterns the events, observation
    pointers the observations — or, for a mask entry, the masks —, done nothing)."""
    n = 0
    for exp in case.expectations:
        if "state" in parts:
            n += len(exp.get("state", {})) + len(exp.get("absent", []))
        if "events" in parts:
            n += len(exp.get("events", [])) + len(exp.get("no_events", []))
        for pointer in exp.get("observations", {}):
            if "observations" in parts or ("masks" in parts and pointer.split("/")[2:3] == ["mask"]):
                n += 1
        n += "done" in exp
    return n


def misjudged_level(case: Any, parts: frozenset[str], result: Any) -> str | None:
    """What the harness gets wrong about an honest simulator at level ``parts`` (None: right)."""
    allowed = allowed_assertions(case, parts)
    label = f"{case.id} ({case.title[:40]}) at {'+'.join(sorted(parts))}"
    if allowed == 0:
        return None if result.outcome == "skip" else f"{label}: {result.outcome} although nothing it asserts is declared"
    if result.outcome != "pass":
        return f"{label}: {result.outcome} ({result.message}) although {allowed} assertion(s) can be checked"
    checked = getattr(result, "assertions_checked", None)
    if checked is not None and checked != allowed:
        return f"{label}: {checked} assertion(s) checked, {allowed} allowed"
    return None


def run_level(case: Any, parts: frozenset[str]) -> Any:
    """Run ``case`` against the reference declaring ``parts`` (tests/fakes/level_adapter.py)."""
    import sys

    from agspec.conform.impl import PythonImpl
    from agspec.conform.items import from_case
    from agspec.conform.run_item import Options, run_item

    sys.path.insert(0, str(ROOT / "tests" / "fakes"))
    from level_adapter import Declares

    impl = PythonImpl(lambda: Declares(parts), spec="python:level_adapter")
    try:
        return run_item(from_case(case), impl, Options())
    finally:
        impl.close()
