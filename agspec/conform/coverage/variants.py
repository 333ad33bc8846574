"""The variant space of F-CONFORM-COVERAGE: does some item make a simulator *read* every option?

Citing a rule is not enough, and neither is running an instance with a non-official value: a
simulator that hard-codes the official value must *fail* some item of the default run.  An
**entry** is one value of one option (a profile parameter, an S-RULE-VARIANTS switch, a
coordination constant, a resource class, the batch mode, a D-TOPOLOGY relation under one topology
and radius, a reason of ``release_lost``).  An item covers an entry when

* its instance has that value (:func:`applies`), and
* the reference run of the item on the **counterfactual** instance — the same instance with the
  value a hard-coding simulator would read instead (:func:`counterfactual`), driven by the same
  joint actions — gives a reply that differs from the reference's (the comparison of
  ``agspec conform`` catches that simulator: :func:`agspec.conform.lockstep.driver.compare_replies`).

For a suite case the entry is also **asserted** when the case's own expectations fail on the
counterfactual run (a tool that checks only a case's expectations catches it too).  A D-TOPOLOGY
entry counts only the parts of a reply its relation decides, on replies whose states still agree
(``G_obs``: the observations' neighbour lists; ``G_handoff``: the handoff and receive bits of the
masks and ``handoff_started`` events; ``G_manip``: the operation options, the operation bits of the
masks and the admissions).  Two entries need no counterfactual: ``bilateral_handoff = true`` (the
only implemented value) is witnessed by a one-sided handoff or receive that starts no transfer, and
a ``release_lost`` reason by the event itself.

Which fields are entries is derived, not listed by hand where a table exists: every implemented
value of :data:`agspec.ir.variants.OPTIONS`, every value a named variant of the official profile
sets (PR-VARIANT), every other profile field of PR-ABSTRACT-V1 except :data:`NO_BEHAVIOUR`, and
the official scenario's coordination and shelf constants (S-OFFICIAL).
"""

from __future__ import annotations

import copy
import json
from dataclasses import dataclass
from functools import lru_cache
from typing import Any, Iterable, Mapping, Sequence

from agspec.conform.cases import mismatches
from agspec.conform.impl import ReferenceImpl
from agspec.conform.lockstep.actions import ControllerPolicy, ScriptPolicy
from agspec.conform.lockstep.compare import behavioural
from agspec.conform.lockstep.driver import Pair, Step, compare_replies, lockstep
from agspec.formats.actions import HANDOFF0, OP0
from agspec.formats.pointer import MISSING, first_difference, parse
from agspec.formats.pointer import resolve as resolve_pointer
from agspec.ir import topology, variants

# Profile fields of PR-ABSTRACT-V1 that change no behaviour of a valid v1 instance: normalisation
# references and labels (PR-ABSTRACT-V1), the payload (it never binds: S-FEASIBILITY 7, AG459, rejects a
# product heavier than the payload), and identity fields.
NO_BEHAVIOUR = ("reference_reach", "reference_time", "robot_model", "tools", "payload", "id", "doc", "kind",
                "ir_version", "variant", "variants")
# release_lost reasons no valid instance can produce (R-RELEASE, I-PRODUCTS: the realization lists one
# product per opportunity, and a lost opportunity consumes none)
UNREACHABLE = {"release_lost:realization_exhausted": "a valid instance lists one product per release opportunity "
                                                     "(I-PRODUCTS, AG511); only an invalid one runs out"}
RELATIONS = ("G_obs", "G_handoff", "G_manip")
RADII = (1, 2)
# the counterfactual grid of a relation entry: the first of these whose relation differs on the grid
ALTERNATIVES = (("moore", 1), ("von_neumann", 1), ("line", 1), ("moore", 2))
STATE_PARTS = ("t", "state", "done")
REPLY_PARTS = ("t", "done", "state", "events", "observations", "masks")


