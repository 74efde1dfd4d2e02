"""Is a skill's policy, or its Q-ensemble, what limits the policy's success? (docs/guide/skills.md#proposal-data)

    python benchmarks/policy_headroom.py [--checkpoints DIR] [--skills push] [--episodes 100]
        [--samples 1024] [--sigma 0.3] [--uniform 0] [--sim mujoco] [--json OUT]

In each of the quality report's evaluation scenes (the same scenes, in the same order, as
``t2m skills report --episodes N``), from the same simulator snapshot, executes:

- ``policy``: the deterministic policy's action (the report's policy success);
- ``best_min``: of ``--samples`` actions, the policy's action plus N(0, sigma²) per dimension
  (clipped to [−1, 1]; the first is the policy's own; a share ``--uniform`` of them drawn uniformly
  over [−1, 1]⁴ instead), the one with the highest min-of-8 Q: what the actor's objective climbs towards;
- ``best_mean``: of the same actions, the one with the highest mean of the 8 members.

A policy that succeeds far less than ``best_min`` has not found its ensemble's optimum; one that
succeeds about as often, where ``best_mean`` succeeds more, is held back by the pessimistic
(min-of-8) target. Prints a table, writes JSON. Exits 1 when a checkpoint is missing or broken.
"""

from __future__ import annotations

import argparse
import sys
from collections import Counter
from pathlib import Path

import numpy as np
import torch

SKILLS = ("pick", "place", "pull", "push")
CHOICES = ("policy", "best_min", "best_mean")


@torch.no_grad()
def measure(
    checkpoints: Path | None, skill_name: str, simulator, episodes: int, samples: int, sigma: float, uniform: float = 0.0, seed: int = 0
) -> dict[str, dict]:
    """choice -> its outcome summary (``episodes``, ``success_rate``, ``outcomes``) for one skill."""
    from t2m_skills_tableenv.episodes import evaluation_episodes, outcome_summary
    from t2m_skills_tableenv.library import load_library
    from t2m_skills_tableenv.options import TableEnvSkillsOptions

    skill = load_library(TableEnvSkillsOptions() if checkpoints is None else TableEnvSkillsOptions(checkpoints=checkpoints))[skill_name]
    noise = np.random.default_rng(seed)
    outcomes = {choice: Counter() for choice in CHOICES}
    for scene in evaluation_episodes(skill_name, simulator, episodes):
        if scene is None:
            for counter in outcomes.values():
                counter["reset_failed"] += 1
            continue
        call, state = scene
        action = np.asarray(skill.policy(state[None]))[0]
        candidates = np.clip(action + noise.normal(0.0, sigma, (samples, action.shape[0])), -1.0, 1.0).astype(np.float32)
        spread = round(uniform * (samples - 1))
        if spread:
            candidates[samples - spread:] = noise.uniform(-1.0, 1.0, (spread, action.shape[0]))
        candidates[0] = action
        members = np.asarray(skill.q_values(np.repeat(state[None], samples, axis=0), candidates))  # (samples, 8)
        chosen = {
            "policy": action,
            "best_min": candidates[int(members.min(axis=1).argmax())],
            "best_mean": candidates[int(members.mean(axis=1).argmax())],
        }
        snapshot = simulator.get_state()
        for choice, act in chosen.items():
            simulator.set_state(snapshot)
            result = simulator.execute(skill_name, call.args, act)
            outcomes[choice][result.failure or "success"] += 1
    return {choice: outcome_summary(counter) for choice, counter in outcomes.items()}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--checkpoints", type=Path, help="skill checkpoints directory (default: the shipped ones)")
    parser.add_argument("--skills", default="push", help="comma-separated skills, or all")
    parser.add_argument("--episodes", type=int, default=100)
    parser.add_argument("--samples", type=int, default=1024, help="noisy policy actions ranked per scene")
    parser.add_argument("--sigma", type=float, default=0.3, help="their noise, per action dimension (PolicyCEM's)")
    parser.add_argument("--uniform", type=float, default=0.0, help="share of them drawn uniformly over the action box instead")
    parser.add_argument("--sim", default="mujoco")
    parser.add_argument("--json", type=Path, help="write the figures here")
    args = parser.parse_args(argv)
    skills = SKILLS if args.skills == "all" else tuple(args.skills.split(","))
    unknown = [s for s in skills if s not in SKILLS]
    if unknown or args.samples < 1 or args.episodes < 1 or not 0.0 <= args.uniform <= 1.0:
        parser.error(
            f"unknown skills {unknown} (known: {', '.join(SKILLS)})" if unknown
            else "--uniform must lie in [0, 1]" if not 0.0 <= args.uniform <= 1.0 else "--samples and --episodes must be at least 1"
        )
    torch.set_num_threads(1)
    from t2m_core.errors import T2MError
    from t2m_core.registry import get_registry

    simulator = get_registry().create("simulator", args.sim)
    try:
        results = {name: measure(args.checkpoints, name, simulator, args.episodes, args.samples, args.sigma, args.uniform) for name in skills}
    except (T2MError, OSError) as error:  # a missing or broken checkpoint: the library's own message
        print(f"error: {error}", file=sys.stderr)
        return 1
    print(f"| skill | {' | '.join(CHOICES)} | failures ({' / '.join(CHOICES)}) |")
    print("|---" * (len(CHOICES) + 2) + "|")
    for name, rows in results.items():
        rates = " | ".join(f"{rows[c]['success_rate']:.0%} of {rows[c]['episodes']}" for c in CHOICES)
        failures = " / ".join(", ".join(f"{k} {v}" for k, v in rows[c]["outcomes"].items() if k != "success") or "-" for c in CHOICES)
        print(f"| {name} | {rates} | {failures} |")
    if args.json:
        from t2m_core.atomic_files import write_json_atomic

        write_json_atomic(args.json, {"checkpoints": str(args.checkpoints or "shipped"), "samples": args.samples, "sigma": args.sigma, "uniform": args.uniform, "skills": results})
    return 0


if __name__ == "__main__":
    sys.exit(main())
