"""What ``agspec conform`` runs: suite cases, catalogue episodes and reproducers, as one kind of item.

* a **case** of the conformance suite (:mod:`agspec.conform.cases`): its instance, execution seed and
  resolved action script — or its controller driver — and its expectations;
* a catalogue **episode** (F-CONFORM): each catalogue scenario (:data:`EPISODE_SCENARIOS`: the
  nine official ones and the three matched geometry controls) at suite index 0, driven by
  the greedy controller (``e-{scenario}-greedy``) and by seeded random-masked controllers
  (``e-{scenario}-random-{k}``, seed k), acting on the *reference's* observations; ``--episodes N``
  runs the greedy one and N - 1 random ones per scenario, ``--ticks T`` steps each;
* a **replay** of a reproducer file (F-REPRO).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

from agspec.catalogue import GEOMETRY_MATCHED, OFFICIAL_SCENARIOS, load_scenario_bundle
from agspec.conform.cases import Case
from agspec.ir.instance import make_instance

# F-CONFORM: the scenarios of the catalogue episodes — every catalogue scenario, the matched geometry
# controls included (their conflict variants are instance values a simulator must read)
EPISODE_SCENARIOS: tuple[str, ...] = (*OFFICIAL_SCENARIOS, *GEOMETRY_MATCHED)
# the default run of `agspec conform`: --episodes and --ticks
DEFAULT_EPISODES, DEFAULT_TICKS = 2, 60


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


def catalogue_episodes(episodes: int, ticks: int, scenarios: Sequence[str] | None = None,
                       index: int = 0) -> list[Item]:
    """F-CONFORM: per catalogue scenario, greedy plus ``episodes - 1`` seeded random episodes."""

    if episodes <= 0 or ticks <= 0:
        return []
    out = []
    for name in scenarios or EPISODE_SCENARIOS:
        sc, recipes, profile = load_scenario_bundle(name)
        inst = make_instance(sc, recipes, profile, index=index)
        seed = inst["seeds"]["execution"]
        drivers = [("greedy", seed)] + [(f"random-{k}", k) for k in range(1, episodes)]
        for label, ctl_seed in drivers:
            out.append(Item(
                id=f"e-{name}-{label}", kind="episode",
                title=f"{inst['id']} · {label.split('-')[0]} controller" + (f" seed {ctl_seed}" if label != "greedy" else ""),
                instance=inst, execution_seed=seed, ticks=ticks,
                controller={"name": label.split("-")[0], "seed": ctl_seed},
                rules=(), invariants=(), tags=("episode", "catalogue", sc.get("family", ""), label.split("-")[0]),
                location=f"catalogue:{name}:{index}",
            ))
    return out


def from_reproducer(data: Mapping[str, Any], path: str) -> Item:
    """F-REPRO: the reproducer's action prefix as a script."""
    actions = tuple(dict(a) for a in data["actions"])
    return Item(
        id=str(data.get("id") or "replay"), kind="replay", title=f"replay of {data.get('title') or path}",
        instance=dict(data["instance"]), execution_seed=data.get("execution_seed"), ticks=len(actions),
        actions=actions, location=str(path), tags=("replay",),
    )


def default_run(cases: Sequence[Case], episodes: int = DEFAULT_EPISODES, ticks: int = DEFAULT_TICKS) -> list[Item]:
    """The items of ``agspec conform`` without selection: every case, then the catalogue episodes."""
    return [from_case(c) for c in cases] + catalogue_episodes(episodes, ticks)


__all__ = ["Item", "EPISODE_SCENARIOS", "DEFAULT_EPISODES", "DEFAULT_TICKS", "from_case", "catalogue_episodes",
           "default_run", "from_reproducer"]