@dataclass(frozen=True)
class Entry:
    """One value of one option.  ``kind``: ``field`` (``pointer`` has ``value`` — ``match`` ``eq``,
    ``ne`` (any value but ``official``) or ``ge`` — and a hard-coding simulator reads ``official``),
    ``resources`` (``value``: finite, zero or override), ``batch``, ``relation`` (``value``:
    (relation, topology, radius)) or ``witness`` (``value``: what the reference run must show)."""

    id: str
    spec: str
    kind: str
    meaning: str
    pointer: str = ""
    value: Any = None
    official: Any = None
    match: str = "eq"

    @property
    def group(self) -> str:
        return self.id.split(":", 1)[0]


def _show(value: Any) -> str:
    return str(value).lower() if isinstance(value, bool) else str(value)


@lru_cache(maxsize=1)
def entries() -> tuple[Entry, ...]:
    """Every entry of the variant space, in a fixed order (see the module docstring)."""
    from agspec.catalogue import load_scenario_bundle

    scenario, _recipes, profile = load_scenario_bundle("flow-easy")  # S-OFFICIAL: shared constants
    out: list[Entry] = []
    for option in variants.OPTIONS:  # S-RULE-VARIANTS: every implemented value
        pointer = "/" + "/".join((option.document, *option.path))
        name = ".".join(option.path)
        for value in option.supported:
            if len(option.supported) > 1:
                out.append(Entry(f"variant:{name}={_show(value)}", option.rule, "field",
                                 f"{option.meaning}" if value != option.default else f"the default of {name}",
                                 pointer, value, not value))
            else:
                out.append(Entry(f"variant:{name}={_show(value)}", option.rule, "witness",
                                 f"the only implemented value: {option.meaning}", pointer, f"one_sided_{option.name}",
                                 value))
    switches = {o.name for o in variants.OPTIONS if o.document == "profile"}
    by_variant = {}
    for name, overrides in sorted((profile.get("variants") or {}).items()):  # PR-VARIANT
        for key, value in overrides.items():
            if value != profile.get(key):
                by_variant.setdefault(key, []).append((value, name))
    for key, values in by_variant.items():
        for value, name in sorted(values):
            out.append(Entry(f"profile:{key}={_show(value)}", "PR-VARIANT", "field",
                             f"variant {name} of {profile['id']} ({key} {profile[key]} -> {value})",
                             f"/profile/{key}", value, profile[key]))
    for key, value in profile.items():  # PR-ABSTRACT-V1: every other field that changes behaviour
        if key in NO_BEHAVIOUR or key in switches or key in by_variant:
            continue
        for sub, official in (value.items() if isinstance(value, dict) else [(None, value)]):
            path = key if sub is None else f"{key}/{sub}"
            out.append(Entry(f"profile:{path.replace('/', '.')}!={_show(official)}", "PR-ABSTRACT-V1", "field",
                             f"{path.replace('/', '.')} other than the official {official}", f"/profile/{path}",
                             official, official, "ne"))
    coord, shelves = scenario["coordination"], scenario["shelves"]
    out += [
        Entry(f"scenario:coordination.support_timeout!={coord['support_timeout']}", "S-COORDINATION", "field",
              "a support timeout other than the official one (R-SUPPORT-LIFECYCLE)",
              "/scenario/coordination/support_timeout", coord["support_timeout"], coord["support_timeout"], "ne"),
        Entry("scenario:coordination.switch_lock>=2", "S-COORDINATION", "field",
              "a switch lock that binds (R-SWITCH-LOCK; 0 and the official 1 are vacuous)",
              "/scenario/coordination/switch_lock", 2, coord["switch_lock"], "ge"),
        Entry(f"scenario:shelves.capacity!={shelves['capacity']}", "S-SHELVES", "field",
              "a shelf capacity other than the official one (R-REPLENISH)", "/scenario/shelves/capacity",
              shelves["capacity"], shelves["capacity"], "ne"),
        Entry(f"scenario:shelves.replenish_interval!={shelves['replenish_interval']}", "S-SHELVES", "field",
              "a replenish interval other than the official one (R-REPLENISH)",
              "/scenario/shelves/replenish_interval", shelves["replenish_interval"], shelves["replenish_interval"],
              "ne"),
        Entry("scenario:evaluation.mode=batch", "S-EVALUATION", "batch",
              "batch evaluation: no release after Z products, done at the Z-th delivery (R-RELEASE, R-TERMINATION)"),
        Entry("scenario:resources.finite", "RC-RESOURCES", "resources",
              "a resource of capacity >= 2 (several activities at once; a simulator with exclusive resources fails)",
              value="finite"),
        Entry("scenario:resources.zero", "RC-RESOURCES", "resources",
              "a resource of capacity 0 (nothing that uses it starts; R-BLOCKING)", value="zero"),
        Entry("scenario:resources.override", "S-RESOURCES", "resources",
              "a scenario capacity overriding the recipe's", value="override"),
        Entry("release_lost:wip_cap", "R-RELEASE", "witness", "a release opportunity lost to the WIP cap",
              value={"type": "release_lost", "reason": "wip_cap"}),
        Entry("release_lost:raw_material", "R-RELEASE", "witness",
              "a release opportunity lost to an empty source row (RES-RELEASE-RAW-MATERIAL)",
              value={"type": "release_lost", "reason": "raw_material"}),
    ]
    for relation in RELATIONS:  # D-TOPOLOGY
        for topo in topology.TOPOLOGIES:
            for radius in RADII:
                out.append(Entry(f"topology:{relation}/{topo}/{radius}", "D-TOPOLOGY", "relation",
                                 f"{relation} on a {topo} grid of radius {radius}", value=(relation, topo, radius)))
    return tuple(out)


