"""What a trained row says about itself (spec/13-policy.md, F-POLICY-BUDGET).

A policy trained by ``agspec train`` carries, in its results-bundle identity, the run's algorithm,
scenario, seed, training steps and the action it was evaluated with (F-POLICY-CHECKPOINT,
T-EVAL-ACTION).  Every rendering of such a row — the tables, the family figure, the held-out row,
the training curves — states its budget against the paper's (``published.json``: 1,536,000
environment steps, tab:marlconfig) and its evaluation action; a row trained for fewer steps than
the paper's is marked :data:`MARK` and footnoted, so that it is never read as the method's result.
Plain data only: no torch, no matplotlib.
"""

from __future__ import annotations

from typing import Any, Mapping, Sequence

from agspec.policy import published

MARK = "†"  # a row trained below the paper's budget (F-POLICY-BUDGET)
METHOD_NAMES = {"ippo": "IPPO", "mappo": "MAPPO", "qmix": "QMIX"}
ACTIONS = ("greedy", "sample")
ACTION_TEXT = {"greedy": "the masked argmax (T-EVAL-ACTION)",
               "sample": "sampled actions (masked softmax; QMIX ε-greedy), not T-EVAL-ACTION"}


def paper_steps() -> int:
    """The paper's training budget in environment steps (tab:marlconfig, as published.json holds it)."""
    return int(published.published()["training_budget"]["env_steps"])


def action_of(target: str) -> str:
    """The evaluation action of a checkpoint policy's target: a target ending in ``#sample`` plays the
    sampled behaviour, any other the masked argmax (T-EVAL-ACTION, F-POLICY-CHECKPOINT)."""
    return "sample" if str(target).endswith("#sample") else "greedy"


def with_action(identity: Mapping[str, Any]) -> dict[str, Any]:
    """A policy identity whose ``training`` states the evaluation action (F-POLICY-BUNDLE)."""
    out = dict(identity)
    training = out.get("training")
    if isinstance(training, Mapping) and "action" not in training:
        out["training"] = {**training, "action": action_of(out.get("target", ""))}
    return out


def action(training: Mapping[str, Any]) -> str:
    """The recorded evaluation action; bundles written before it was recorded ran the masked argmax,
    the only action F-POLICY-CHECKPOINT ran then."""
    return str(training.get("action") or "greedy")


def below(training: Mapping[str, Any]) -> bool:
    return int(training["steps"]) < paper_steps()


def method(training: Mapping[str, Any]) -> str:
    """The paper's method name, marked when the run is below the paper's budget."""
    name = METHOD_NAMES.get(str(training["algorithm"]), str(training["algorithm"]))
    return name + (MARK if below(training) else "")


def row_name(label: str, training: Mapping[str, Any]) -> str:
    """``IPPO†`` for a run labelled by its method, else ``label (IPPO†)``."""
    name = method(training)
    return name if label in (name, name.rstrip(MARK)) else f"{label} ({name})"


def budget(steps: int) -> str:
    """The budget against the paper's: "4,000 of the paper's 1,536,000 training steps"."""
    paper = paper_steps()
    if steps < paper:
        return f"{steps:,} of the paper's {paper:,} training steps"
    if steps == paper:
        return f"{steps:,} training steps (the paper's budget)"
    return f"{steps:,} training steps (above the paper's {paper:,})"


def steps_range(steps: Sequence[int]) -> str:
    lo, hi = min(steps), max(steps)
    return f"{lo:,}" if lo == hi else f"{lo:,}–{hi:,}"


def note(label: str, training: Mapping[str, Any]) -> str:
    """One footnote line of a trained row: name, budget, run, evaluation action."""
    return (f"{row_name(label, training)} — {budget(int(training['steps']))}; {training['algorithm']} on "
            f"{training['scenario']}, seed {training['seed']}; evaluated with {ACTION_TEXT[action(training)]}.")


def mark_note() -> str:
    return (f"{MARK} trained below the paper's budget of {paper_steps():,} environment steps: not the method's "
            "result, and not comparable with its published row.")


def notes(trained: Mapping[str, Mapping[str, Any]]) -> list[str]:
    """The footnote lines of the trained rows ``label -> training`` shown, in their order."""
    if not trained:
        return []
    out = [note(label, t) for label, t in trained.items()]
    if any(below(t) for t in trained.values()):
        out.append(mark_note())
    return out


def trainings(policies: Sequence[Mapping[str, Any]] | Mapping[str, Mapping[str, Any]] | None
              ) -> dict[str, dict[str, Any]]:
    """label -> training (with its action) of the trained policies among bundle identities."""
    items = policies.values() if isinstance(policies, Mapping) else (policies or ())
    out = {}
    for p in items:
        p = with_action(p)
        if isinstance(p.get("training"), Mapping):
            out[p["label"]] = dict(p["training"])
    return out
