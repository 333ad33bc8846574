"""Where the cold start of `agspec validate catalogue/*/*.ag` goes: import time per top-level package
(python -X importtime, cumulative, first import wins) and the slowest functions after import (cProfile).

Usage:  python benchmarks/profile_validate.py [--top 12] [--json]
"""

from __future__ import annotations

import argparse
import cProfile
import io
import json
import pstats
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RUN = ("import sys, glob; from agspec.cli.main import main; "
       "sys.argv = ['agspec', 'validate', *sorted(glob.glob('catalogue/*/*.ag'))]; main()")


def import_times() -> dict[str, float]:
    """Cumulative import seconds per top-level package (only the outermost import of each is counted)."""
    proc = subprocess.run([sys.executable, "-X", "importtime", "-c", RUN], cwd=ROOT, capture_output=True, text=True)
    totals: dict[str, float] = {}
    for line in proc.stderr.splitlines():
        if not line.startswith("import time:") or "cumulative" in line:
            continue
        _, cumulative, name = (part.strip() for part in line[len("import time:"):].split("|"))
        if name != name.lstrip():
            continue
        indent = len(line.split("|")[2]) - len(line.split("|")[2].lstrip()) - 1
        top = name.split(".")[0]
        if indent == 0:  # a top-level import statement of the running program
            totals[top] = totals.get(top, 0.0) + int(cumulative) / 1e6
    return dict(sorted(totals.items(), key=lambda kv: -kv[1]))


THIRD_PARTY = ("networkx", "jsonschema", "lark", "click", "rich", "rfc8785", "yaml", "referencing")


def package_times() -> dict[str, float]:
    """Cumulative import seconds of the main third-party packages, wherever they are first imported."""
    proc = subprocess.run([sys.executable, "-X", "importtime", "-c", RUN], cwd=ROOT, capture_output=True, text=True)
    found: dict[str, float] = {}
    for line in proc.stderr.splitlines():
        parts = line[len("import time:"):].split("|") if line.startswith("import time:") else []
        if len(parts) == 3 and parts[2].strip() in THIRD_PARTY:
            found[parts[2].strip()] = max(found.get(parts[2].strip(), 0.0), int(parts[1]) / 1e6)
    return dict(sorted(found.items(), key=lambda kv: -kv[1]))


def hot_functions(top: int) -> list[dict]:
    sys.path.insert(0, str(ROOT))
    import glob
    import os

    os.chdir(ROOT)
    sys.argv = ["agspec", "validate", *sorted(glob.glob("catalogue/*/*.ag"))]
    prof = cProfile.Profile()
    out = io.StringIO()
    from contextlib import redirect_stdout

    prof.enable()
    try:
        with redirect_stdout(out):
            from agspec.cli.main import main

            main()
    except SystemExit:
        pass
    prof.disable()
    stats = pstats.Stats(prof)
    rows = []
    for (file, line, func), (_, _, _, cum, _) in stats.stats.items():  # type: ignore[attr-defined]
        if "/agspec/" in file and "<frozen" not in file:
            rows.append({"function": f"{Path(file).parent.name}/{Path(file).name}:{func}", "cumulative_s": cum})
    rows.sort(key=lambda r: -r["cumulative_s"])
    return rows[:top]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--top", type=int, default=12)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    imports = import_times()
    packages = package_times()
    hot = hot_functions(args.top)
    result = {"benchmark": "profile-validate", "imports_s": imports, "third_party_s": packages, "hot_functions": hot}
    if args.json:
        print(json.dumps(result, indent=2))
        return
    print("import time per top-level import (s, cumulative):")
    for name, sec in list(imports.items())[: args.top]:
        print(f"  {name:<32} {sec:7.3f}")
    print("third-party packages (s, cumulative, where first imported):")
    for name, sec in packages.items():
        print(f"  {name:<32} {sec:7.3f}")
    print("slowest agspec functions (cumulative s, one in-process run incl. lazy imports):")
    for r in hot:
        print(f"  {r['function']:<60} {r['cumulative_s']:7.3f}")


if __name__ == "__main__":
    main()
