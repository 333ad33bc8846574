"""Long search of the "a resumed run is not the run" class (spec/16-training.md, T-RESUME).

Usage:  python benchmarks/fuzz_resume.py [--algorithms ippo,mappo,qmix] [--cuts 1,2] [--mutants] [--json]

For each algorithm, trains the fuzzed tiny run once uncut, then once per cut point (every progress
notification, cut once or twice and resumed each time) and compares the final policy file's digest,
steps, updates and the training record without wall times (tests/train_cuts.py).  With --mutants, also
runs every seeded resumption bug at every cut point and counts the cut points that catch it.  The
bounded run is tests/test_train_resume.py.  Target: 0 violations without mutants; every mutant caught.
Nothing is asserted.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

import torch  # noqa: E402

from train_cuts import MUTANTS, cut_and_resume, cut_config, differences, mutant, outcome  # noqa: E402

from agspec.train.api import train  # noqa: E402

ROWS = 5


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--algorithms", default="ippo,mappo,qmix")
    ap.add_argument("--cuts", default="1,2")
    ap.add_argument("--mutants", action="store_true")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    torch.set_num_threads(1)
    report = {"tried": 0, "violations": [], "mutants": {}}
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        for algorithm in args.algorithms.split(","):
            config = cut_config(algorithm, root)
            train(config, root / f"{algorithm}-uncut")
            expected = outcome(root / f"{algorithm}-uncut")
            for cuts in map(int, args.cuts.split(",")):
                for row in range(1, ROWS):
                    report["tried"] += 1
                    diff = differences(expected, cut_and_resume(config, root / "run", row, cuts))
                    if diff:
                        report["violations"].append(f"{algorithm} cut at row {row} x{cuts}: {diff}")
            if args.mutants:
                for name in MUTANTS:
                    caught = 0
                    for row in range(1, ROWS):
                        with mutant(name):
                            caught += bool(differences(expected, cut_and_resume(config, root / "run", row)))
                    report["mutants"][f"{algorithm}:{name}"] = f"caught at {caught} of {ROWS - 1} cut points"
    report["seconds"] = round(time.perf_counter() - t0, 1)
    if args.json:
        print(json.dumps(report, indent=2))
        return
    print(f"cut-and-resume runs tried: {report['tried']}, violations: {len(report['violations'])}")
    for v in report["violations"]:
        print("  VIOLATION", v)
    for name, text in report["mutants"].items():
        print(f"  mutant {name}: {text}")
    print(f"{report['seconds']} s")


if __name__ == "__main__":
    main()
