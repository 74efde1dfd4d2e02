"""Several policies of one skill in the same evaluation scenes: paired success counts (docs/guide/skills.md#searched-actor-targets)

    python benchmarks/policy_success.py --skill push --checkpoints shipped,DIR[,DIR...]
        [--episodes 300] [--seeds 7,11] [--sim mujoco] [--json OUT]

For every ``--seeds`` value, executes each checkpoint's deterministic policy in the same
``--episodes`` evaluation scenes (the quality report's scenes are seed 0, the policy selection's
seed 1; other seeds draw scenes that neither saw). ``shipped`` names the checkpoints in the package.
Prints success per checkpoint and seed, the pooled rate, and for each checkpoint after the first the
scenes it gained and lost against the first (the paired comparison that 100-episode rates are too
noisy to make). Writes JSON. Exits 1 when a checkpoint is missing or broken.
"""

from __future__ import annotations

import argparse
import sys
from collections import Counter
from pathlib import Path

import numpy as np

SKILLS = ("pick", "place", "pull", "push")


def outcomes(skill_name: str, checkpoints: str, simulator, episodes: int, seeds: list[int]) -> dict[int, list[str]]:
    """seed -> the outcome (``"success"``, a failure reason or ``"reset_failed"``) of each of the
    ``episodes`` scenes of that seed."""
    import torch

    from t2m_skills_tableenv.episodes import policy_outcomes
    from t2m_skills_tableenv.library import load_library
    from t2m_skills_tableenv.options import TableEnvSkillsOptions

    options = TableEnvSkillsOptions() if checkpoints == "shipped" else TableEnvSkillsOptions(checkpoints=Path(checkpoints))
    skill = load_library(options)[skill_name]
    act = lambda states: np.asarray(skill.policy(states))  # noqa: E731
    with torch.no_grad():
        return {seed: policy_outcomes(skill_name, act, simulator, episodes, seed) for seed in seeds}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--skill", required=True, choices=SKILLS)
    parser.add_argument("--checkpoints", required=True, help="comma-separated checkpoints directories; 'shipped' for the package's")
    parser.add_argument("--episodes", type=int, default=300, help="evaluation scenes per seed")
    parser.add_argument("--seeds", default="7,11", help="comma-separated scene seeds (0: the report's scenes)")
    parser.add_argument("--sim", default="mujoco")
    parser.add_argument("--json", type=Path, help="write the figures here")
    args = parser.parse_args(argv)
    names = [c for c in args.checkpoints.split(",") if c]
    try:
        seeds = [int(s) for s in args.seeds.split(",")]
    except ValueError:
        parser.error(f"--seeds must be comma-separated integers, got {args.seeds!r}")
    if args.episodes < 1 or not names:
        parser.error("--episodes must be at least 1 and --checkpoints name at least one directory")
    import torch

    torch.set_num_threads(1)
    from t2m_core.errors import T2MError
    from t2m_core.registry import get_registry
    from t2m_skills_tableenv.episodes import outcome_summary

    simulator = get_registry().create("simulator", args.sim)
    runs: dict[str, dict[int, list[str]]] = {}
    try:
        for name in names:
            runs[name] = outcomes(args.skill, name, simulator, args.episodes, seeds)
    except (T2MError, OSError) as error:  # a missing or broken checkpoint: the library's own message
        print(f"error: {error}", file=sys.stderr)
        return 1
    first = names[0]
    summary = {}
    print(f"| {args.skill} policy | {' | '.join(f'seed {s}' for s in seeds)} | pooled | gained / lost against {first} | failures |")
    print("|---" * (len(seeds) + 4) + "|")
    for name in names:
        pooled = [o for seed in seeds for o in runs[name][seed]]
        baseline = [o for seed in seeds for o in runs[first][seed]]
        gained = sum(o == "success" != b for o, b in zip(pooled, baseline, strict=True))
        lost = sum(b == "success" != o for o, b in zip(pooled, baseline, strict=True))
        per_seed = {seed: outcome_summary(Counter(runs[name][seed]))["success_rate"] for seed in seeds}
        failures = Counter(o for o in pooled if o != "success")
        summary[name] = {
            "per_seed": per_seed, "pooled": outcome_summary(Counter(pooled)), "gained": gained, "lost": lost,
            "outcomes": {str(seed): runs[name][seed] for seed in seeds},
        }
        rates = " | ".join(f"{rate:.1%}" for rate in per_seed.values())
        paired = "-" if name == first else f"+{gained} / -{lost}"
        failed = ", ".join(f"{k} {v}" for k, v in failures.most_common()) or "-"
        print(f"| {name} | {rates} | {summary[name]['pooled']['success_rate']:.1%} | {paired} | {failed} |")
    if args.json:
        from t2m_core.atomic_files import write_json_atomic

        write_json_atomic(args.json, {"skill": args.skill, "episodes": args.episodes, "seeds": seeds, "checkpoints": summary})
    return 0


if __name__ == "__main__":
    sys.exit(main())
