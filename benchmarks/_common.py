"""Shared helpers of the benchmark scripts: timing of subprocesses, peak memory, JSON + table output."""

from __future__ import annotations

import json
import platform
import resource
import shutil
import subprocess
import sys
import time
from typing import Any, Sequence


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
