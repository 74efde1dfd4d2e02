"""Which τ separates plans that succeed from plans that fail: the reference skeletons' first plans.

    python benchmarks/tau_acceptance.py --outcomes benchmarks/results/stap_quality_...json --json OUT
        [--taus 0,0.05,0.1,0.15,0.2,0.25,0.3] [--checkpoints DIR]

A lookahead task planner accepts a goal-reaching plan only when every OOD-masked step value exceeds
τ (docs/guide/planners.md#constants). This benchmark re-plans the first PolicyCEM plan of every
episode in a ``benchmarks/stap_quality.py`` report (each plan seeds its own generator, so it is the
plan that episode started from), takes its smallest masked step value, and counts, for each τ, the
plans accepted and rejected against whether the episode reached its goal closed loop. A τ that
rejects plans that succeed costs the task planners goal-reaching plans; one that accepts plans that
fail costs execution failures.
"""

from __future__ import annotations

import argparse
import json

import numpy as np


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--outcomes", required=True, help="a benchmarks/stap_quality.py report (JSON) with policy-cem episodes")
    parser.add_argument("--json", dest="json_out", required=True)
    parser.add_argument("--taus", default="0,0.05,0.1,0.15,0.2,0.25,0.3")
    parser.add_argument("--checkpoints", default=None, help="skill checkpoints (default: the shipped ones; use the report's)")
    args = parser.parse_args()

    from t2m_core.atomic_files import write_json_atomic
    from t2m_core.evaluation import SEED_SPACING
    from t2m_core.registry import get_registry
    from t2m_core.tasks import load_task

    report = json.loads(open(args.outcomes, encoding="utf-8").read())
    episodes = report["planners"]["policy-cem"]["episodes"]
    registry = get_registry()
    simulator = registry.create("simulator", "mujoco")
    skills = registry.create("skill_library", "tableenv", {"checkpoints": args.checkpoints} if args.checkpoints else {})
    planner = registry.create("feasibility_planner", "policy-cem", {})
    plans = []
    for episode in episodes:
        task = load_task(episode["task"])
        reset = simulator.reset(task, seed=episode["seed"] * SEED_SPACING)
        plan = planner.plan(simulator.observation(), list(task.reference_skeleton), skills, reset.state.object_names)
        masked = np.asarray(plan.values, dtype=float) * ~np.asarray(plan.ood, dtype=bool)
        plans.append({"task": episode["task"], "seed": episode["seed"], "success": bool(episode["success"]),
                      "min_value": float(masked.min()), "values": [round(float(v), 4) for v in masked]})
        print(f"{episode['task']} seed {episode['seed']}: min masked value {masked.min():.2f}, "
              f"{'reached the goal' if episode['success'] else 'failed'}", flush=True)
    simulator.close()
    rows = []
    for tau in (float(t) for t in args.taus.split(",")):
        accepted = [p for p in plans if p["min_value"] > tau]
        rejected = [p for p in plans if p["min_value"] <= tau]
        row = {"tau": tau, "accepted_succeeded": sum(p["success"] for p in accepted), "accepted_failed": sum(not p["success"] for p in accepted),
               "rejected_succeeded": sum(p["success"] for p in rejected), "rejected_failed": sum(not p["success"] for p in rejected)}
        rows.append(row)
    print("| τ | accepted, reached the goal | accepted, failed | rejected, would have reached it | rejected, failed |")
    print("|---|---|---|---|---|")
    for row in rows:
        print(f"| {row['tau']:.2f} | {row['accepted_succeeded']} | {row['accepted_failed']} | {row['rejected_succeeded']} | {row['rejected_failed']} |")
    write_json_atomic(args.json_out, {"outcomes": args.outcomes, "checkpoints": args.checkpoints or "shipped", "plans": plans, "rows": rows})


if __name__ == "__main__":
    main()
