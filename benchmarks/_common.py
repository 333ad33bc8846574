"""Shared helpers of the benchmark scripts: timing of subprocesses, peak memory, JSON + table output."""

from __future__ import annotations

import json
import platform
import resource
import shutil
import subprocess
import sys
import time
from pathlib import Path
from typing import Any, Sequence

ROOT = Path(__file__).resolve().parents[1]  # this checkout


def agspec_cmd() -> list[str]:
    """The CLI as a fresh process (cold start): the installed entry point, or `python -m`."""
    exe = shutil.which("agspec")
    return [exe] if exe else [sys.executable, "-c", "from agspec.cli.main import main; main()"]


def children_peak_mib() -> float:
    """Peak RSS of any waited-for child so far (ru_maxrss of RUSAGE_CHILDREN; KiB on Linux)."""
    return resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024


def self_peak_mib() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def timed_run(cmd: Sequence[str], **kw: Any) -> tuple[float, subprocess.CompletedProcess]:
    """Wall time of one subprocess run (stdout/stderr captured)."""
    t0 = time.perf_counter()
    proc = subprocess.run(list(cmd), capture_output=True, text=True, **kw)
    return time.perf_counter() - t0, proc


def machine() -> dict[str, Any]:
    import os

    return {"python": platform.python_version(), "platform": platform.platform(), "cpus": os.cpu_count(),
            "processor": platform.processor() or platform.machine()}


def emit(result: dict[str, Any], rows: list[dict[str, Any]], columns: Sequence[str], title: str, as_json: bool) -> None:
    """Print JSON (``--json``) or a plain table followed by the JSON on one line."""
    result = {**result, "machine": machine()}
    if as_json:
        print(json.dumps(result, indent=2))
        return
    widths = [max(len(c), *(len(_cell(r.get(c))) for r in rows)) if rows else len(c) for c in columns]
    print(title)
    print("  ".join(c.ljust(w) for c, w in zip(columns, widths)))
    print("  ".join("-" * w for w in widths))
    for r in rows:
        print("  ".join(_cell(r.get(c)).rjust(w) for c, w in zip(columns, widths)))
    print(json.dumps(result))


def _cell(v: Any) -> str:
    if isinstance(v, float):
        return f"{v:.3f}"
    return "—" if v is None else str(v)


# --------------------------------------------------------------------------- baseline side by side

BASELINE_ENV = "AGSPEC_BASELINE_PYTHON"


def _has_our_sources(package_dir: Path) -> bool:
    """Whether an agspec package holds every Python source of this checkout's, unchanged (an install
    may add files of its own: packaged data)."""
    ours = ROOT / "agspec"
    for path in ours.rglob("*.py"):
        theirs = package_dir / path.relative_to(ours)
        if not theirs.is_file() or theirs.read_bytes() != path.read_bytes():
            return False
    return True


def baseline_python(given: str | None) -> str | None:
    """The Python of a virtual environment with the baseline release installed (``--baseline-python``
    or $AGSPEC_BASELINE_PYTHON), or None: the scripts then print this build's figures only.

    Refused when the agspec that Python imports (as the baseline's CLI is started, from this
    checkout, :func:`baseline_cli`) has this build's sources — the checkout itself or a copy — since
    the "baseline" figures would then be this build's."""
    import os

    path = given or os.environ.get(BASELINE_ENV)
    if not path:
        return None
    if not os.path.exists(path):
        raise SystemExit(f"baseline python {path!r} does not exist (see docs/performance.md)")
    probe = subprocess.run([*baseline_cli(path)[:2], "-c", "import agspec; print(agspec.__file__)"],
                           capture_output=True, text=True, cwd=ROOT)
    if probe.returncode != 0:
        raise SystemExit(f"baseline python {path!r} cannot import agspec: {probe.stderr.strip()[-500:]}")
    imported = Path(probe.stdout.strip()).resolve().parent
    if _has_our_sources(imported):
        raise SystemExit(f"baseline python {path!r} imports agspec from {imported}, which has this build's "
                         "sources: install the baseline release in its own environment (see docs/performance.md)")
    return path


def baseline_cli(python: str) -> list[str]:
    """The baseline's CLI as a fresh process.  ``-P``: the working directory (this checkout, where the
    benchmarks run) is not put first on the module path, so the baseline's own agspec is imported."""
    return [python, "-P", "-c", "from agspec.cli.main import main; main()"]


def run_json(python: str, script: str, args: Sequence[str]) -> dict[str, Any]:
    """Run a benchmark script (its ``--json`` worker mode) under ``python``; its JSON result."""
    import os

    env = {k: v for k, v in os.environ.items() if k != BASELINE_ENV}  # the worker measures one side only
    proc = subprocess.run([python, script, *args, "--json"], capture_output=True, text=True, env=env)
    if proc.returncode != 0:
        raise SystemExit(f"{python} {script} {' '.join(args)} failed:\n{proc.stderr[-2000:]}")
    return json.loads(proc.stdout)


def paired(script: str, args: Sequence[str], reps: int, baseline: str | None,
           value: Any) -> dict[str, Any]:
    """Median of ``value(result)`` for this build and the baseline, runs interleaved (new, base,
    base, new, ...) so that load from other processes on a shared machine hits both sides alike."""
    import statistics

    sides = {"new": sys.executable, **({"baseline": baseline} if baseline else {})}
    samples: dict[str, list[float]] = {k: [] for k in sides}
    last: dict[str, dict[str, Any]] = {}
    for rep in range(reps):
        order = list(sides) if rep % 2 == 0 else list(reversed(sides))
        for side in order:
            last[side] = run_json(sides[side], script, args)
            samples[side].append(value(last[side]))
    out: dict[str, Any] = {side: statistics.median(v) for side, v in samples.items()}
    out["samples"] = samples
    out["last"] = last
    if baseline:
        out["ratio"] = out["new"] / out["baseline"] if out["baseline"] else None
    return out


def ratio_table(title: str, rows: list[dict[str, Any]], columns: Sequence[tuple[str, str]]) -> None:
    """A rich table of ``rows``; ``columns`` are (key, header) pairs; floats get 2-3 significant places."""
    from rich.console import Console
    from rich.table import Table

    table = Table(title=title)
    for key, header in columns:
        table.add_column(header, justify="left" if key in ("scenario", "controller", "cell", "scope", "side") else "right")
    for r in rows:
        table.add_row(*(_fmt(r.get(key)) for key, _ in columns))
    Console(width=160).print(table)  # not the 80-column default of a pipe: reports are read in files


def _fmt(v: Any) -> str:
    if isinstance(v, bool):
        return "yes" if v else "NO"
    if isinstance(v, float):
        return (f"{v:.2g}" if 0 < abs(v) < 0.01 else f"{v:.2f}") if abs(v) < 100 else f"{v:.0f}"
    return "—" if v is None else str(v)
