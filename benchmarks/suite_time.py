"""Where the test suite's time goes, and which tests leave the quick tier (tests/tiers.py).

Usage:
  python benchmarks/suite_time.py --junit run.xml [--threshold 2.0] [--write]
      reads the durations of a run (`pytest --junitxml run.xml -m "not slow and not ray and not browser"`,
      so every tier's tests are in it), prints the time by file and by tier, and with --write adds
      every test over the threshold to tests/extended.txt (entries already there stay: a test that
      left the quick tier comes back only by hand, after it was made faster)
  python benchmarks/suite_time.py --fresh [--python python3]
      the README's test command as a new user runs it: a clone of HEAD in a temporary directory, a
      fresh virtual environment, `pip install '.[test]'` and `pytest -q`, each timed (wall seconds),
      nothing cached from earlier runs (no .pytest_cache, no .hypothesis, a private golden cache)

The rule for the quick tier: a test case whose setup, call and teardown took more than the threshold
in the reference run (tests/extended.txt's header says which machine, load and threshold) is extended; a function whose every case is
over it is listed whole.  A matrix the quick tier samples (tests/tiers.py `sample_params`) is not
listed here.  Fixture costs move: when a listed test paid a module fixture's setup, the next quick
test pays it in the next run, which `--write` then lists too (run it until it adds nothing).
"""

from __future__ import annotations

import argparse
import collections
import os
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

import tiers  # noqa: E402  (tests/tiers.py: the tier list's one reader)


def durations(junit: Path) -> dict[str, tuple[float, bool]]:
    """node id -> (seconds, skipped) from a pytest junit file."""
    out = {}
    for case in ET.parse(junit).iter("testcase"):
        module = case.get("classname", "")
        path = module.replace(".", "/") + ".py"
        out[f"{path}::{case.get('name')}"] = (float(case.get("time", 0.0)), case.find("skipped") is not None)
    return out


def over(times: dict[str, tuple[float, bool]], threshold: float) -> dict[str, float]:
    """The entries the rule gives: node id (or function, when every case is over) -> seconds."""
    by_function: dict[str, list[tuple[str, float]]] = collections.defaultdict(list)
    for nodeid, (seconds, skipped) in times.items():
        if not skipped and nodeid.split("[", 1)[0] not in tiers.SAMPLED:
            by_function[nodeid.split("[", 1)[0]].append((nodeid, seconds))
    out = {}
    for function, cases in by_function.items():
        slow = [(n, s) for n, s in cases if s > threshold]
        if slow and len(slow) == len(cases) and len(cases) > 1:
            out[function] = sum(s for _, s in cases)
        else:
            out.update(slow)
    return out


def report(times: dict[str, tuple[float, bool]], listed: frozenset[str]) -> None:
    files: dict[str, list[float]] = collections.defaultdict(lambda: [0.0, 0.0])
    for nodeid, (seconds, _) in times.items():
        files[nodeid.split("::", 1)[0]][1 if tiers.extended(nodeid, listed) else 0] += seconds
    quick = sum(q for q, _ in files.values())
    extended = sum(e for _, e in files.values())
    print(f"{'file':48} {'quick s':>9} {'extended s':>11}")
    for name, (q, e) in sorted(files.items(), key=lambda kv: -sum(kv[1]))[:30]:
        print(f"{name:48} {q:9.1f} {e:11.1f}")
    print(f"{'all files':48} {quick:9.1f} {extended:11.1f}   (test time summed over the workers)")


def write(entries: dict[str, float], path: Path = tiers.LIST) -> int:
    have = {e.test for e in tiers.entries(path)}
    new = {t: s for t, s in entries.items() if t not in have and not any(t.startswith(h + "[") for h in have)}
    if new:
        with path.open("a", encoding="utf-8") as out:
            for test, seconds in sorted(new.items()):
                out.write(f"{seconds:6.1f}  {test}\n")
    return len(new)


def fresh(python: str) -> None:
    load = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as tmp:
        clone = Path(tmp) / "agspec"
        subprocess.run(["git", "clone", "-q", str(ROOT), str(clone)], check=True)
        env = {**os.environ, "XDG_CACHE_HOME": str(Path(tmp) / "cache"), "PIP_DISABLE_PIP_VERSION_CHECK": "1"}
        env.pop("VIRTUAL_ENV", None)
        subprocess.run([python, "-m", "venv", ".venv"], cwd=clone, check=True)
        env["PATH"] = f"{clone / '.venv' / 'bin'}{os.pathsep}{env['PATH']}"
        t0 = time.perf_counter()
        subprocess.run(["pip", "install", "-q", ".[test]"], cwd=clone, env=env, check=True)
        t1 = time.perf_counter()
        run = subprocess.run(["pytest", "-q"], cwd=clone, env=env, capture_output=True, text=True)
        t2 = time.perf_counter()
        lines = run.stdout.strip().splitlines()
        print("\n".join([line for line in lines if line.startswith(("FAILED", "ERROR"))] + lines[-1:])
              if lines else run.stderr[-2000:])
        print(f"install {t1 - t0:.0f} s, pytest {t2 - t1:.0f} s ({(t2 - t1) / 60:.1f} min), exit {run.returncode}, "
              f"load average before {load:.2f}, after {os.getloadavg()[0]:.2f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--junit", type=Path)
    ap.add_argument("--threshold", type=float, default=2.0)
    ap.add_argument("--write", action="store_true")
    ap.add_argument("--fresh", action="store_true")
    ap.add_argument("--python", default="python3")
    args = ap.parse_args()
    if args.fresh:
        fresh(args.python)
        return
    if args.junit is None:
        ap.error("give --junit FILE or --fresh")
    times = durations(args.junit)
    entries = over(times, args.threshold)
    if args.write:
        print(f"{write(entries)} test(s) added to {tiers.LIST.relative_to(ROOT)}")
    report(times, frozenset(e.test for e in tiers.entries()) | frozenset(entries))


if __name__ == "__main__":
    main()
