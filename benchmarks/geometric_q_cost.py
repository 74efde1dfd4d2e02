"""What the geometric screen costs a Q-ensemble call (docs/guide/skills.md#geometric-q-ensemble).

    python benchmarks/geometric_q_cost.py --checkpoints A,B [--skill pick] [--data datasets/tableenv]
        [--pairs 500] [--repeats 5] [--json OUT]

Times, in one process on one torch thread, each library's ``q_values`` of ``skill`` on ``--pairs``
validation pairs three ways: every pair in its own state (all objects elsewhere), every action in
one state (a plan's first step, or a policy's search), and a plan's later step as a planner meets
it (one state whose end effector and argument moved a little differently in every sample, the
bystanders where they were). Prints milliseconds per call (the fastest of ``--repeats``) and the
ratio to the first library; writes JSON. Exits 1 when a checkpoint or the validation split is missing.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import torch


def timed(function, repeats: int) -> float:
    """Milliseconds of the fastest of ``repeats`` calls (after one warm-up call)."""
    function()
    best = float("inf")
    for _ in range(repeats):
        started = time.perf_counter()
        function()
        best = min(best, time.perf_counter() - started)
    return 1000.0 * best


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--checkpoints", required=True, help="comma-separated skill checkpoint directories ('shipped': the installed ones)")
    parser.add_argument("--skill", default="pick")
    parser.add_argument("--data", type=Path, default=Path("datasets/tableenv"), help="dataset directory holding SKILL/validation")
    parser.add_argument("--pairs", type=int, default=500)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args(argv)
    if args.pairs < 1 or args.repeats < 1:
        parser.error("--pairs and --repeats must be at least 1")
    torch.set_num_threads(1)
    from t2m_core.errors import T2MError
    from t2m_skills_tableenv.dataset import SkillTensors
    from t2m_skills_tableenv.library import load_library
    from t2m_skills_tableenv.networks import q_network_name
    from t2m_skills_tableenv.options import TableEnvSkillsOptions

    try:
        validation = SkillTensors.load(args.data / args.skill / "validation").head(args.pairs)
        libraries = {
            name: load_library(TableEnvSkillsOptions() if name == "shipped" else TableEnvSkillsOptions(checkpoints=Path(name)))[args.skill]
            for name in args.checkpoints.split(",")
        }
    except (T2MError, OSError) as error:
        print(f"error: {error}", file=sys.stderr)
        return 1
    states, actions = validation.states(), validation.actions
    one_state = states[:1].expand(len(validation), -1)
    # a plan's later step: one state (a success's, its object where the skill can act) whose EE and
    # argument rows (the first 24 numbers) moved a little differently in every sample, the bystanders shared
    start = states[int(torch.nonzero(validation.rewards > 0.5)[0])]
    moved = start.expand(len(validation), -1).clone()
    generator = torch.Generator().manual_seed(0)
    for row in (0, 12):
        moved[:, row : row + 2] += 0.002 * torch.randn(len(validation), 2, generator=generator)
    results = {}
    for name, skill in libraries.items():
        results[name] = {
            "network": q_network_name(skill.config["models"]["q"]["architecture"]),
            "distinct_states_ms": timed(lambda skill=skill: skill.q_values(states, actions), args.repeats),
            "one_state_ms": timed(lambda skill=skill: skill.q_values(one_state, actions), args.repeats),
            "plan_step_ms": timed(lambda skill=skill: skill.q_values(moved, actions), args.repeats),
        }
    first = next(iter(results.values()))
    print(f"| checkpoints | Q network | {len(validation)} pairs, each its own state: ms | ratio | one state: ms | ratio | a plan step: ms | ratio |")
    print("|---|---|---|---|---|---|---|---|")
    for name, row in results.items():
        for case in ("distinct", "one_state", "plan_step"):
            key = "distinct_states_ms" if case == "distinct" else f"{case}_ms"
            row[f"{case}_ratio"] = row[key] / first[key]
        print(f"| {name} | {row['network']} | {row['distinct_states_ms']:.1f} | {row['distinct_ratio']:.1f} | {row['one_state_ms']:.1f} "
              f"| {row['one_state_ratio']:.1f} | {row['plan_step_ms']:.1f} | {row['plan_step_ratio']:.1f} |")
    if args.json:
        from t2m_core.atomic_files import write_json_atomic

        write_json_atomic(args.json, {"skill": args.skill, "pairs": len(validation), "repeats": args.repeats, "libraries": results})
    return 0


if __name__ == "__main__":
    sys.exit(main())