# =============================================================================================
# which instances an entry applies to, and the counterfactual instance


def _capacities(instance: Mapping[str, Any]) -> tuple[dict[str, int], dict[str, int]]:
    """(recipe-declared capacities, effective capacities) (S-RESOURCES, RC-RESOURCES)."""
    declared: dict[str, int] = {}
    for recipe in (instance.get("recipes") or {}).values():
        declared.update({k: int(v) for k, v in (recipe.get("resources") or {}).items()})
    effective = {**declared, **{k: int(v) for k, v in (instance["scenario"].get("resources") or {}).items()}}
    return declared, effective


def _grid(instance: Mapping[str, Any]) -> tuple[int, int, str, int]:
    g = instance["scenario"]["grid"]
    return int(g["rows"]), int(g["cols"]), g.get("topology", "moore"), int(g.get("radius", 1))


def _relation_edges(relation: str, rows: int, cols: int, topo: str, radius: int) -> frozenset:
    graph = {"G_obs": topology.observation_graph, "G_handoff": topology.handoff_graph,
             "G_manip": topology.manipulation_graph}[relation](rows, cols, topo, radius)
    return frozenset(graph.edges)


def _field_value(entry: Entry, instance: Mapping[str, Any]) -> Any:
    value = resolve_pointer(instance, entry.pointer)
    if value is MISSING and entry.group == "variant":  # S-RULE-VARIANTS: an absent option has its default
        option = variants.BY_NAME[parse(entry.pointer)[-1]]
        value = option.default
    return value


def applies(entry: Entry, instance: Mapping[str, Any]) -> bool:
    """Whether ``instance`` has the entry's value (for a witness: could show it)."""
    if entry.kind in ("field", "witness") and entry.pointer:
        value = _field_value(entry, instance)
        if entry.kind == "witness":
            return value == entry.official
        if value is MISSING or isinstance(value, bool) != isinstance(entry.value, bool):
            return False
        return {"eq": value == entry.value, "ne": value != entry.value,
                "ge": isinstance(value, (int, float)) and value >= entry.value}[entry.match]
    if entry.kind == "witness":
        return True
    if entry.kind == "batch":
        return instance["scenario"]["evaluation"].get("mode") == "batch"
    if entry.kind == "resources":
        declared, effective = _capacities(instance)
        return {"finite": any(c >= 2 for c in effective.values()), "zero": any(c == 0 for c in effective.values()),
                "override": any(declared.get(k, 1) != c for k, c in effective.items())}[entry.value]
    relation, topo, radius = entry.value
    return _grid(instance)[2:] == (topo, radius)


