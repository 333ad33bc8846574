"""The heuristic of heuristic.py as a policy process (any language works; this one is stdlib Python).

    agspec evaluate --policy "python3 examples/policies/heuristic_process.py" --name heuristic-process

Speaks agspec-policy/1 (spec/13-policy.md, F-POLICY-PROTOCOL): one JSON object per line on stdin,
one reply per request on stdout, echoing each request's "seq".
"""

import json
import sys

DELIVER, PICK, HANDOFF, RECEIVE, OPERATION = 1, range(2, 34), range(34, 42), range(42, 50), range(50, 114)
PREFERENCE = [DELIVER, *OPERATION, *PICK, *(HANDOFF[d] for d in (2, 1, 3)), *(RECEIVE[d] for d in (6, 7, 5))]


def act(observations):
    actions = {}
    for agent, obs in observations.items():
        mask = obs["mask"]
        legal = [a for a, ok in enumerate(mask) if ok]
        actions[agent] = next((a for a in PREFERENCE if mask[a]), legal[0])
    return actions


def main():
    for line in sys.stdin:
        msg = json.loads(line)
        reply = {"seq": msg["seq"], "ok": True}
        if msg["cmd"] == "start":
            reply.update(protocol=msg["protocol"], policy={"name": "heuristic-process", "version": "1"})
        elif msg["cmd"] == "act":
            reply["actions"] = act(msg["observations"])
        print(json.dumps(reply), flush=True)
        if msg["cmd"] == "stop":
            return


if __name__ == "__main__":
    main()
