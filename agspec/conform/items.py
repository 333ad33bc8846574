"""What ``agspec conform`` runs: suite cases, catalogue episodes and reproducers, as one kind of item.

* a **case** of the conformance suite (:mod:`agspec.conform.cases`): its instance, execution seed and
  resolved action script — or its controller driver — and its expectations;
* a catalogue **episode** (F-CONFORM): each catalogue scenario (:data:`EPISODE_SCENARIOS`: the
  nine official ones and the three matched geometry controls) at suite index 0, driven by
  the greedy controller (``e-{scenario}-greedy``) and by seeded random-masked controllers
  (``e-{scenario}-random-{k}``, seed k), acting on the *reference's* observations; ``--episodes N``
  runs the greedy one and N - 1 random ones per scenario, over the whole horizon (``--horizon T``: its
  first T epochs);
* a **replay** of a reproducer file (F-REPRO).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, Sequence

from agspec.catalogue import GEOMETRY_MATCHED, OFFICIAL_SCENARIOS, load_scenario_bundle
from agspec.conform.cases import Case
from agspec.ir.instance import make_instance

# F-CONFORM: the scenarios of the catalogue episodes — every catalogue scenario, the matched geometry
# controls included (their conflict variants are instance values a simulator must read)
EPISODE_SCENARIOS: tuple[str, ...] = (*OFFICIAL_SCENARIOS, *GEOMETRY_MATCHED)
# the default run of `agspec conform`: --episodes, and --horizon (None: every catalogue episode runs its
# whole horizon, RES-CONFORM-HORIZON)
DEFAULT_EPISODES, DEFAULT_TICKS = 2, None


@dataclass(frozen=True)
class Item:
    """One unit of a conformance run (picklable, for ``-j``)."""

    id: str
    kind: str  # "case" | "episode" | "replay"
    title: str
    instance: dict[str, Any] = field(repr=False)
    execution_seed: int | None
    ticks: int
    actions: tuple[dict[str, int], ...] = field(default=(), repr=False)  # scripted joint actions
    controller: dict[str, Any] | None = None  # {"name": ..., "seed": ...}: actions from the reference's observations
    case: Case | None = field(default=None, repr=False)
    rules: tuple[str, ...] = ()
    invariants: tuple[str, ...] = ()
    tags: tuple[str, ...] = ()
    location: str | None = None
    # F-REPRO: requests the implementation's process received before this episode, sent again first
    # (("load", instance) / ("reset", seed) / ("step", actions)); a history-dependent failure's reproducer
    history: tuple[tuple[str, Any], ...] = field(default=(), repr=False)
    horizon: int | None = None  # a catalogue episode: the epochs its execution lasts (F-CONFORM horizon)

    @property
    def name(self) -> str:
        """What a person reads: a suite case by its title and place in the suite (``support expiry: …
        (conformance/cases/support.yaml:7)``), an episode or a replay by its id; ``id`` stays the
        stable key (``--expect`` files, reports, reproducers)."""
        return f"{self.title} ({self.location})" if self.kind == "case" and self.location else self.id

    @property
    def heading(self) -> str:
        """The first line of a failure's text: the name, then the stable id."""
        return f"{self.title} [{self.id}]" if self.kind == "case" else f"{self.id} {self.title}"

    @property
    def scenario(self) -> str | None:
        """The official scenario of a catalogue episode (None for a case or a replay)."""
        loc = self.location or ""
        return loc.split(":")[1] if self.kind == "episode" and loc.startswith("catalogue:") else None


def from_case(case: Case) -> Item:
    controller = None
    if case.driver is not None and "controller" in case.driver:
        seed = case.driver.get("seed")
        controller = {"name": case.driver["controller"], "seed": case.execution_seed if seed is None else seed}
    return Item(
        id=case.id, kind="case", title=case.title, instance=case.instance, execution_seed=case.execution_seed,
        ticks=case.ticks, actions=tuple(case.actions) if controller is None else (), controller=controller,
        case=case, rules=tuple(case.rules), invariants=tuple(case.invariants), tags=tuple(case.tags),
        location=case.location,
    )


