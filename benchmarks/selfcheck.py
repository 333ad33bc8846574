"""Long self-check of the reference on generated valid scenarios: scenarios x ticks checked, violations.

Usage:  python benchmarks/selfcheck.py [--budget 300] [--examples 1000] [--seed 0] [--horizon 60]
                                       [--cross-process-every 10] [--out DIR] [--json]

Draws scenarios across the space the DSL and IR accept (tests/strategies_scenarios.py), keeps the
ones `agspec validate` accepts (the acceptance rate is printed), and checks each one as
tests/reference_selfcheck.py describes: fmt fixpoint, fingerprints, a trace under every reference
controller and under random (partly illegal) actions checked like `agspec check`, and every K-th
scenario one run repeated in a fresh process. The bounded run is tests/test_selfcheck.py. Nothing is
asserted here; the target is 0 findings. With --out, the smallest scenario of each finding kind is
written there (its .ag texts and instance) as a reproducer.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from hypothesis import HealthCheck, Phase, given, seed as hseed, settings  # noqa: E402

from reference_selfcheck import Tally, check_bundle  # noqa: E402
from strategies_scenarios import Bundle, bundle_errors, raw_bundles, realize  # noqa: E402


class _OutOfBudget(BaseException):
    """Ends the hypothesis run once the time budget is spent (not an Exception: never shrunk)."""


def _size(bundle: Bundle) -> int:
    return sum(len(t) for t in bundle.texts.values())


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--budget", type=float, default=300.0, help="seconds to spend (default 300)")
    ap.add_argument("--examples", type=int, default=1000, help="scenarios to draw at most (default 1000)")
    ap.add_argument("--seed", type=int, default=0, help="hypothesis seed (default 0)")
    ap.add_argument("--horizon", type=int, default=60, help="ticks per run at most (default 60)")
    ap.add_argument("--cross-process-every", type=int, default=10,
                    help="repeat one run in a fresh process every K valid scenarios (0: never; default 10)")
    ap.add_argument("--out", type=Path, default=None, help="write one reproducer per finding kind here")
    ap.add_argument("--json", action="store_true", help="print the summary as JSON")
    args = ap.parse_args(argv)

    total = Tally()
    drawn = accepted = 0
    smallest: dict[str, tuple[int, Bundle, str]] = {}
    by_topology: dict[str, int] = {}
    started = time.perf_counter()
    work = Path(tempfile.mkdtemp(prefix="agspec-selfcheck-"))

    @settings(max_examples=args.examples, deadline=None, database=None, phases=[Phase.generate],
              suppress_health_check=list(HealthCheck))
    @hseed(args.seed)
    @given(raw_bundles(), __import__("hypothesis").strategies.integers(0, 3))
    def explore(bundle: Bundle, index: int) -> None:
        nonlocal drawn, accepted
        if time.perf_counter() - started > args.budget:
            raise _OutOfBudget
        drawn += 1
        if bundle_errors(bundle):
            return
        accepted += 1
        realized = realize(bundle, index)
        g = realized.scenario["grid"]
        key = f"{g['topology']} r{g['radius']}"
        by_topology[key] = by_topology.get(key, 0) + 1
        every = args.cross_process_every
        tally = check_bundle(realized, work / f"s{accepted}", horizon=args.horizon, seed=accepted,
                             cross_process="greedy" if every and accepted % every == 1 else None)
        total.add(tally)
        for f in tally.findings:
            size = _size(realized)
            if f.kind not in smallest or size < smallest[f.kind][0]:
                smallest[f.kind] = (size, realized, f"{f.run}: {f.detail}")

    try:
        explore()
    except _OutOfBudget:
        pass
    seconds = time.perf_counter() - started
    summary = {
        "seed": args.seed, "seconds": round(seconds, 1), "drawn": drawn, "accepted": accepted,
        "acceptance_rate": round(accepted / drawn, 3) if drawn else None,
        "scenarios": total.scenarios, "runs": total.runs, "ticks_checked": total.ticks,
        "by_topology": dict(sorted(by_topology.items())),
        "findings": len(total.findings), "findings_by_kind": total.kinds(),
        "events_exercised": dict(sorted(total.events.items())),
        "examples": {k: v[2][:300] for k, v in sorted(smallest.items())},
    }
    if args.out is not None:
        for kind, (_, bundle, detail) in smallest.items():
            d = args.out / kind
            d.mkdir(parents=True, exist_ok=True)
            for name, text in bundle.texts.items():
                (d / (name.replace(":", "-") + ".ag")).write_text(text, encoding="utf-8")
            (d / "instance.json").write_text(json.dumps(bundle.instance, indent=1), encoding="utf-8")
            (d / "finding.txt").write_text(detail + "\n", encoding="utf-8")
    if args.json:
        print(json.dumps(summary, indent=1))
    else:
        print(f"self-check: {drawn} scenarios drawn, {accepted} valid ({summary['acceptance_rate']}), "
              f"{total.runs} runs, {total.ticks} ticks checked in {seconds:.0f} s")
        print(f"  by topology: {summary['by_topology']}")
        print(f"  behaviour exercised: {summary['events_exercised']}")
        print(f"  findings: {len(total.findings)} {summary['findings_by_kind']}")
        for kind, text in summary["examples"].items():
            print(f"  e.g. {kind}: {text}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
