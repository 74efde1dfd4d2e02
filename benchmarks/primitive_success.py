"""Success rate of each primitive under the heuristic sampler, the screened heuristic and uniform actions.

    python benchmarks/primitive_success.py --sim mujoco --json OUT [--samples 500] [--only pull,push]
        [--scenes task|evaluation]

Scenes come from the tasks (same cases as sim_throughput.py): one distinct scene per sample, the setup skills
(e.g. picking the hook by its handle's tail before a pull) not counted, then one
heuristic (the reference's), one screened-heuristic (``Primitive.screened_action``, the data-generation
sampler: heuristic draws that pass an analytic screen of the domain geometry) and one uniform execution
from that same snapshot. ``--scenes evaluation`` measures the
evaluation scenes (docs/guide/skills.md#evaluation-scenes) instead (feasible instances: ``free``, ``nonblocking``), where
they differ from the task scenes (Pull).
"""

from __future__ import annotations

import argparse
from collections import Counter

import numpy as np

from t2m_core.atomic_files import write_json_atomic


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sim", default="mujoco")
    parser.add_argument("--json", dest="json_out", required=True)
    parser.add_argument("--samples", type=int, default=500)
    parser.add_argument("--only", default="", help="comma-separated primitives (default: all)")
    parser.add_argument("--scenes", choices=("task", "evaluation"), default="task")
    args = parser.parse_args()

    import sys
    from pathlib import Path

    from rich.progress import track

    sys.path.insert(0, str(Path(__file__).parent))
    from sim_throughput import CASES, EVALUATION_CASES, case_scene, distinct_scenes, evaluation_scene, prepare

    from t2m_core.cli.sim_cmd import resolve_simulator
    from t2m_core.domain.primitives import get_primitive
    sim = resolve_simulator(args.sim)
    report = {}
    only = set(filter(None, args.only.split(",")))
    cases = EVALUATION_CASES if args.scenes == "evaluation" else CASES
    for name, (scene_a, scene_b, setup, (primitive, arguments)) in cases.items():
        if only and name not in only:
            continue
        task = evaluation_scene(scene_a, scene_b) if args.scenes == "evaluation" else case_scene(scene_a, scene_b)
        rng = np.random.default_rng(1)
        spec = get_primitive(primitive)
        samplers = {
            "heuristic": spec.heuristic_action,
            "screened": spec.screened_action,
            "uniform": lambda _state, _arguments, generator: generator.uniform(-1, 1, 4),
        }
        counts = {sampler: Counter() for sampler in samplers}
        for _reset in track(distinct_scenes(sim, task, args.samples), total=args.samples, description=f"{name:5s}", transient=True):
            if not prepare(sim, setup, rng):
                continue
            scene = sim.get_state()
            state = sim.geometric_state()
            for sampler, counter in counts.items():
                sim.set_state(scene)
                action = samplers[sampler](state, arguments, rng)
                result = sim.execute(primitive, arguments, action)
                counter[result.failure or "success"] += 1
        for sampler, counter in counts.items():
            samples = sum(counter.values())
            rate = counter["success"] / max(samples, 1)
            report[f"{name}/{sampler}"] = {"samples": samples, "success_rate": rate, "outcomes": dict(counter)}
            print(f"{name:5s} {sampler:9s} {rate:6.1%} of {samples}  {dict(counter)}", flush=True)
    write_json_atomic(args.json_out, {"simulator": args.sim, "scenes": args.scenes, "results": report})


if __name__ == "__main__":
    main()
