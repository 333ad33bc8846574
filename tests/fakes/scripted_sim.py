#!/usr/bin/env python3
"""A family of F-PROTOCOL simulators, parametrized, for the generators of the harness's own tests.

    python tests/fakes/scripted_sim.py [--fail JSON] [--leak load|reset] [--coin DIR] [--wrong-at T]
                                       [--rerun-wrong] [--refuse-rerun] [--kill-parent] [--daemon HOW] [--coercion HOW]
                                       [--refuse-custom CODE]

The simulator is the reference interpreter behind the protocol (privileged state and events), with
the faults its options name:

``--fail JSON``       per instance id (substring): ``{"cmd": load|reset|step, "mode": M, "at": T}`` where
                      M is ``error:CODE`` (answers ``ok: false`` with CODE), ``crash`` (exits 3),
                      ``garbage`` (a line that is not JSON), ``hang`` (never answers) or ``wrong``
                      (a wrong state); ``at`` is the epoch of the step (default 1)
``--refuse-custom CODE`` answers ``ok: false`` with CODE to the load of every instance that is not an
                      official catalogue instance (id ``ag32-…``), as the original release wrapped
                      honestly does (``invalid_instance``)
``--leak load``       a counter of loads in this process leaks into the state: robot 0,0's
                      ``switch_lock`` is one higher from the step at epoch 1 in every episode after the first
``--leak reset``      the same with a counter of resets
``--coin DIR``        a per-process coin: the process that takes an even ticket in DIR (a file per
                      process) is wrong at epoch 1, an odd one is not — random per process, as a
                      simulator seeded by its pid or the clock is
``--wrong-at T``      always wrong from epoch T on
``--rerun-wrong``     wrong from epoch 1 when this process has loaded the same instance before
``--refuse-rerun``    answers ``ok: false`` to every load after the first of this process
``--kill-parent``     kills its parent (the harness worker) with SIGKILL at the step of epoch 1
``--coercion HOW``    mishandles illegal actions (R-ACTION-VALIDATION): coerces them without the
                      ``action_coerced`` event (``silent``), only the out-of-range ones or only the
                      masked ones so (``silent-range``, ``silent-masked``), or reports the wrong
                      ``action`` in the event (``wrong-action``)
``--daemon HOW``      at start, leaves a daemon that holds its pipes for 600 s: ``session`` (in a session
                      of its own, both pipes), ``stdout`` / ``stderr`` (own session, one pipe), ``group``
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import sys
import time
from pathlib import Path


def _ticket(directory: str) -> int:
    """The next free ticket in ``directory`` (one file per process, created exclusively)."""
    Path(directory).mkdir(parents=True, exist_ok=True)
    n = 0
    while True:
        try:
            fd = os.open(os.path.join(directory, f"ticket-{n}"), os.O_CREAT | os.O_EXCL | os.O_WRONLY)
            os.close(fd)
            return n
        except FileExistsError:
            n += 1


def _daemon(how: str) -> None:
    """A grandchild that holds our pipes open for 600 s: in a session of its own (``session``, both
    pipes), holding only stdout or only stderr (``stdout``, ``stderr``, also in its own session), or
    in our process group (``group``)."""
    if os.fork() == 0:
        if how != "group":
            os.setsid()
        devnull = os.open(os.devnull, os.O_WRONLY)
        if how == "stdout":
            os.dup2(devnull, 2)
        elif how == "stderr":
            os.dup2(devnull, 1)
        if os.fork() == 0:
            signal.signal(signal.SIGTERM, signal.SIG_IGN)
            time.sleep(600)
        os._exit(0)
    os.wait()


def _coerced(event: dict, how: str) -> dict | None:
    """An ``action_coerced`` event as a simulator that mishandles illegal actions reports it (None: dropped)."""
    if event.get("type") != "action_coerced":
        return event
    out_of_range = not 0 <= int(event.get("action", 0)) < 114
    if how == "silent" or (how == "silent-range" and out_of_range) or (how == "silent-masked" and not out_of_range):
        return None
    if how == "wrong-action":
        return {**event, "action": 0}
    return event


def main() -> int:
    if os.environ.get("AGSPEC_LEAK"):  # HOW:TAG, a helper left behind at start (tests/fakes/helpers.py)
        sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
        from helpers import leave

        how, _, tag = os.environ["AGSPEC_LEAK"].partition(":")
        leave(how, tag)
    parser = argparse.ArgumentParser()
    parser.add_argument("--fail", default="{}")
    parser.add_argument("--refuse-custom", default=None)
    parser.add_argument("--leak", choices=("load", "reset"), default=None)
    parser.add_argument("--coin", default=None)
    parser.add_argument("--wrong-at", type=int, default=None)
    parser.add_argument("--rerun-wrong", action="store_true")
    parser.add_argument("--refuse-rerun", action="store_true")
    parser.add_argument("--kill-parent", action="store_true")
    parser.add_argument("--coercion", choices=("silent", "silent-range", "silent-masked", "wrong-action"),
                        default=None)
    parser.add_argument("--tag", default="", help="ignored: names the process for a test that looks for it")
    parser.add_argument("--daemon", choices=("session", "stdout", "stderr", "group"), default=None)
    args = parser.parse_args()
    plan = json.loads(args.fail)

    from agspec.conform.impl.serve import Server
    from agspec.ir.fingerprint import fingerprint

    server = Server(observations=False, masks=False)
    coin_wrong = _ticket(args.coin) % 2 == 0 if args.coin else False
    loads = resets = 0
    seen: set[str] = set()
    again = False
    out = sys.stdout

    def write(obj) -> None:
        out.write((obj if isinstance(obj, str) else json.dumps(obj)) + "\n")
        out.flush()

    for line in sys.stdin:
        if not line.strip():
            continue
        msg = json.loads(line)
        cmd, seq = msg.get("cmd"), msg.get("seq")
        if cmd == "start" and args.daemon:
            _daemon(args.daemon)
        ident = str(((msg.get("instance") if cmd == "load" else server.instance) or {}).get("id", ""))
        at = server.sim.t if (cmd == "step" and server.sim is not None) else -1
        fault = next((f for key, f in plan.items() if key in ident and f.get("cmd") == cmd
                      and (cmd != "step" or at == f.get("at", 1))), None)
        mode = (fault or {}).get("mode", "")
        if cmd == "load" and args.refuse_custom and not ident.startswith("ag32-"):
            mode = "error:" + args.refuse_custom
        if cmd == "load":
            loads += 1
            fp = fingerprint(msg["instance"])
            again = fp in seen
            seen.add(fp)
            if args.refuse_rerun and loads > 1:
                write({"seq": seq, "ok": False, "error": {"code": "busy", "message": "one episode per process"}})
                continue
        if cmd == "reset":
            resets += 1
        if cmd == "step" and at == 1 and args.kill_parent:
            os.kill(os.getppid(), signal.SIGKILL)
        if mode == "crash":
            sys.stderr.write(f"scripted_sim: crash at {cmd}\n")
            sys.stderr.flush()
            os._exit(3)
        if mode == "hang":
            time.sleep(3600)
        if mode.startswith("error:"):
            write({"seq": seq, "ok": False, "error": {"code": mode[6:], "message": f"cannot represent {ident}"}})
            continue
        reply = server.handle(msg)
        if mode == "garbage":
            write("DEBUG: not a reply")
        if args.coercion and cmd == "step" and isinstance(reply.get("events"), list):
            reply["events"] = [_coerced(e, args.coercion) for e in reply["events"]]
            reply["events"] = [e for e in reply["events"] if e is not None]
        wrong = mode == "wrong"
        if cmd == "step" and reply.get("ok") and at >= 1:
            history = {"load": loads, "reset": resets}.get(args.leak or "", 0)
            wrong = wrong or history > 1 or coin_wrong or (args.rerun_wrong and again) \
                or (args.wrong_at is not None and at >= args.wrong_at)
        if wrong and reply.get("ok") and "state" in reply:
            robots = reply["state"]["robots"]
            first = sorted(robots)[0]
            robots[first]["switch_lock"] += 1
        write(reply)
        if cmd == "stop":
            return 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
