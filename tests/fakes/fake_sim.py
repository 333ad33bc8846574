#!/usr/bin/env python3
"""Deliberately broken F-PROTOCOL simulators, for the harness's own tests (never shipped).

    python tests/fakes/fake_sim.py MODE [--only SUBSTRING] [--at T]

The simulator is the reference interpreter behind the protocol (agspec.conform.impl.serve.Server), except
that on the ``step`` request applied at epoch ``T`` (default 2) of an instance whose id contains
SUBSTRING (default: every instance) it misbehaves:

    ok         behaves (a control)
    crash      writes a message on stderr and exits with status 3 instead of replying
    hang       never replies (sleeps)
    garbage    prints a line that is not JSON before its reply
    wrong_seq  replies with a seq that was never sent
    stale_seq  replies to the step twice (the second reply arrives for the next request)
    missing    leaves `state` out of its reply
    mutate     from tick T on, reports robot 0,0's `switch_lock` one higher than it is
    schema     reports `t` as a string in its reply (caught by --validate-protocol and the reply checks)
    drop_support  from tick T on, leaves every `support` event out of its replies (the state is right)
    ignore_actions  from tick T on, steps as if every robot idled (starts nothing it is asked to)
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

MODES = ("ok", "crash", "hang", "garbage", "wrong_seq", "stale_seq", "missing", "mutate", "schema", "drop_support",
         "ignore_actions")


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("mode", choices=MODES)
    parser.add_argument("--only", default="")
    parser.add_argument("--at", type=int, default=2)
    args = parser.parse_args()

    from agspec.conform.impl.serve import Server

    server = Server(observations=False, masks=False)
    out = sys.stdout

    def write(obj) -> None:
        out.write((obj if isinstance(obj, str) else json.dumps(obj)) + "\n")
        out.flush()

    for line in sys.stdin:
        if not line.strip():
            continue
        msg = json.loads(line)
        cmd = msg.get("cmd")
        targeted = args.only in ((server.instance or {}).get("id") or "")
        at = server.sim.t if server.sim is not None else -1
        hit = cmd == "step" and targeted and at == args.at
        if hit and args.mode == "crash":
            sys.stderr.write("fake_sim: simulated fatal error in step\n")
            sys.stderr.flush()
            os._exit(3)
        if hit and args.mode == "hang":
            time.sleep(3600)
        if args.mode == "ignore_actions" and cmd == "step" and targeted and at >= args.at:
            msg = {**msg, "actions": {}}
        reply = server.handle(msg)
        if hit and args.mode == "garbage":
            write("DEBUG: entering step, t=%d" % at)
        if hit and args.mode == "wrong_seq":
            reply["seq"] = f"never-sent-{reply['seq']}"
        if hit and args.mode == "missing":
            reply.pop("state", None)
        if hit and args.mode == "schema":
            reply["t"] = str(reply["t"])
        if args.mode == "mutate" and cmd == "step" and targeted and at >= args.at and reply.get("ok"):
            reply["state"]["robots"]["0,0"]["switch_lock"] += 1
        if args.mode == "drop_support" and cmd == "step" and targeted and at >= args.at and reply.get("ok"):
            reply["events"] = [e for e in reply["events"] if e.get("type") != "support"]
        write(reply)
        if hit and args.mode == "stale_seq":
            write(reply)
        if cmd == "stop":
            return 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
