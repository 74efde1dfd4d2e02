"""``t2m sim demo`` over tasks × seeds without video: how many reach the goal, and why the others fail.

    python benchmarks/sim_demo_sweep.py --sim mujoco --json OUT [--tasks task0,...] [--seeds 10]
"""

from __future__ import annotations

import argparse
import json

from t2m_core.atomic_files import write_json_atomic


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sim", default="mujoco")
    parser.add_argument("--json", dest="json_out", required=True)
    parser.add_argument("--tasks", default="task0,task1,task2,task3,task4,task5,task6")
    parser.add_argument("--seeds", type=int, default=10)
    args = parser.parse_args()

    from t2m_core.cli.sim_cmd import resolve_simulator
    from t2m_core.demo import run_demo
    from t2m_core.tasks import load_task

    sim = resolve_simulator(args.sim)
    report = {}
    for task_id in args.tasks.split(","):
        task = load_task(task_id)
        runs = []
        for seed in range(args.seeds):
            result = run_demo(sim, task, seed, None)
            runs.append(result)
            print(f"{task_id} seed {seed}: {'ok' if result['success'] else 'FAIL ' + str(result['failure'])} "
                  f"tries={[s['tries'] for s in result['steps']]} {result['seconds']} s", flush=True)
        report[task_id] = {"reached": sum(r["success"] for r in runs), "runs": runs}
        print(f"{task_id}: {report[task_id]['reached']}/{args.seeds}", flush=True)
    write_json_atomic(args.json_out, json.loads(json.dumps(report, default=str)))


if __name__ == "__main__":
    main()
