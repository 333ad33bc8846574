#!/usr/bin/env python3
"""``agspec serve`` behind a wrapper that is wrong in every N-th reply of its process (never shipped).

    python tests/fakes/every_nth_sim.py N

Reply number N, 2N, … of this process (counting every reply) has ``/state/released`` raised by one: a
simulator whose answers depend on how many requests its process has served, so a failure recurs in a
fresh process only after the same history (F-CONFORM-HISTORY).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent.parent))

from agspec.conform.impl.serve import Server  # noqa: E402
from agspec.formats.jsonl import compact_bytes  # noqa: E402


def main() -> int:
    every = int(sys.argv[1]) if len(sys.argv) > 1 else 50
    server, served = Server(), 0
    out = sys.stdout.buffer
    for line in sys.stdin.buffer:
        if not line.strip():
            continue
        reply = server.handle(json.loads(line))
        served += 1
        if served % every == 0 and isinstance(reply.get("state"), dict) and "released" in reply["state"]:
            reply["state"]["released"] += 1
        out.write(compact_bytes(reply) + b"\n")
        out.flush()
        if server.stopped:
            return 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
