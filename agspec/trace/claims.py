"""The claims of a trace header, each checked against what determines it (F-TRACE-CLAIMS).

A header says which run the trace is: of which instance, under which spec, for how many epochs,
by which controller, from which initial state. :func:`check_claims` checks every claim that can
be checked, and reports each that does not hold, located at the header's line and the pointer of
the field (F-TRACE-VALIDATE; ``agspec trace validate`` and ``agspec check`` report the same):

* **F-CLAIM-FINGERPRINT** — ``fingerprint`` is the F-FINGERPRINT of the stored ``instance`` (AG607);
* **F-CLAIM-INSTANCE** — the stored instance is a valid instance (I-*; its own AG5xx codes, with the
  pointer under ``/instance``);
* **F-CLAIM-OFFICIAL** — a scenario that says ``suite official`` (S-OFFICIAL) is an official scenario of
  the catalogue lock (F-LOCK) and the stored instance is the one the catalogue makes from it with
  the stored seeds: scenario, recipes, resolved profile and realization (AG610);
* **F-CLAIM-LOCK-ID** — an instance whose ``id`` is the id of an instance of the lock is that
  instance: its fingerprint is the lock's (AG610);
* **F-CLAIM-SUITE-INDEX** — an instance with a suite ``index`` (S-SEEDS) has the generation seed of that
  index, the id of S-INSTANCE and the realization its generation seed makes (S-REALIZATION) (AG610);
* **F-CLAIM-SPEC-VERSION**, **F-CLAIM-HORIZON**, **F-CLAIM-CONTROLLER** — the header's own fields (AG611);
* **F-CLAIM-INITIAL-STATE** — ``state`` is s_0 of the instance (S-INSTANCE), its behavioural fields
  (F-TRACE-STATE), and ``events`` (when not null) the events of ``reset`` (F-TRACE-EMISSION) (AG612).

What is not checked, and why, is F-TRACE-CLAIMS too: ``implementation`` (a self-declared name),
``execution_seed`` and ``seeds.execution`` (inert in v1, D-DETERMINISM), ``id`` and ``meta`` of an
instance that makes no suite or lock claim, ``realization.method`` of such an instance
(a non-normative label), and the diagnostic fields of s_0.
"""

from __future__ import annotations

import functools
from typing import Any, Callable, Mapping

from agspec import SPEC_VERSION
from agspec.catalogue import CatalogueError, load_scenario_bundle, read_lock
from agspec.controllers import CONTROLLERS
from agspec.formats.diagnostics import Diagnostic
from agspec.formats.pointer import first_difference
from agspec.formats.trace import behavioural
from agspec.interp.snapshot import global_state
from agspec.interp.tick import Simulator
from agspec.ir.fingerprint import defining_view, fingerprint
from agspec.ir.instance import DEFAULT_SEED_BASES, InstanceError, instance_id, make_instance, realize
from agspec.ir.validate import validate_instance
from agspec.resources import catalogue_dir

Json = dict[str, Any]
Diag = Callable[..., Diagnostic]

CLAIM_CODES = {
    "AG610": "the stored instance is not the instance it names (an official scenario, a lock instance id, "
             "a suite index)",
    "AG611": "a header field claims what the trace cannot be (spec version, horizon, controller)",
    "AG612": "the header's initial state or reset events are not those of its instance",
}
# C-INFORMATION: the information each reference controller acts on
CONTROLLER_INFORMATION = {"random": "local", "greedy": "local", "parallel-aware": "local", "centralized": "global"}
assert set(CONTROLLER_INFORMATION) == set(CONTROLLERS)


def _first_difference(expected: Any, actual: Any) -> str:
    """The JSON Pointer of the first place where ``actual`` differs from ``expected`` ('' if none)."""
    found = first_difference(expected, actual)
    return "" if found is None else (found[0] or "/")


@functools.lru_cache(maxsize=1)
def _lock() -> Json:
    try:
        return read_lock()
    except CatalogueError:
        return {"scenarios": {}, "indices": []}