def counterfactual(entry: Entry, instance: Mapping[str, Any]) -> dict[str, Any] | None:
    """The instance a simulator that hard-codes the official value reads (None: no counterfactual)."""
    if entry.kind == "witness":
        return None
    out = copy.deepcopy(dict(instance))
    if entry.kind == "field":
        tokens = parse(entry.pointer)
        holder = out
        for token in tokens[:-1]:
            holder = holder.setdefault(token, {})
        holder[tokens[-1]] = entry.official
    elif entry.kind == "batch":  # the batch mode ignored: a continuing run to the batch timeout
        ev = out["scenario"]["evaluation"]
        out["scenario"]["evaluation"] = {"mode": "continuing", "horizon": int(ev.get("timeout", ev.get("horizon", 1)))}
    elif entry.kind == "resources":
        declared, effective = _capacities(out)
        if entry.value == "override":  # the scenario's capacities ignored: the recipes' apply
            out["scenario"]["resources"] = {k: c for k, c in effective.items() if k not in declared}
        else:  # every resource exclusive (capacity 1, as the implicit ones)
            out["scenario"]["resources"] = {k: 1 for k in effective}
    else:
        relation, topo, radius = entry.value
        rows, cols = _grid(out)[:2]
        mine = _relation_edges(relation, rows, cols, topo, radius)
        other = next((alt for alt in ALTERNATIVES if alt != (topo, radius)
                      and _relation_edges(relation, rows, cols, *alt) != mine), None)
        if other is None:
            return None  # on this grid no other topology gives the relation other edges
        out["scenario"]["grid"] = {**out["scenario"]["grid"], "topology": other[0], "radius": other[1]}
    return out


# =============================================================================================
# running an item and its counterfactuals on the reference


@dataclass
class Recording:
    """The reference's run of an item: the joint actions sent and every reply (reset first)."""

    actions: list[dict[str, int]]
    replies: list[Mapping[str, Any]]
    failed: str = ""


def _run(instance: Mapping[str, Any], seed: int | None, policy: Any, ticks: int, stop: Any = None) -> Recording:
    """One single-sided run of the reference through the lockstep driver; ``stop(index, reply)``
    ends it early."""
    replies: list[Mapping[str, Any]] = []

    def observe(step: Step) -> bool:
        replies.append(step.expected)
        return bool(stop and stop(len(replies) - 1, step.expected))

    impl = ReferenceImpl()
    impl.start()
    try:
        run = lockstep(Pair(impl, None), instance, seed, policy, ticks, observer=observe)
    finally:
        impl.close()
    failed = run.failure.message if run.failure is not None else (run.invalid or "")
    return Recording(list(run.actions), replies, failed)


def record(item: Any) -> Recording:
    """The reference's run of ``item`` (a :class:`agspec.conform.items.Item`), as ``agspec conform`` drives it."""
    if item.controller is not None:
        policy: Any = ControllerPolicy(item.controller["name"], item.controller.get("seed"))
    else:
        policy = ScriptPolicy(item.actions)
    return _run(item.instance, item.execution_seed, policy, item.ticks)


def _mask_slice(reply: Mapping[str, Any], lo: int, hi: int | None) -> dict[str, Any]:
    return {r: list(m[lo:hi]) for r, m in (reply.get("masks") or {}).items()}


def _events(reply: Mapping[str, Any], types: Iterable[str]) -> list:
    wanted = set(types)
    return [e for e in reply.get("events") or [] if isinstance(e, dict) and e.get("type") in wanted]


def relation_view(relation: str, reply: Mapping[str, Any], events_only: bool = False) -> Any:
    """The parts of a reply that ``relation`` decides (D-TOPOLOGY); ``events_only``: only the events
    (the transition's, when the reply's state is already a consequence of the relation)."""
    if events_only:
        reply = {"events": reply.get("events")}
    obs = reply.get("observations") or {}
    if relation == "G_obs":  # O-OBSERVATION: the neighbour entries
        return {r: o.get("neighbours") for r, o in obs.items()}
    if relation == "G_handoff":  # O-MASK handoff and receive bits, R-HANDOFF starts
        return [_mask_slice(reply, HANDOFF0, OP0), _events(reply, ("handoff_started",))]
    return [{r: o.get("operation_options") for r, o in obs.items()}, _mask_slice(reply, OP0, None),
            _events(reply, ("support", "proposal_created", "admitted"))]  # R-CANDIDATES, R-ADMISSION


