"""Was a failed step the search's luck or the models' error? Re-plan it with other planner seeds.

    python benchmarks/replan_variance.py RUN_DIR [...] [--seeds 6] [--json OUT]

For each run directory (``t2m run``, or one episode of ``t2m eval``) whose execution failed at a
skill: build the recorded simulator, skill library and feasibility planner from its
``config.yaml``, reset to the recorded scene (``result.json``'s seed; the accepted seed must match),
execute the recorded actions of the steps before the failed one (each must end as recorded), and
snapshot. Then plan the remaining skeleton from that state with the recorded planner under seeds
0 .. ``--seeds`` − 1 (the run's closed-loop re-plan used the configured seed, 0 by default) and
execute each plan's first action from the snapshot. Prints, per run and seed, the failed skill's
min-of-8 value, the remaining skeleton's ``p_success`` and the simulated outcome.

Reading it: if other seeds find higher-valued actions that succeed, the failure was the search's
(its ten iterations settled elsewhere); if every seed's action fails, the state the earlier steps
left decided it; if high values fail, the ensemble is wrong there.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import numpy as np
from replay import start_replay

from t2m_core.atomic_files import write_json_atomic
from t2m_core.errors import T2MError


def replan_failed_step(run: Path, seeds: int) -> dict[str, Any]:
    """The re-plans of ``run``'s failed step under planner seeds ``0 .. seeds - 1``.

    Raises:
        T2MError: the run did not fail at a skill, or its replay does not reproduce the record.
    """
    from t2m_core.components import build_component
    from t2m_core.domain.skills import parse_skill_call
    from t2m_core.registry import get_registry

    replay = start_replay(run)
    result, config, simulator, names = replay.result, replay.config, replay.simulator, replay.names
    executed = result.get("executed") or []
    failed = next((i for i, step in enumerate(executed) if not step["success"]), None)
    if failed is None:
        raise T2MError(f"{run}: no executed skill failed", "give a run that failed in execution")
    skills = build_component(config, "skills")
    for index, _call, _record in replay.steps():
        if index == failed:
            break
    snapshot = simulator.get_state()
    remaining = [parse_skill_call(text, names) for text in result["plan"][failed:]]
    planner_block = config.feasibility_planner
    rows = []
    for seed in range(seeds):
        planner = get_registry().create("feasibility_planner", planner_block.name, {**planner_block.options, "seed": seed})
        plan = planner.plan(simulator.observation(), remaining, skills, names)  # planning leaves the simulator as it is
        action = np.clip(np.asarray(plan.actions[0], dtype=np.float64), -1.0, 1.0)
        outcome = simulator.execute(remaining[0].name, remaining[0].args, action)
        simulator.set_state(snapshot)
        rows.append({"seed": seed, "value": float(plan.values[0]), "p_success": float(plan.p_success),
                     "success": bool(outcome.success), "failure": outcome.failure})
    step = executed[failed]
    return {"run": str(run), "skill": step["skill"], "recorded_value": float(step["value"]),
            "recorded_failure": step["failure"], "replans": rows}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", type=Path, help="run directories that failed in execution")
    parser.add_argument("--seeds", type=int, default=6, help="planner seeds 0 .. N-1")
    parser.add_argument("--json", dest="json_out", default=None)
    args = parser.parse_args()
    if args.seeds < 1:
        parser.error("--seeds must be at least 1")
    report = []
    for run in args.runs:
        try:
            entry = replan_failed_step(run, args.seeds)
        except T2MError as error:
            sys.exit(f"{error.message}: {error.hint}" if error.hint else error.message)
        report.append(entry)
        succeeded = sum(row["success"] for row in entry["replans"])
        print(f"{run}: {entry['skill']} failed ({entry['recorded_failure']}) at value {entry['recorded_value']:.2f}; "
              f"re-planned with {args.seeds} seeds, {succeeded} succeed", flush=True)
        for row in entry["replans"]:
            print(f"    seed {row['seed']}: value {row['value']:.3f}, p_success {row['p_success']:.3f}, "
                  f"{'success' if row['success'] else row['failure']}", flush=True)
    if args.json_out:
        write_json_atomic(args.json_out, {"seeds": args.seeds, "runs": report})


if __name__ == "__main__":
    main()
