"""The teardown generator's one case (F-PROTOCOL-TEARDOWN), shared by tests/test_conform_teardown.py
(each holder and each ending once) and benchmarks/fuzz_harness.py (the whole product): a simulator of
tests/fakes/scripted_sim.py that leaves a process behind holding its pipes (``daemon``: in a session
of its own, only stdout, only stderr, or its own process group), ending its session by ``end`` (a
clean stop, a crash, a hang)."""

from __future__ import annotations

import json
import time
from pathlib import Path

from scoping_cases import scripted

from agspec.conform import runner
from agspec.conform.impl import SubprocessImpl
from agspec.conform.items import catalogue_episodes

DAEMONS = ("session", "stdout", "stderr", "group")
ENDS = ("stop", "crash", "hang")


def tagged_processes(tag: str) -> list[int]:
    """Processes whose command line carries ``tag`` (a left-behind daemon is a fork of the simulator)."""
    out = []
    for proc in Path("/proc").iterdir():
        if proc.name.isdigit():
            try:
                if tag.encode() in (proc / "cmdline").read_bytes():
                    out.append(int(proc.name))
            except OSError:
                pass
    return out


def run_case(daemon: str, end: str, tag: str) -> tuple[float, str]:
    """One flow-easy episode of 3 ticks against that simulator: (seconds until closed, outcome)."""
    fail = {"": {"cmd": "step", "mode": end, "at": 1}} if end != "stop" else {}
    spec = scripted("--daemon", daemon, "--fail", json.dumps(fail), "--tag", tag)
    t0 = time.monotonic()
    impl = SubprocessImpl(spec, 2.0)
    try:
        summary = runner.run(catalogue_episodes(1, 3, ["flow-easy"]), spec, impl=impl, replays=0)
    finally:
        impl.close()
    return time.monotonic() - t0, summary.results[0][1]