def relation_path(relation: str, pointer: str) -> str:
    """A pointer into :func:`relation_view` as a pointer into the reply (or the events it came from)."""
    tokens = parse(pointer)
    if relation == "G_obs":
        return "/observations/" + "/".join(tokens[:1] + ["neighbours"] + tokens[1:])
    part, rest = (tokens[0], tokens[1:]) if tokens else ("", [])
    if part == str(len(relation_view(relation, {})) - 1):
        return "/events (" + "/".join(rest) + ")"
    if relation == "G_handoff" or part == "1":  # a mask slice: its index back to the action
        offset = HANDOFF0 if relation == "G_handoff" else OP0
        return "/masks/" + "/".join(rest[:1] + [str(offset + int(rest[1]))] if len(rest) > 1 else rest)
    return "/observations/" + "/".join(rest[:1] + ["operation_options"] + rest[1:])


@dataclass(frozen=True)
class Finding:
    """How an item catches a simulator that reads the counterfactual: the first differing reply
    (``tick`` -1 = the reset reply) and where, and whether the case's expectations fail too."""

    tick: int
    where: str
    asserted: bool

    def to_json(self) -> dict[str, Any]:
        return {"tick": self.tick, "where": self.where, "asserted": self.asserted}


def _behaviour(reply: Mapping[str, Any]) -> dict[str, Any]:
    """A reply without the state's diagnostic fields (F-TRACE-STATE): a simulator that keeps its own
    bookkeeping is caught on behaviour alone."""
    return {**reply, "state": behavioural(reply.get("state"))}


def _same(a: Mapping[str, Any], b: Mapping[str, Any], parts: Sequence[str]) -> bool:
    """Whether two replies of the reference are equal on ``parts`` (both come from one interpreter:
    Python equality is the comparison's, without its walk)."""
    return all(a.get(p) == b.get(p) and type(a.get(p)) is type(b.get(p)) for p in parts)


def _asserted(case: Any, replies: Sequence[Mapping[str, Any]]) -> bool:
    """Whether the case's expectations — on behaviour, not on diagnostic fields — fail on ``replies``."""
    for t, reply in enumerate(replies[1:]):
        if case.expectations_at(t) and mismatches(case, t, reply.get("state") or {}, reply.get("events") or [],
                                                  observations=reply.get("observations"), done=reply.get("done"),
                                                  diagnostic=False):
            return True
    return False


def discriminate(item: Any, rec: Recording, cf_instance: Mapping[str, Any],
                 relations: Sequence[str] = ()) -> dict[str, Finding]:
    """Run ``item``'s actions on ``cf_instance`` and compare with ``rec``.  Key ``""``: the first
    difference of the whole reply; key ``relation``: the first difference of that relation's view
    on replies whose states agree.  A case runs to its end (its expectations are checked); other
    items stop at the first state difference."""
    case = item.case if item.kind == "case" and item.case is not None and not item.case.driver else None
    found: dict[str, tuple[int, str]] = {}
    states_agree = [True]

    def stop(index: int, reply: Mapping[str, Any]) -> bool:
        if index >= len(rec.replies):
            return True
        ref, reply = _behaviour(rec.replies[index]), _behaviour(reply)
        if not states_agree[0]:
            return case is None
        same = _same(ref, reply, REPLY_PARTS)  # equal values: the common case, decided without a walk
        if "" not in found and not same:
            d = compare_replies(index - 1, ref, reply, REPLY_PARTS)
            if d is not None:
                found[""] = (index - 1, d.path)
        if not same and not _same(ref, reply, STATE_PARTS):
            states_agree[0] = False  # this reply's observations and masks follow from another state
        for relation in relations:
            if relation not in found and not same:
                only = not states_agree[0]
                a, b = relation_view(relation, ref, only), relation_view(relation, reply, only)
                diff = None if a == b else first_difference(a, b)
                if diff is not None:
                    found[relation] = (index - 1, relation_path(relation, diff[0]))
        if not states_agree[0] or ("" in found and all(r in found for r in relations)):
            return case is None
        return False

    cf = _run(cf_instance, item.execution_seed, ScriptPolicy(rec.actions), len(rec.actions), stop=stop)
    asserted = case is not None and not cf.failed and _asserted(case, cf.replies)
    return {key: Finding(t, where, asserted) for key, (t, where) in found.items()}