@functools.lru_cache(maxsize=1)
def _lock_ids() -> dict[str, tuple[str, int, str]]:
    """Lock instance id → (scenario, index, fingerprint)."""
    return {e["id"]: (name, e["index"], e["fingerprint"])
            for name, s in _lock().get("scenarios", {}).items() for e in s.get("instances", [])}


@functools.lru_cache(maxsize=32)
def _official_instance(name: str, index: int | None, generation: int, execution: int | None) -> Json:
    """The instance the catalogue makes of official scenario ``name`` with these seeds (S-SEEDS)."""
    scenario, recipes, profile = load_scenario_bundle(catalogue_dir() / "scenarios" / f"{name}.ag")
    return make_instance(scenario, recipes, profile, index=index, generation_seed=generation,
                         execution_seed=execution)


def check_claims(header: Mapping[str, Any], file: str, line: int | None, diag: Diag) -> list[Diagnostic]:
    """Every checkable claim of ``header`` (F-TRACE-CLAIMS); the fingerprint (AG607) first."""
    out: list[Diagnostic] = []

    def bad(code: str, pointer: str, message: str, hint: str | None = None) -> None:
        out.append(diag(code, message, file, line, pointer=pointer, hint=hint))

    instance = header.get("instance")
    try:
        _header_fields(header, instance, bad)
    except (KeyError, TypeError, ValueError, AttributeError, IndexError):
        pass  # fields of the wrong type: the schema diagnostics say so
    if not isinstance(instance, dict):
        return out  # the schema reports it
    try:
        fp = fingerprint(instance)
    except Exception:  # no canonical form: the schema reports the value
        return out
    # F-CLAIM-FINGERPRINT
    if isinstance(header.get("fingerprint"), str) and header["fingerprint"] != fp:
        bad("AG607", "/fingerprint", f"fingerprint {header['fingerprint'][:19]}… is not the instance's ({fp[:19]}…)")
    # F-CLAIM-INSTANCE
    issues = [i for i in validate_instance(instance) if i.severity == "error"]
    for issue in issues:
        bad(issue.code, "/instance" + (issue.pointer or ""), issue.message, issue.hint)
    if issues:
        return out  # the claims below read a valid instance
    try:
        _instance_claims(instance, fp, bad)
        _initial_state(header, instance, bad)
    except (KeyError, TypeError, ValueError, AttributeError, IndexError):
        pass  # an instance without the fields: the schema diagnostics of the header say so
    return out


def _header_fields(header: Mapping[str, Any], instance: Any, bad: Callable[..., None]) -> None:
    # F-CLAIM-SPEC-VERSION
    if isinstance(header.get("spec_version"), str) and header["spec_version"] != SPEC_VERSION:
        bad("AG611", "/spec_version", f"spec_version {header['spec_version']!r} is not this specification's "
                                      f"({SPEC_VERSION!r})", "a v1 trace declares the spec version it follows")
    # F-CLAIM-HORIZON
    horizon = header.get("horizon")
    ev = (instance.get("scenario") or {}).get("evaluation") if isinstance(instance, dict) else None
    if isinstance(horizon, int) and isinstance(ev, dict):
        limit = ev.get("horizon") if ev.get("mode") != "batch" else ev.get("timeout")
        if isinstance(limit, int) and not 1 <= horizon <= limit:
            bad("AG611", "/horizon", f"horizon {horizon} is outside 1..{limit}, the instance's evaluation "
                                     f"{'timeout' if ev.get('mode') == 'batch' else 'horizon'}",
                "a run executes at most its instance's evaluation horizon (R-TERMINATION)")
    # F-CLAIM-CONTROLLER
    ctl = header.get("controller")
    if "controller" in header and isinstance(ctl, dict):
        name, info = ctl.get("name"), ctl.get("information")  # their form is the schema's
        if name in CONTROLLER_INFORMATION and "information" in ctl and info != CONTROLLER_INFORMATION[name]:
            bad("AG611", "/controller/information", f"the reference controller {name!r} acts on "
                                                    f"{CONTROLLER_INFORMATION[name]!r} information, not {info!r}")


