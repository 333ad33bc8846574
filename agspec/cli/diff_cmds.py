"""`agspec diff`: differential testing of two implementations with shrinking (F-CONFORM, F-REPRO)."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import click

from agspec.campaign.executor import ExecutorError, ExecutorSpec
from agspec.catalogue import CatalogueError, InvalidDocumentError, InvalidInstanceError, parse_indices
from agspec.cli.common import EXIT_HARNESS, EXIT_INVALID, EXIT_OK, EXIT_USAGE, FORMAT_OPTION, SEED_RANGE, Choice
from agspec.cli.common import emit_json, fail, stderr, stdout
from agspec.cli.executor_opts import executor_options
from agspec.cli.grammar import exitfirst_option, horizon_option, output_option, timeout_option
from agspec.conform.confirm import HISTORY_DEPENDENT, NONDETERMINISTIC, REPRODUCED
from agspec.conform.lockstep.compare import reply_name
from agspec.conform.run_item import LEVEL_PARTS
from agspec.conform.runner import EXIT_NONDETERMINISTIC, level_name
from agspec.formats import limits
from agspec.transport.teardown import exit_on_signals

DEFAULT_SCENARIOS = ("flow-easy", "coalition-medium", "concurrency-medium")


@click.command("diff")
@click.option("--impl", "impls", multiple=True, required=True, metavar="SPEC",
              help="An implementation (give exactly two): `reference`, `python:pkg.module:factory` or a command line.")
@click.option("--scenario", "scenarios", multiple=True, metavar="S",
              help="Catalogue scenario name, scenario .ag file or instance .json file (repeatable). "
                   f"Default: {', '.join(DEFAULT_SCENARIOS)}.")
@click.option("--indices", default="0", show_default=True, metavar="SPEC",
              help="Suite indices per catalogue scenario, e.g. 0-3 or 1000,1003 (one episode per index and "
                   "controller).")
@horizon_option("Ticks per episode.", default=60)
@click.option("--seed", type=SEED_RANGE, default=0, show_default=True,
              help="Seed of this command's own random choices: the controllers, small instances and hypothesis.")
@click.option("--controller", "controllers", multiple=True, type=Choice(["random", "greedy", "parallel-aware"]),
              help="Controllers choosing the actions (repeatable). Default: random and greedy.")
@click.option("--small", type=click.IntRange(0), default=1, show_default=True,
              help="Small generated instances per scenario (its recipes on a 1..3 x 2..4 grid).")
@click.option("--illegal-rate", type=click.FloatRange(0.0, 1.0), default=0.05, show_default=True,
              help="Share of generated actions replaced by illegal ones — masked or outside 0..113 — so that "
                   "action validation (R-ACTION-VALIDATION, `action_coerced`) is compared too (0: legal only).")
@click.option("--hypothesis-examples", type=click.IntRange(0), default=0, show_default=True,
              help="Also search hypothesis-generated joint-action sequences (this many examples).")
@output_option("The directory where the shrunk counterexample is saved (a conformance case file).",
               default="agspec-diff", file=False)
@timeout_option("Seconds per protocol request before a subprocess implementation counts as hung.", 5.0)
@click.option("--shrink-budget", type=click.IntRange(0), default=400, show_default=True,
              help="At most this many replays while shrinking (0: do not shrink).")
@click.option("--shrink-seconds", type=click.FloatRange(min=0.0), default=120.0, show_default=True,
              help="Time limit of shrinking.")
@click.option("--any-divergence", is_flag=True,
              help="While shrinking, accept any divergence (default: the same compared part and pointer shape).")
@exitfirst_option(True)
@FORMAT_OPTION
@click.option("-j", "--jobs", type=click.IntRange(1, 256), default=None,
              help="Workers, each with its own pair of implementations (default: 1 locally; with --executor ray "
                   "every CPU).")
@executor_options
def diff(impls, scenarios, indices, horizon, seed, controllers, small, illegal_rate, hypothesis_examples, output,
         timeout, shrink_budget, shrink_seconds, any_divergence, exitfirst, fmt, jobs,
         campaign: ExecutorSpec) -> None:
    """Drive two implementations in lockstep on generated episodes; shrink and save the first divergence.

    Actions come from seeded random and greedy controllers acting on the driver's observations (the
    reference if one side is `reference`, else A) and, with --hypothesis-examples, from hypothesis-
    generated joint-action sequences drawn from the masks; --illegal-rate of them (default 5 %) are
    replaced by illegal actions, masked or out of range, which both sides must coerce to idle.
    States, events, observations, masks and the end flag are compared every tick. Exit 0: no
    divergence; 1: divergent; 3: an implementation failed (crash, timeout, protocol) or nothing was
    compared; 5: the divergence does not reproduce on replay (nondeterministic implementation); 2: usage.

    One instance (its episodes with every controller) is one campaign item: with -j N or --executor
    ray the instances run on workers, each with its own pair of implementations, and the output and
    the saved counterexample are the same as with -j 1 (CAMP-IDENTICAL). Shrinking and the
    hypothesis search run in this process.
    """
    from agspec.conform.explore import diff as D

    ticks, impl_timeout, out_dir, keep_going = horizon, timeout, Path(output), not exitfirst
    try:
        wanted = parse_indices(indices, limit=10_000)
    except CatalogueError as exc:
        fail(f"--indices: {exc}", EXIT_USAGE)
    if len(impls) != 2:
        fail(f"give exactly two implementations (--impl A --impl B), got {len(impls)}", EXIT_USAGE)
    quiet = fmt == "json"
    log = (lambda *a, **k: None) if quiet else stderr.print

    subjects: list[D.Subject] = []
    for target in scenarios or DEFAULT_SCENARIOS:
        try:
            subjects += D.load_subjects(target, wanted, seed, small=small)
        except limits.InputError as exc:
            fail(f"--scenario {target}: {exc}", exc.exit_code)
        except (InvalidDocumentError, InvalidInstanceError) as exc:  # F-EXIT-CODES: invalid input
            fail(f"--scenario {target}: {exc}", EXIT_INVALID)
        except Exception as exc:  # CatalogueError (unknown name, unreadable file): usage errors
            fail(f"--scenario {target}: {exc}", EXIT_USAGE)
    # SIGTERM / SIGHUP raise SystemExit, so pair.close() below kills both process groups (F-PROTOCOL-TEARDOWN)
    click.get_current_context().with_resource(exit_on_signals())
    pair = _open_pair(impls, impl_timeout)

    start = time.perf_counter()
    findings: list[D.Finding] = []
    report: dict[str, Any] = {"implementations": {"A": impls[0], "B": impls[1]}, "driver": pair.expected_side,
                              "illegal_rate": illegal_rate}
    # F-CONFORM-LEVELS: what the pair can compare is what both declare
    proven = [p for p in LEVEL_PARTS if p in pair.parts()]
    report["level"] = level_name(proven)
    here = D.inline(campaign)
    if not here:  # the workers open their own pairs; the driver's is reopened for shrinking (CAMP-EXECUTOR)
        pair.close()
    try:
        log(f"[bold]agspec diff[/]: A = {impls[0]}, B = {impls[1]}; expected values from "
            f"{pair.expected_side} ({pair.expected_label}); {len(subjects)} instance(s); "
            f"{illegal_rate:.0%} of the actions illegal (masked or out of range, F-DIFF-ACTIONS)")

        def on_episode(label: str, run: D.Run) -> None:
            status = "[green]same[/]" if run.divergence is None else "[red]DIVERGES[/]"
            log(f"  {label:<48} {run.ticks:>4} ticks  {status}")

        try:
            exploration = D.explore(pair, subjects, controllers=controllers or ("random", "greedy"), seed=seed,
                                    ticks=ticks, on_episode=on_episode, first_only=not keep_going,
                                    executor=campaign, specs=(impls[0], impls[1]), timeout=impl_timeout,
                                    illegal_rate=illegal_rate)
        except ExecutorError as exc:  # CAMP-EXECUTOR: an executor that cannot start is a usage error, as elsewhere
            fail(str(exc))
        findings += exploration.findings
        for subject, cause in exploration.errors:  # CAMP-FAULTS: reported, never dropped
            log(f"  {subject.label:<48} [red]ERROR[/] {cause}")
        if not here and (exploration.findings or (hypothesis_examples and (keep_going or not findings))):
            pair = _open_pair(impls, impl_timeout)  # shrinking and hypothesis run here (RES-CAMP-DIFF)
            here = True
        if hypothesis_examples and (keep_going or not findings):
            log(f"  hypothesis: up to {hypothesis_examples} joint-action sequences of <= {min(ticks, 40)} ticks …")
            found, tried = D.hypothesis_search(pair, subjects, examples=hypothesis_examples, ticks=min(ticks, 40),
                                               seed=seed, illegal_rate=illegal_rate)
            exploration.hypothesis_examples = tried
            log(f"  hypothesis: {tried} sequences tried, " + ("a divergence" if found else "no divergence"))
            if found is not None:
                findings.append(found)
        report["compared"] = {"episodes": exploration.episodes, "ticks": exploration.ticks,
                              "states": exploration.states, "hypothesis_examples": exploration.hypothesis_examples}
        report["errors"] = [{"instance": subject.label, "error": cause} for subject, cause in exploration.errors]
        report["findings"] = []
        for finding in findings:
            entry = _report_finding(pair, finding, out_dir, shrink_budget, shrink_seconds, any_divergence, log, quiet,
                                    (impls[0], impls[1]), impl_timeout)
            report["findings"].append(entry)
    finally:
        if here:
            pair.close()
    report["seconds"] = round(time.perf_counter() - start, 3)

    vacuous = (report["compared"]["ticks"] == 0 and report["compared"]["hypothesis_examples"] == 0 and not findings) \
        or not proven
    errors = [f for f in findings if f.run.divergence.where == "error"]
    flaky = [e for e in report.get("findings", []) if e.get("nondeterministic")]
    code = EXIT_HARNESS if (errors or report["errors"] or vacuous) else (EXIT_INVALID if findings else EXIT_OK)
    if flaky and not vacuous:
        code = EXIT_NONDETERMINISTIC
    report["exit"] = code
    if quiet:
        emit_json(report, "diff")
    else:
        c = report["compared"]
        summary = (f"level {report['level']}: {c['episodes']} episode(s), {c['ticks']} ticks compared"
                   + (f", {c['hypothesis_examples']} hypothesis sequences" if c["hypothesis_examples"] else "")
                   + f" in {report['seconds']:.1f} s: ")
        if vacuous:
            stdout.print(summary + "[red]nothing was compared[/] (vacuous run)")
        elif flaky:
            stdout.print(summary + "[bold red]nondeterministic implementation[/]: the divergence does not reproduce "
                         "when the same actions are replayed (see the replays above)")
        elif report["errors"]:
            stdout.print(summary + f"[red]{len(report['errors'])} instance(s) not compared[/]: their worker failed "
                         f"(see above); {len(findings)} divergent episode(s)")
        elif not findings:
            stdout.print(summary + "[green]no divergence[/]")
        else:
            history = sum(1 for e in report["findings"] if e.get("history_dependent"))
            stdout.print(summary + f"[red]{len(findings)} divergent episode(s)[/]"
                         + (f", {history} of them history-dependent (F-CONFORM-HISTORY)" if history else ""))
    raise SystemExit(code)


def _open_pair(impls, timeout: float):
    from agspec.conform.explore import diff as D

    try:
        return D.open_pair(impls[0], impls[1], timeout=timeout)
    except D.ImplementationFailure as exc:
        fail(exc.message, EXIT_HARNESS)
    except ValueError as exc:
        fail(str(exc), EXIT_USAGE)


def _report_finding(pair, finding, out_dir: Path, budget: int, seconds: float, any_divergence: bool, log,
                    quiet: bool, impls: tuple[str, str], impl_timeout: float) -> dict[str, Any]:
    from agspec.conform.explore import diff as D
    from agspec.conform.explore import shrink as S

    run, subject = finding.run, finding.subject
    d = run.divergence
    entry: dict[str, Any] = {"instance": subject.label, "policy": finding.policy, "divergence": d.to_json(),
                             "ticks": run.ticks, "actions": sum(1 for _ in D.non_idle(run.script))}
    # F-CONFORM-NONDETERMINISM, F-CONFORM-HISTORY: the original failure is judged as `agspec conform` judges
    # its own — replayed in fresh implementations, alone and then after its processes' history — before
    # it is worth shrinking
    # (an implementation that failed a request is a harness error, exit 3, and not judged — as in conform)
    kind, alone, with_history = (REPRODUCED, [], []) if d.where == "error" else D.judge_divergence(
        impls, impl_timeout, subject.instance, subject.execution_seed, run.script, d, d.tick + 1, finding.history)
    original = _reproductions(alone)
    if kind == NONDETERMINISTIC:
        entry["nondeterministic"] = {"original": original, "final": None}
        if not quiet:
            _print_nondeterministic(finding, original, None)
        return entry
    if kind == HISTORY_DEPENDENT:
        entry["history_dependent"] = _history_dependent(pair, finding, out_dir, original,
                                                        _reproductions(with_history))
        if not quiet:
            _print_history_dependent(finding, entry["history_dependent"])
        return entry
    if budget > 0:
        log(f"  shrinking ({budget} replays / {seconds:.0f} s at most) …")
        shrunk = S.shrink(pair, subject.instance, subject.execution_seed, run.script, d, max_checks=budget,
                          max_seconds=seconds, same_signature=not any_divergence)
    else:
        shrunk = S.Shrunk(subject.instance, subject.execution_seed, S.trim_script(run.script[: d.tick + 1]), d,
                          original_ticks=max(0, d.tick + 1), original_actions=entry["actions"])

    def judged(candidate) -> tuple[str, list[dict[str, Any]]]:
        if d.where == "error":
            return REPRODUCED, []
        verdict, runs, _ = D.judge_divergence(impls, impl_timeout, candidate.instance, candidate.execution_seed,
                                              candidate.script, candidate.divergence, max(1, candidate.ticks), None)
        return verdict, runs

    kind, alone = judged(shrunk)
    actions = None
    if kind != REPRODUCED and budget > 0:
        # shrinking replays in the same processes; a counterexample it found there that a fresh process does
        # not repeat (it needed that history) is dropped for the original episode, which does (judged above)
        original_episode = S.Shrunk(subject.instance, subject.execution_seed, S.trim_script(run.script[: d.tick + 1]),
                                    d, original_ticks=max(0, d.tick + 1), original_actions=entry["actions"],
                                    checks=shrunk.checks, seconds=shrunk.seconds, instance_notes=[
                                        "the shrunk counterexample did not diverge in fresh implementations; this is "
                                        "the original episode (F-CONFORM-HISTORY)"])
        kind, alone = judged(original_episode)
        shrunk, actions = original_episode, run.actions[: d.tick + 1]
    finding.shrunk = shrunk
    final = replay_check(pair, shrunk) if actions is None else None
    coerced = final.coerced > 0 if final is not None else run.coerced > 0
    actions = final.actions if final is not None else actions
    again = _reproductions(alone)
    if kind != REPRODUCED:
        entry["nondeterministic"] = {"original": original, "final": again}
    title = (f"diff: {pair.expected_label} vs {pair.actual_label}: {shrunk.divergence.where} "
             f"{shrunk.divergence.pointer or ''} {reply_name(shrunk.divergence.tick, short=True)}")
    notes = (f"Found by `agspec diff` on {subject.label} with {finding.policy} ({entry['ticks']} ticks, "
             f"{entry['actions']} non-idle actions); shrunk to {shrunk.ticks} ticks and {shrunk.actions} non-idle "
             f"actions in {shrunk.checks} replays. Expected values are {pair.expected_label}'s.")
    stem = f"diff-{_slug(subject.label)}-t{shrunk.divergence.tick}"
    path = S.write_case(shrunk, out_dir, stem, title=title, notes=notes, coerced=coerced)
    repro = None
    if actions is not None:  # F-REPRO: integer actions, replayable with `agspec conform --replay`
        from agspec.conform.repro import make_reproducer, save_reproducer

        repro = save_reproducer(out_dir, make_reproducer(
            ident=stem, title=title, instance=shrunk.instance, execution_seed=shrunk.execution_seed,
            actions=actions, impl=pair.other_spec, failure=shrunk.divergence.to_json()))
    entry["shrunk"] = {"divergence": shrunk.divergence.to_json(), "ticks": shrunk.ticks, "actions": shrunk.actions,
                       "script": shrunk.script, "replays": shrunk.checks, "seconds": round(shrunk.seconds, 3),
                       "instance": shrunk.instance_notes, "budget_exhausted": shrunk.exhausted,
                       "reproduces": kind == REPRODUCED,
                       "case": str(path), "reproducer": str(repro) if repro else None}
    if not quiet:
        if entry.get("nondeterministic"):
            _print_nondeterministic(finding, original, again)
        else:
            _print_counterexample(pair, finding, shrunk, path, entry)
    return entry


def _reproductions(runs: list[dict[str, Any]]) -> dict[str, Any]:
    """F-CONFORM-NONDETERMINISM: fresh replays and how often the divergence recurred (the report's form)."""
    kept = [{k: v for k, v in r.items() if k != "signature"} for r in runs]
    return {"replays": len(kept), "reproduced": sum(1 for r in kept if r.get("same")), "runs": kept}


def _history_dependent(pair, finding, out_dir: Path, alone: dict[str, Any], again: dict[str, Any]) -> dict[str, Any]:
    """F-CONFORM-HISTORY: the facts and a reproducer that replays the history first (F-REPRO)."""
    from agspec.conform.confirm import history_facts
    from agspec.conform.repro import make_reproducer, save_reproducer

    d, subject = finding.run.divergence, finding.subject
    history = (finding.history or {}).get(pair.actual_side) or ()
    facts = history_facts(f"the divergence on {subject.label}", history)
    ident = f"diff-{_slug(subject.label)}-t{d.tick}-history"
    data = make_reproducer(ident=ident, title=f"diff: {d.where} {d.pointer or ''} after the process's history",
                           instance=subject.instance, execution_seed=subject.execution_seed,
                           actions=finding.run.actions[: d.tick + 1], impl=pair.other_spec, failure=d.to_json(),
                           history=history)
    try:
        path = str(save_reproducer(out_dir, data))
    except OSError:
        path = None
    return {**facts, "replays": alone, "with_history": again, "reproducer": path}


def _print_history_dependent(finding, facts: dict[str, Any]) -> None:
    d = finding.run.divergence
    stdout.print(f"\n[bold red]history-dependent divergence[/] on {finding.subject.label} with {finding.policy}: "
                 f"{d.where} {d.pointer or ''} {reply_name(d.tick, short=True)} — {facts['message']}", markup=True)
    if facts.get("reproducer"):
        stdout.print(f"  reproducer (with that history): {facts['reproducer']}", markup=False)


def _print_nondeterministic(finding, original: dict[str, Any], final: dict[str, Any] | None) -> None:
    d = finding.run.divergence
    stdout.print(f"\n[bold red]nondeterministic implementation[/] on {finding.subject.label} with {finding.policy}: "
                 f"the divergence {d.where} {d.pointer or ''} {reply_name(d.tick, short=True)} recurred in "
                 f"{original['reproduced']} of {original['replays']} replays of the same actions"
                 + (f", the shrunk counterexample in {final['reproduced']} of {final['replays']}" if final else ""),
                 markup=True)
    for k, r in enumerate((final or original)["runs"]):
        what = (f"diverged {reply_name(r['tick'], short=True)}: {r['where']} {r['pointer'] or ''}" if r.get("diverged")
                else r.get("error") or "no divergence")
        stdout.print(f"    replay {k + 1}: {what}", markup=False)


def replay_check(pair, shrunk):
    """Replay the shrunk counterexample once more (it must still diverge)."""
    from agspec.conform.explore import diff as D

    try:
        return D.replay(pair, shrunk.instance, shrunk.execution_seed, shrunk.script, max(1, shrunk.ticks))
    except Exception:
        return None


def _slug(text: str) -> str:
    out = "".join(ch if ch.isalnum() or ch in "-_." else "-" for ch in text)
    return "-".join(p for p in out.split("-") if p)[:60]


def _print_counterexample(pair, finding, shrunk, path: Path, entry: dict[str, Any]) -> None:
    repro = entry["shrunk"].get("reproducer")
    from agspec.conform.explore import diff as D

    d0, d = finding.run.divergence, shrunk.divergence
    stdout.print(f"\n[bold red]divergence[/] on {finding.subject.label} with {finding.policy}: "
                 f"{d0.where} {d0.pointer or ''} {reply_name(d0.tick, short=True)}", markup=True)
    stdout.print(f"[bold]minimal counterexample[/] ({entry['ticks']} -> {shrunk.ticks} ticks, "
                 f"{entry['actions']} -> {shrunk.actions} non-idle actions, {shrunk.checks} replays, "
                 f"{shrunk.seconds:.1f} s{'; budget exhausted' if shrunk.exhausted else ''})", markup=True)
    for note in shrunk.instance_notes:
        stdout.print(f"  instance: {note}", markup=False)
    stdout.print("  " + d.show(f"expected ({pair.expected_label})", f"actual   ({pair.actual_label})")
                 .replace("\n", "\n  "), markup=False)
    actions = list(D.non_idle(shrunk.script))
    if actions:
        stdout.print("  actions (all others idle):", markup=False)
        for t, robot, a in actions:
            stdout.print(f"    t={t:<4} {robot:<6} {D.describe_action(a)}", markup=False)
    else:
        stdout.print("  actions: none (every robot idles)", markup=False)
    impl = pair.other_spec
    impl = f'"{impl}"' if " " in impl else impl
    stdout.print(f"  saved case: {path}", markup=False)
    stdout.print(f"    replay:  agspec conform --impl {impl} --suite {path.parent.parent} --episodes 0", markup=False)
    if repro:
        stdout.print(f"  reproducer: {repro}", markup=False)
        stdout.print(f"    replay:  agspec conform --impl {impl} --replay {repro}", markup=False)
