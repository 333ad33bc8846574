"""Every fix a diagnostic claims is correct, every misspelt name gets its right suggestion (F-FIX,
F-SUGGEST): the whole generator of tests/fix_cases.py.

Usage:  python benchmarks/fuzz_fixes.py [--every 1] [--show 20] [--from-hints]

Each case (the golden corpus of bad inputs; the catalogue mutated: precedences dropped, an earlier
operation consuming a later one's output, names, keywords and JSON fields misspelt by one edit,
`use` of official catalogue paths from an empty directory) is validated, and so is every command-line
name (controller, algorithm, scenario, spec ID) misspelt by one edit; every diagnostic's fix is
applied to the file and the file validated again: the fix is wrong if its error stays or an error
is added. For a misspelt name, the diagnostics must name the right one. Prints the figures; the
bounded share is tests/test_fixes.py.

Figures (shared 2-core machine):

* before diagnostics carried fixes — the agspec of 6a69b00, each hint's prose read as its edit:
  `python benchmarks/fuzz_fixes.py --every 5 --from-hints`: 907 documents, 591 command lines; 724
  edits, wrong: 6 AG305 "add `after X`" closing a precedence cycle (AG303), 49 AG305 "add `after
  X`" written as a second `after` field (AG206), 1 AG104 "did you mean `operation`" for a misplaced
  `duration` (85 AG204 edits in JSON that prose cannot place are not counted); right name not
  suggested: 330 of 1441 (197 recipe, profile and variant names in documents, 128 `run` controllers
  and scenarios, 5 `train --algorithm`).
* now, the same share: `python benchmarks/fuzz_fixes.py --every 5`: 907 documents, 614 command
  lines; 938 fixes, 0 wrong; 1464 misspelt names, 0 not suggested.
* now, all of it: `python benchmarks/fuzz_fixes.py`: 3612 documents, 3071 command lines; 3821
  fixes, 0 wrong; 6626 misspelt names, 0 not suggested.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from fix_cases import cases, check, check_cli, cli_cases  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--every", type=int, default=1, help="keep one misspelling in N (1: all)")
    ap.add_argument("--show", type=int, default=20, help="wrong cases printed")
    ap.add_argument("--from-hints", action="store_true",
                    help="read each fix from the hint's prose (how an agspec without F-FIX is measured)")
    args = ap.parse_args()
    tried = fixes = named_cases = unnamed = 0
    wrong: list[str] = []
    missed: list[str] = []
    with tempfile.TemporaryDirectory() as tmp:
        for n, case in enumerate(cases(args.every)):
            out = check(case, Path(tmp) / f"c{n}", args.from_hints)
            tried += 1
            fixes += out.fixes
            wrong += out.wrong_fixes or []
            if out.named is not None:
                named_cases += 1
                if not out.named:
                    unnamed += 1
                    missed.append(f"{case.name}: `{case.expect}` not suggested")
    cli_tried = 0
    for argv, name in cli_cases(args.every):
        cli_tried += 1
        if not check_cli(argv, name):
            unnamed += 1
            missed.append(f"agspec {' '.join(argv)}: `{name}` not suggested")
    named_cases += cli_tried
    for line in (wrong + missed)[:args.show]:
        print(line)
    print(f"inputs tried: {tried} documents, {cli_tried} command lines; fixes applied: {fixes}; "
          f"wrong fixes: {len(wrong)}; misspelt names: {named_cases}; right name not suggested: {unnamed}")
    return 1 if wrong or unnamed else 0


if __name__ == "__main__":
    sys.exit(main())
