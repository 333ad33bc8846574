"""A policy process for tests/test_policy.py: plays the highest legal action; misbehaves on demand.

argv[1] = mode: ok | crash (exit 3 at tick 3) | garbage (non-JSON at tick 3) | hang (at tick 3) |
wrong-seq | no-handshake | respelt (every action written another way: ``6.0``, ``6e0``, ``60e-1``;
F-VALUES) | as:TEXT (every action written as the JSON text TEXT, e.g. ``as:2.5``).  With a second argument, writes its pid there (to check teardown).  With
``AGSPEC_LEAK=HOW:TAG`` in the environment, it leaves a helper process behind at start
(tests/fakes/helpers.py).
"""

import json
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
if os.environ.get("AGSPEC_LEAK"):
    from helpers import leave

    _how, _, _tag = os.environ["AGSPEC_LEAK"].partition(":")
    leave(_how, _tag)
mode = sys.argv[1] if len(sys.argv) > 1 else "ok"
if len(sys.argv) > 2:
    with open(sys.argv[2], "a") as fh:
        fh.write(f"{os.getpid()}\n")
for line in sys.stdin:
    msg = json.loads(line)
    reply = {"seq": msg["seq"], "ok": True}
    if msg["cmd"] == "start":
        reply["protocol"] = "other/1" if mode == "no-handshake" else msg["protocol"]
    elif msg["cmd"] == "act":
        if msg["t"] == 3:
            if mode == "crash":
                sys.exit(3)
            if mode == "garbage":
                print("this is not json", flush=True)
                continue
            if mode == "hang":
                time.sleep(60)
            if mode == "wrong-seq":
                reply["seq"] = "nope"
        reply["actions"] = {a: max(k for k, ok in enumerate(o["mask"]) if ok) for a, o in msg["observations"].items()}
    spelt = reply.pop("actions", None) if mode == "respelt" or mode.startswith("as:") else None
    text = json.dumps(reply)
    if spelt is not None:
        forms = ["{0}.0", "{0}e0", "{1}e-1", "{0}.000", "{0}E0"]
        text = text[:-1] + ', "actions": {' + ", ".join(
            f"{json.dumps(a)}: {mode[3:] if mode.startswith('as:') else forms[(k + msg['t']) % 5].format(v, v * 10)}"
            for k, (a, v) in enumerate(spelt.items())) + "}}"
    print(text, flush=True)
    if msg["cmd"] == "stop":
        break
