"""Where one step of the PettingZoo loop goes, layer by layer, in this build.

Usage:  python benchmarks/bench_step_parts.py [--scenario S ...] [--index 1000] [--steps 400]
                                              [--episodes 5] [--reps 5] [--json]

For each scenario one episode of masked random actions (a NumPy generator seeded 0, as
``bench_throughput.py`` draws them) is recorded, then replayed ``--episodes`` times through three
entry points, each timed in CPU seconds of a fresh process per scenario (best of ``--reps``):

* ``Simulator.step`` on the row-major joint lists: the interpreter alone (R-TICK-ORDER, without
  M-CAPACITY, as the PettingZoo environment runs it, A-PZ-CAPACITY);
* ``env.step_joint``: the interpreter plus the A-OBS-VECTOR / O-MASK encoder and the two new arrays
  every epoch hands out (A-PZ-ARRAYS);
* ``env.step`` with the recorded dicts: plus the per-agent dicts of the PettingZoo API (A-PZ-STEP).

The differences are the layers' costs: the encoder and arrays (``step_joint`` − interpreter) and the
dict API (``step`` − ``step_joint``).  Two more columns:

* **in the loop** — ``env.step`` again, with the PettingZoo loop's action drawing (``rng.choice`` of
  each agent's legal actions) run between the steps, outside the timer: the same work as ``step``,
  measured as ``bench_throughput.py`` measures it;
* **passes over every robot** — O-MASK, the option lists, the encoder's comparisons, M-UTILIZATION's
  busy count and the applied-action map, each timed alone a quarter, half and three quarters into
  the recorded episode (epochs 100, 200 and 300 of 400): the most that a change log kept by the rules (touching only the robots a tick changed)
  could save.

The interpreter runs somewhat slower inside the environment than alone (the encoder's arrays take
cache), so the encoder's share includes that.  Replaying recorded actions in a tight loop leaves the
caches warmer than the loop whose action drawing runs between steps, so the layer figures are lower
than "in the loop"; the shares are what they are for.  Nothing is asserted.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time

from _common import ratio_table


def recorded(scenario: str, index: int, steps: int):
    import numpy as np

    from agspec.pettingzoo import parallel_env

    env = parallel_env(scenario, index=index, max_cycles=steps)
    rng = np.random.default_rng(0)
    obs, _ = env.reset(seed=0)
    dicts = []
    while env.agents:
        actions = {a: int(rng.choice(np.flatnonzero(o["action_mask"]))) for a, o in obs.items()}
        dicts.append(actions)
        obs, *_ = env.step(actions)
    return env, dicts, [[d[a] for a in env.possible_agents] for d in dicts]


def best_of(reps: int, runs: dict) -> dict[str, float]:
    """The best CPU seconds of each run over ``reps`` rounds; the runs take turns within a round, so a
    slow spell of the machine hits them alike.  A run that times itself returns its seconds."""
    best = dict.fromkeys(runs, float("inf"))
    for _ in range(reps):
        for name, run in runs.items():
            t0 = time.process_time()
            seconds = run()
            best[name] = min(best[name], time.process_time() - t0 if seconds is None else seconds)
    return best


def parts(scenario: str, index: int, steps: int, episodes: int, reps: int) -> dict:
    import numpy as np

    from agspec.interp.tick import Simulator

    env, dicts, joints = recorded(scenario, index, steps)
    sim = Simulator(env.instance, capacity=False)

    def interpreter():
        for _ in range(episodes):
            sim.reset(0)
            for joint in joints:
                sim.step(joint)

    def arrays():
        for _ in range(episodes):
            env.reset(seed=0)
            for joint in joints:
                env.step_joint(joint)

    def api():
        for _ in range(episodes):
            env.reset(seed=0)
            for actions in dicts:
                env.step(actions)

    def loop():  # as step, with the PettingZoo loop's action drawing between steps (outside the timer)
        seconds = 0.0
        for _ in range(episodes):
            rng = np.random.default_rng(0)
            obs, _ = env.reset(seed=0)
            for actions in dicts:
                for o in obs.values():
                    rng.choice(np.flatnonzero(o["action_mask"]))
                t0 = time.process_time()
                obs, *_ = env.step(actions)
                seconds += time.process_time() - t0
        return seconds

    n = episodes * len(joints)
    best = best_of(reps, {"interpreter": interpreter, "step_joint": arrays, "step": api, "loop": loop})
    us = {name: seconds / n * 1e6 for name, seconds in best.items()}
    total = us["step"]
    layers = {"interpreter": us["interpreter"], "encoder + arrays": us["step_joint"] - us["interpreter"],
              "dict API": us["step"] - us["step_joint"]}
    row = {"scenario": scenario, "robots": len(env.possible_agents), "steps": n, "step us": round(total, 1)}
    for name, value in layers.items():
        row[f"{name} us"] = round(value, 1)
        row[f"{name} %"] = round(100 * value / total, 1)
    row["in the loop us"] = round(us["loop"], 1)
    row["passes over every robot us"] = round(robot_passes(env, joints), 1)
    return row


def robot_passes(env, joints: list[list[int]], number: int = 2000) -> float:
    """CPU us per step of the passes that visit every robot whatever happened (O-MASK, the option
    lists, the encoder's comparisons, M-UTILIZATION's busy count, the applied-action map): the most a
    change log kept by the rules could save.  Timed on the decision epochs a quarter, half and three
    quarters into the recorded episode, on unchanged inputs (so the encoder only compares), and averaged."""
    from agspec.interp.observe import action_masks, build_options

    total = 0.0
    epochs = sorted({len(joints) * q // 4 for q in (1, 2, 3)})
    for k in epochs:
        env.reset(seed=0)
        for joint in joints[:k]:
            env.step_joint(joint)
        sim, enc = env.sim, env._encoder
        state, model, d = sim.state, sim.model, sim.decision
        idle = [0] * len(model.cells)
        passes = (lambda: action_masks(state, model, d.options, d.masks),
                  lambda: build_options(state, model, d.candidates, d.options),
                  lambda: enc.update(state, d.options, d.masks),
                  lambda: [r.busy_until > state.t or r.incoming is not None for r in state.robots.values()].count(True),
                  lambda: dict(zip(model.cell_ids, idle)))
        for run in passes:
            t0 = time.process_time()
            for _ in range(number):
                run()
            total += (time.process_time() - t0) / number
    return total / max(1, len(epochs)) * 1e6


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter,
                                 epilog="example: python benchmarks/bench_step_parts.py --scenario concurrency-hard "
                                        "--episodes 5 --reps 5")
    ap.add_argument("--scenario", action="append", default=None)
    ap.add_argument("--index", type=int, default=1000)
    ap.add_argument("--steps", type=int, default=400)
    ap.add_argument("--episodes", type=int, default=5, help="replays of the recorded episode per timing")
    ap.add_argument("--reps", type=int, default=5, help="rounds of timings, the entry points taking turns (the best is kept)")
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    scenarios = args.scenario or ["coalition-medium", "concurrency-hard"]
    common = ["--index", str(args.index), "--steps", str(args.steps), "--episodes", str(args.episodes),
              "--reps", str(args.reps)]
    if args.worker:  # one scenario in this process: the driver's subprocess
        print(json.dumps(parts(scenarios[0], args.index, args.steps, args.episodes, args.reps)))
        return
    # a fresh process per scenario: another scenario's memos and objects would change this one's figures
    rows = [json.loads(subprocess.run([sys.executable, __file__, "--worker", "--scenario", s, *common], check=True,
                                      capture_output=True, text=True).stdout.splitlines()[-1]) for s in scenarios]
    out = {"benchmark": "step_parts", "index": args.index, "steps": args.steps, "episodes": args.episodes,
           "reps": args.reps, "rows": rows}
    if args.json:
        print(json.dumps(out, indent=2))
        return
    ratio_table(f"one PettingZoo step by layer, this build (CPU us per step, best of {args.reps}; index {args.index})",
                rows, [(k, k) for k in rows[0]])
    print(json.dumps(out))


if __name__ == "__main__":
    main()
