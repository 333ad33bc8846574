"""Long run of the misleading-numbers class (F-POLICY-COVERAGE): generated bundles, violations found.

Usage:  python benchmarks/fuzz_policy_reports.py [--bundles 40] [--no-plan] [--pythonpath DIR] [--json]

Bundles come from the strategy of tests/test_policy_reports.py (any mix of ok, failed and missing
episodes, subsets of a split, several policies).  Each is rendered by ``report --to markdown``,
``report --to latex``, ``evaluate --from`` and ``evaluate --from --format json`` in a fresh process,
without ``--allow-incomplete``.  A violation is a rendering that

* exits 0, or prints a summary number, while a row has errors or missing episodes;
* shows a row of a complete bundle without its n;
* cuts a table ("…");
* names a split without its count ("final-test" instead of "10 of 50 final-test instances");
* shows the published (final-test) rows beside other instances, or without saying their interval
  is over training seeds.

``--pythonpath DIR`` renders with another build (for a before/after figure; an older build reads
only bundles without ``planned``: add ``--no-plan``).  The target is 0; nothing is asserted.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _common import ROOT, emit

sys.path.insert(0, str(ROOT / "tests"))

from hypothesis import HealthCheck, given, settings  # noqa: E402

from test_policy_reports import bundles, incomplete_cells, table_lines  # noqa: E402

from agspec.policy.coverage import describe_indices  # noqa: E402

RENDERERS = (("report", "{b}", "--to", "markdown"), ("report", "{b}", "--to", "latex"),
             ("evaluate", "--from", "{b}"), ("evaluate", "--from", "{b}", "--format", "json"))


def render(args: tuple[str, ...], bundle: Path, pythonpath: str | None) -> subprocess.CompletedProcess:
    env = dict(os.environ, COLUMNS="80")
    if pythonpath:
        env["PYTHONPATH"] = pythonpath
    cmd = [sys.executable, "-m", "agspec.cli.main", *(a.format(b=bundle) for a in args)]
    return subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=tempfile.gettempdir(), timeout=300)


def violations_of(doc: dict, truth: dict, res: subprocess.CompletedProcess, args: tuple[str, ...]) -> list[str]:
    out, found = res.stdout, []
    name = " ".join(a for a in args if a != "{b}")
    if res.returncode == 2:
        return [f"{name}: the bundle was not read ({res.stderr.strip()[:120]})"]
    incomplete = incomplete_cells(truth)
    if incomplete and res.returncode == 0:
        found.append(f"{name}: exit 0 with {len(incomplete)} incomplete row(s)")
    if incomplete and ("±" in out or r"\pm" in out or '"mean"' in out):
        if not all("‡" in line or r"\ddagger" in line for label, _ in incomplete
                   for line in table_lines(out, label)):
            found.append(f"{name}: numbers printed for an incomplete row without a mark")
    if "…" in out:
        found.append(f"{name}: a table was cut")
    if out.strip() and "json" not in args:
        if describe_indices(truth["indices"], truth["split"]) not in out.replace("--", "–"):
            found.append(f"{name}: the instance set is not stated as "
                         f"{describe_indices(truth['indices'], truth['split'])!r}")
        if not incomplete:
            for label in truth["labels"]:
                planned = next(iter(truth["cells"].values()))[0]
                lines = table_lines(out, label)
                if not lines or not all(re.search(rf"[|│&]\s*{planned}\s*[|│&]", line) for line in lines):
                    found.append(f"{name}: row {label} does not show n = {planned}")
                    break
        published = "(published)" in out
        if published and truth["split"] != "final-test":
            found.append(f"{name}: published final-test rows beside {truth['split']} instances")
        if published and "training seeds" not in out:
            found.append(f"{name}: published rows without 'training seeds'")
    return found


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bundles", type=int, default=40)
    ap.add_argument("--no-plan", action="store_true", help="bundles without the `planned` header field")
    ap.add_argument("--pythonpath", default=None, help="render with the agspec found here")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    work = Path(tempfile.mkdtemp(prefix="agspec-reports-"))
    tried, bad, examples = 0, 0, []
    started = time.perf_counter()

    @settings(max_examples=args.bundles, deadline=None, database=None, suppress_health_check=list(HealthCheck))
    @given(bundles())
    def one(case) -> None:
        nonlocal tried, bad
        doc, truth = case
        if args.no_plan:
            doc = {k: v for k, v in doc.items() if k != "planned"}
        tried += 1
        path = work / f"b{tried}.json"
        path.write_text(json.dumps(doc))
        found = [v for r in RENDERERS for v in violations_of(doc, truth, render(r, path, args.pythonpath), r)]
        bad += bool(found)
        examples.extend(f"bundle {tried}: {v}" for v in found[:2])
        print(f"bundle {tried}: {len(found)} violation(s)", flush=True)

    one()
    result = {"bundles_tried": tried, "bundles_with_violations": bad, "examples": examples[:25],
              "seconds": round(time.perf_counter() - started, 1), "build": args.pythonpath or "this checkout"}
    emit(result, [result], ["bundles_tried", "bundles_with_violations", "seconds"], "misleading-number bundles",
         args.json)


if __name__ == "__main__":
    main()
