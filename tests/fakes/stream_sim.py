#!/usr/bin/env python3
"""``agspec serve`` behind a chosen way of reading standard input (never shipped).

    python tests/fakes/stream_sim.py STRATEGY

``lines``     iterates over lines (correct);
``newline``   reads one byte at a time until a newline (correct);
``chunk``     one ``read()`` per request, answering only the first line of each chunk (wrong: F-PROTOCOL
              says the input is a stream of lines, and requests may arrive together);
``fixed[-N]`` fixed-size reads of N bytes (default 4,096), answering the first line of each and dropping the
              rest (wrong for every line longer than a read, and for requests that arrive together).
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent.parent))

from agspec.conform.impl.serve import Server  # noqa: E402
from agspec.formats.jsonl import compact_bytes  # noqa: E402


def requests(strategy: str):
    fd = sys.stdin.fileno()
    if strategy == "lines":
        yield from sys.stdin.buffer
    elif strategy == "newline":
        line = b""
        while (byte := os.read(fd, 1)):
            line += byte
            if byte == b"\n":
                yield line
                line = b""
    else:
        size = 1 << 20 if strategy == "chunk" else int(strategy.partition("-")[2] or 4096)
        while (chunk := os.read(fd, size)):
            yield chunk.split(b"\n", 1)[0]


def main() -> int:
    server, out = Server(), sys.stdout.buffer
    for line in requests(sys.argv[1]):
        try:
            msg = json.loads(line)
        except ValueError:
            continue
        out.write(compact_bytes(server.handle(msg)) + b"\n")
        out.flush()
        if server.stopped:
            return 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
