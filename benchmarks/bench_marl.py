"""Steps per second of the PettingZoo adapter (A-PZ-ENV) per official scenario, masked random play.

Usage:  python benchmarks/bench_marl.py [--steps 400] [--index 1000] [--scenario S ...] [--json]
Measures env.step including the A-OBS-VECTOR encoding of every agent and the action-mask sampling;
the interpreter's own speed is bench_run.py.  Needs the extra agspec[marl].  Nothing is asserted.
"""

from __future__ import annotations

import argparse
import time

from _common import emit, self_peak_mib

from agspec.catalogue import OFFICIAL_SCENARIOS


def bench(scenario: str, index: int, steps: int) -> dict:
    from agspec.pettingzoo import parallel_env

    env = parallel_env(scenario, index=index, max_cycles=steps)
    t0 = time.perf_counter()
    obs, _ = env.reset(seed=0)
    n = 0
    while env.agents:
        actions = {a: env.action_space(a).sample(mask=obs[a]["action_mask"]) for a in env.agents}
        obs, *_ = env.step(actions)
        n += 1
    elapsed = time.perf_counter() - t0
    robots = len(env.possible_agents)
    return {"scenario": scenario, "robots": robots, "steps": n, "seconds": round(elapsed, 3),
            "steps_per_second": round(n / elapsed, 1), "agent_steps_per_second": round(n * robots / elapsed)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--steps", type=int, default=400)
    ap.add_argument("--index", type=int, default=1000)
    ap.add_argument("--scenario", action="append", default=None)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    rows = [bench(s, args.index, args.steps) for s in (args.scenario or OFFICIAL_SCENARIOS)]
    result = {"benchmark": "pettingzoo-adapter", "runs": rows, "peak_rss_mib": round(self_peak_mib(), 1)}
    emit(result, rows, ("scenario", "robots", "steps", "seconds", "steps_per_second", "agent_steps_per_second"),
         f"PettingZoo adapter, masked random play (index {args.index}); peak RSS {result['peak_rss_mib']} MiB",
         args.json)


if __name__ == "__main__":
    main()