def horizon(instance: Mapping[str, Any]) -> int:
    """The epochs an execution of ``instance`` lasts at most (its evaluation horizon, or batch timeout)."""
    ev = instance["scenario"]["evaluation"]
    return int(ev.get("horizon", ev.get("timeout", 0)))


def catalogue_episodes(episodes: int, ticks: int | None = None, scenarios: Sequence[str] | None = None,
                       index: int = 0) -> list[Item]:
    """F-CONFORM: per official scenario, greedy plus ``episodes - 1`` seeded random episodes, over the
    whole horizon (``ticks`` None) or its first ``ticks`` epochs."""

    if episodes <= 0 or (ticks is not None and ticks <= 0):
        return []
    out = []
    for name in scenarios or EPISODE_SCENARIOS:
        sc, recipes, profile = load_scenario_bundle(name)
        inst = make_instance(sc, recipes, profile, index=index)
        seed = inst["seeds"]["execution"]
        span = horizon(inst)
        steps = span if ticks is None else min(ticks, span)
        drivers = [("greedy", seed)] + [(f"random-{k}", k) for k in range(1, episodes)]
        for label, ctl_seed in drivers:
            out.append(Item(
                id=f"e-{name}-{label}", kind="episode",
                title=f"{inst['id']} · {label.split('-')[0]} controller" + (f" seed {ctl_seed}" if label != "greedy" else ""),
                instance=inst, execution_seed=seed, ticks=steps, horizon=span,
                controller={"name": label.split("-")[0], "seed": ctl_seed},
                rules=(), invariants=(), tags=("episode", "catalogue", sc.get("family", ""), label.split("-")[0]),
                location=f"catalogue:{name}:{index}",
            ))
    return out


def from_reproducer(data: Mapping[str, Any], path: str) -> Item:
    """F-REPRO: the reproducer's action prefix as a script, after the requests of its ``history`` and with
    the case's ``expectations`` it carries."""
    actions = tuple(dict(a) for a in data["actions"])
    case = None
    if data.get("expectations"):
        case = Case(id=str(data.get("id") or "replay"), title=str(data.get("title") or path), rules=(), invariants=(),
                    tags=(), instance=dict(data["instance"]), execution_seed=data.get("execution_seed"),
                    actions=actions, driver=None, expectations=tuple(dict(e) for e in data["expectations"]),
                    source=Path(path), line=1)
    return Item(
        id=str(data.get("id") or "replay"), kind="replay", title=f"replay of {data.get('title') or path}",
        instance=dict(data["instance"]), execution_seed=data.get("execution_seed"), ticks=len(actions),
        actions=actions, location=str(path), tags=("replay",), case=case,
        history=history_requests(data.get("history")),
    )


def default_run(cases: Sequence[Case], episodes: int = DEFAULT_EPISODES,
                ticks: int | None = DEFAULT_TICKS) -> list[Item]:
    """The items of ``agspec conform`` without selection: every case, then the catalogue episodes."""
    return [from_case(c) for c in cases] + catalogue_episodes(episodes, ticks)


def history_requests(history: Mapping[str, Any] | None) -> tuple[tuple[str, Any], ...]:
    """The requests of a reproducer's ``history`` ({"instances": [IR...], "requests": [...]})."""
    if not history:
        return ()
    instances = history["instances"]
    out: list[tuple[str, Any]] = []
    for req in history["requests"]:
        if req["cmd"] == "load":
            out.append(("load", instances[req["instance"]]))
        elif req["cmd"] == "reset":
            out.append(("reset", req.get("execution_seed")))
        else:
            out.append(("step", dict(req["actions"])))
    return tuple(out)


__all__ = ["Item", "EPISODE_SCENARIOS", "DEFAULT_EPISODES", "DEFAULT_TICKS", "from_case", "catalogue_episodes",
           "default_run", "from_reproducer", "horizon", "history_requests"]