def _instance_claims(instance: Json, fp: str, bad: Callable[..., None]) -> None:
    scenario, seeds = instance["scenario"], instance.get("seeds") or {}
    index, gen, exe = seeds.get("index"), seeds.get("generation"), seeds.get("execution")
    # F-CLAIM-LOCK-ID
    locked = _lock_ids().get(instance.get("id"))
    if locked is not None and locked[2] != fp:
        bad("AG610", "/instance/id", f"the instance is named {instance['id']!r}, an instance of the catalogue lock "
                                     f"({locked[0]} index {locked[1]}), but its fingerprint {fp[:19]}… is not "
                                     f"the lock's ({locked[2][:19]}…)",
            "a trace of another instance must not carry an official instance's name")
    if not isinstance(gen, int):
        return
    # F-CLAIM-SUITE-INDEX: the seed and the name of a suite index
    suite = scenario.get("suite") or {}
    if isinstance(index, int) and not isinstance(index, bool):
        base = int(suite.get("generation_seed_base", DEFAULT_SEED_BASES[0]))
        if gen != base + index:
            bad("AG610", "/instance/seeds/generation", f"suite index {index} has generation seed {base + index} "
                                                       f"(S-SEEDS), the instance says {gen}")
            return
        want_id = instance_id(scenario, index, gen, True)
        if instance.get("id") != want_id:
            bad("AG610", "/instance/id", f"the instance of suite index {index} is named {want_id!r} (S-INSTANCE), "
                                         f"not {instance.get('id')!r}")
    # F-CLAIM-OFFICIAL
    if suite.get("official"):
        entry = _lock().get("scenarios", {}).get(scenario.get("id"))
        if entry is None or entry.get("fingerprint") != fingerprint(scenario):
            bad("AG610", "/instance/scenario", f"the scenario {scenario.get('id')!r} says `suite official` but is "
                                               "not an official scenario of the catalogue lock (S-OFFICIAL, F-LOCK)")
            return
        try:
            want = _official_instance(scenario["id"], index, gen, exe)
        except (CatalogueError, InstanceError) as exc:
            bad("AG610", "/instance/seeds", f"the catalogue cannot make this instance: {exc}")
            return
        # what the fingerprint covers (F-FINGERPRINT): the id and index were judged above, the
        # execution seed is inert (D-DETERMINISM), `meta` and `doc` are documentation
        where = _first_difference(defining_view(want), defining_view(instance))
        if where:
            bad("AG610", "/instance" + where, f"the instance is not the one official scenario {scenario['id']!r} "
                                              f"makes with its seeds (index {index}, generation seed {gen}): "
                                              f"they differ at {where}")
        return
    # F-CLAIM-SUITE-INDEX: the realization of a suite index is its generation seed's
    if isinstance(index, int) and not isinstance(index, bool):
        try:
            made = realize(scenario, instance["recipes"], instance["profile"], gen)
        except (KeyError, TypeError, ValueError):
            return
        where = _first_difference(made, instance["realization"])
        if where:
            bad("AG610", "/instance/realization" + where, f"the realization is not the one generation seed {gen} "
                                                          f"makes (S-REALIZATION): they differ at {where}")


def _initial_state(header: Mapping[str, Any], instance: Json, bad: Callable[..., None]) -> None:
    # F-CLAIM-INITIAL-STATE
    try:
        sim = Simulator(instance)
    except Exception:  # an instance the interpreter cannot load: its validation says why
        return
    state = header.get("state")
    if isinstance(state, dict):
        where = _first_difference(behavioural(global_state(sim.state)), behavioural(state))
        if where:
            bad("AG612", "/state" + where, f"the header's state is not s_0 of its instance (S-INSTANCE): "
                                           f"they differ at {where}")
    events = header.get("events")
    if isinstance(events, list):
        where = _first_difference(sim.reset_events, events)
        if where:
            bad("AG612", "/events" + where, "the header's events are not those of reset (F-TRACE-EMISSION): "
                                            f"they differ at {where}")


__all__ = ["check_claims", "CLAIM_CODES", "CONTROLLER_INFORMATION"]
