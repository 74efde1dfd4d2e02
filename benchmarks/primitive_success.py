"""Success rate of each primitive under the heuristic sampler and under uniform actions.

    python benchmarks/primitive_success.py --sim mujoco --json OUT [--samples 500]

Scenes come from the tasks (same cases as sim_throughput.py); each sample is one execution from a
fresh reset (setup skills chosen by the exploration sampler, not counted).
"""

from __future__ import annotations

import argparse
import json
from collections import Counter

import numpy as np


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sim", default="mujoco")
    parser.add_argument("--json", dest="json_out", required=True)
    parser.add_argument("--samples", type=int, default=500)
    args = parser.parse_args()

    import sys
    from pathlib import Path

    from rich.progress import track

    sys.path.insert(0, str(Path(__file__).parent))
    from sim_throughput import CASES

    from t2m_core.cli.sim_cmd import resolve_simulator
    from t2m_core.domain.primitives import get_primitive
    from t2m_core.tasks import load_task

    sim = resolve_simulator(args.sim)
    report = {}
    for name, (task_id, setup, (primitive, arguments)) in CASES.items():
        task = load_task(task_id)
        rng = np.random.default_rng(1)
        for sampler in ("heuristic", "uniform"):
            successes, samples, failures = 0, 0, Counter()
            for seed in track(range(args.samples), description=f"{name} {sampler}", transient=True):
                sim.reset(task, seed=seed)
                ready = True
                for skill, skill_args in setup:
                    for _ in range(20):
                        snapshot = sim.get_state()
                        spec = get_primitive(skill)
                        if sim.execute(skill, skill_args, spec.exploration_action(sim.geometric_state(), skill_args, rng)).success:
                            break
                        sim.set_state(snapshot)
                    else:
                        ready = False
                if not ready:
                    continue
                spec = get_primitive(primitive)
                state = sim.geometric_state()
                action = spec.heuristic_action(state, arguments, rng) if sampler == "heuristic" else rng.uniform(-1, 1, 4)
                result = sim.execute(primitive, arguments, action)
                samples += 1
                successes += int(result.success)
                failures[result.failure or "success"] += 1
            report[f"{name}/{sampler}"] = {"samples": samples, "success_rate": successes / max(samples, 1),
                                           "outcomes": dict(failures)}
            print(f"{name:5s} {sampler:9s} {successes / max(samples, 1):6.1%} of {samples}  {dict(failures)}", flush=True)
    with open(args.json_out, "w") as stream:
        json.dump({"simulator": args.sim, "results": report}, stream, indent=2)


if __name__ == "__main__":
    main()