def _one_sided(rec: Recording) -> bool:
    """bilateral_handoff: a handoff (receive) sent without the partner's matching receive (handoff)
    that started no transfer (R-HANDOFF)."""
    for t, joint in enumerate(rec.actions):
        reply = rec.replies[t + 1] if t + 1 < len(rec.replies) else {}
        started = {e.get("sender") for e in _events(reply, ("handoff_started",))} | \
                  {e.get("receiver") for e in _events(reply, ("handoff_started",))}
        if any(HANDOFF0 <= a < OP0 and r not in started for r, a in joint.items()):
            return True
    return False


def _witnessed(entry: Entry, rec: Recording) -> bool:
    if isinstance(entry.value, str) and entry.value.startswith("one_sided_"):
        return _one_sided(rec)
    pattern = entry.value
    return any(all(e.get(k) == v for k, v in pattern.items()) for reply in rec.replies
               for e in reply.get("events") or [] if isinstance(e, dict))


def item_coverage(item: Any, universe: Sequence[Entry] | None = None) -> dict[str, Finding]:
    """The entries ``item`` covers, each with its finding (a witness: tick -1, where "witnessed")."""
    universe = entries() if universe is None else universe
    applicable = [e for e in universe if applies(e, item.instance)]
    if not applicable:
        return {}
    rec = record(item)
    if rec.failed:
        return {}
    out: dict[str, Finding] = {}
    runs: dict[str, tuple[dict[str, Any], list[Entry]]] = {}
    for entry in applicable:
        if entry.kind == "witness":
            if _witnessed(entry, rec):
                out[entry.id] = Finding(-1, "witnessed", False)  # no counterfactual: nothing to assert
            continue
        cf = counterfactual(entry, item.instance)
        if cf is None or cf == item.instance:
            continue
        runs.setdefault(json.dumps(cf, sort_keys=True), (cf, []))[1].append(entry)
    for cf, group in runs.values():
        relations = sorted({e.value[0] for e in group if e.kind == "relation"})
        found = discriminate(item, rec, cf, relations)
        for entry in group:
            key = entry.value[0] if entry.kind == "relation" else ""
            if key in found:
                out[entry.id] = found[key]
    return out


ASSERTED_KINDS = ("field", "resources", "batch")  # entries a suite case's expectations must catch


def variant_coverage(items: Sequence[Any], *, enough: int | None = None) -> dict[str, Any]:
    """``{"variants": {entry: {"spec", "meaning", "items": [ids], "asserted": [case ids], "findings": {id:
    finding}}},
    "uncovered": [entries], "unreachable": {entry: why}}`` over :func:`entries`.

    An entry is uncovered when no item covers it, or — a field, resource or batch entry — when no
    suite case's expectations assert it.  ``enough``: stop looking at an entry once that many items
    cover (and, where required, assert) it — a cheaper answer to "is everything covered?"."""
    universe = entries()
    table: dict[str, dict[str, Any]] = {
        e.id: {"spec": e.spec, "meaning": e.meaning, "items": [], "asserted": [], "findings": {}} for e in universe}

    def settled(e: Entry) -> bool:
        row = table[e.id]
        return enough is not None and len(row["asserted" if e.kind in ASSERTED_KINDS else "items"]) >= enough

    for item in items:
        wanted = [e for e in universe if not settled(e)]
        if not wanted:
            break
        for ident, finding in item_coverage(item, wanted).items():
            row = table[ident]
            row["items"].append(item.id)
            row["findings"][item.id] = finding.to_json()
            if finding.asserted:
                row["asserted"].append(item.id)
    kinds = {e.id: e.kind for e in universe}
    uncovered = [ident for ident, row in table.items()
                 if not row["items"] or (kinds[ident] in ASSERTED_KINDS and not row["asserted"])]
    return {"variants": table, "uncovered": uncovered, "unreachable": dict(UNREACHABLE)}


__all__ = ["Entry", "Finding", "Recording", "NO_BEHAVIOUR", "UNREACHABLE", "RELATIONS", "ASSERTED_KINDS", "entries",
           "applies", "counterfactual", "record", "discriminate", "relation_view", "relation_path", "item_coverage",
           "variant_coverage"]
