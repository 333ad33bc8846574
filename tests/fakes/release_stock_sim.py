#!/usr/bin/env python3
"""A simulator that behaves like the original release at a release opportunity (DIV-RELEASE-STOCK).

    python tests/fakes/release_stock_sim.py [--no-events] [--no-state]

The reference interpreter behind the protocol (agspec.conform.impl.serve.Server), except that R-RELEASE
checks only the WIP cap: a product is released even when a source row of its raw material is empty,
as the original release does (spec/10-divergences.md, DIV-RELEASE-STOCK). Everything else follows
the reference, so the only failure it can show is that divergence. ``--no-events`` and
``--no-state`` drop the capability, to test that the divergence is named from either part.
"""

from __future__ import annotations

import argparse
import json
import sys

from agspec.conform.impl.serve import Server
from agspec.interp import rules

_release = rules.release_product


def release_ignoring_stock(state, model, events, forced: bool = False) -> None:
    """R-RELEASE without its raw-material clause: every empty stock looks stocked during the check."""
    saved = [dict(shelf) for shelf in state.shelves]
    for shelf in state.shelves:
        for token in shelf:
            shelf[token] = max(1, shelf[token])
    try:
        _release(state, model, events, forced)
    finally:
        for shelf, before in zip(state.shelves, saved):
            shelf.update(before)


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("--no-events", action="store_true")
    parser.add_argument("--no-state", action="store_true")
    args = parser.parse_args()
    rules.release_product = release_ignoring_stock
    server = Server(observations=False, masks=False)
    for line in sys.stdin:
        if not line.strip():
            continue
        msg = json.loads(line)
        reply = server.handle(msg)
        if msg.get("cmd") == "start" and reply.get("ok"):
            caps = reply["capabilities"]
            caps["events"] = not args.no_events
            caps["privileged_state"] = not args.no_state
            caps["diagnostic_state"] = not args.no_state
        if args.no_events:
            reply.pop("events", None)
        if args.no_state:
            reply.pop("state", None)
        sys.stdout.write(json.dumps(reply) + "\n")
        sys.stdout.flush()
        if msg.get("cmd") == "stop":
            return 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
