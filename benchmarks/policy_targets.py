"""Are a skill's searched actor targets learnable, and did a fine-tuned policy reach them?
(docs/guide/skills.md#searched-actor-targets)

    python benchmarks/policy_targets.py --data DIR [--skill pick] [--checkpoints DIR]
        [--samples 512] [--sigma 0.3] [--margin 0.3] [--tolerance 0.05] [--policies A,B] [--json OUT]

Searches the targets of ``t2m train --policy-targets`` twice, with seeds 0 and 1, from the library's
policy on the distinct states of the train split of ``--data`` (datasets of several actions per
scene repeat each state), and prints:

- ``moved``: states whose target is not the policy's own action, in each search and in both;
- ``own_to_target``: the mean squared distance (4 normalised dimensions) from the policy's action to
  seed 0's target, and ``seed_to_seed`` between the two seeds' targets where both moved. When the
  second is as large as the first, a target is one draw from a wide plateau of near-best actions:
  a regression towards it cannot fall below about half of ``seed_to_seed``;
- ``value``: the mean min-of-8 Q, on seed 0's moved states, of the library's policy, of the targets,
  and of each ``--policies`` weights file (``policy.safetensors``), with the share valued at least
  0.9: whether a fine-tuned policy reached the plateau the targets lie on.

Exits 1 when a checkpoint or the data is missing or broken.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import torch

SKILLS = ("pick", "place", "pull", "push")
REACHED = 0.9


@torch.no_grad()
def measure(
    data: Path, skill: str, checkpoints: Path | None, samples: int, sigma: float, margin: float, tolerance: float,
    policies: list[Path],
) -> dict:
    """The figures described in the module docstring, as a dictionary."""
    from t2m_skills_tableenv.checkpoints import architecture_of, load_q, load_weights
    from t2m_skills_tableenv.dataset import SkillTensors
    from t2m_skills_tableenv.geometric_policy import build_policy
    from t2m_skills_tableenv.networks import GaussianPolicy
    from t2m_skills_tableenv.options import SHIPPED_CHECKPOINTS
    from t2m_skills_tableenv.training import WEIGHT_FILES, searched_actions

    directory = (checkpoints or SHIPPED_CHECKPOINTS) / skill
    q_ensemble = load_q(directory).eval()
    policy = load_weights(directory / WEIGHT_FILES["policy"], build_policy(architecture_of(directory, "policy"))).eval()
    stored = SkillTensors.load(data / skill / "train").rows
    rows = torch.unique(stored.reshape(stored.shape[0], -1), dim=0).reshape(-1, *stored.shape[1:])
    states = rows.reshape(rows.shape[0], -1)
    own = policy(states)
    first, second = (
        searched_actions(policy, q_ensemble, rows, samples, sigma, torch.Generator().manual_seed(seed), margin=margin, tolerance=tolerance)
        for seed in (0, 1)
    )
    moved, both = first.moved, first.moved & second.moved

    def value(actions: torch.Tensor) -> dict[str, float]:
        on_moved = q_ensemble.probabilities(states[moved], actions[moved]).min(dim=1).values
        return {"mean": round(float(on_moved.mean()), 4), f"share_at_least_{REACHED}": round(float((on_moved >= REACHED).float().mean()), 4)}

    def distance(a: torch.Tensor, b: torch.Tensor, where: torch.Tensor) -> float:
        return round(float((a - b).square().sum(-1)[where].mean()), 4)

    values = {"library policy": value(own), "targets": value(first.actions)}
    for path in policies:
        values[str(path)] = value(load_weights(path, GaussianPolicy()).eval()(states))
    return {
        "states": int(rows.shape[0]),
        "moved": {"seed 0": int(moved.sum()), "seed 1": int(second.moved.sum()), "both": int(both.sum())},
        "own_to_target": distance(first.actions, own, moved),
        "seed_to_seed": distance(first.actions, second.actions, both),
        "value": values,
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", type=Path, required=True, help="dataset directory (DIR/<skill>/train)")
    parser.add_argument("--skill", choices=SKILLS, default="pick")
    parser.add_argument("--checkpoints", type=Path, default=None, help="skill library directory (default: the shipped one)")
    parser.add_argument("--samples", type=int, default=512)
    parser.add_argument("--sigma", type=float, default=0.3)
    parser.add_argument("--margin", type=float, default=0.3)
    parser.add_argument("--tolerance", type=float, default=0.05)
    parser.add_argument("--policies", default="", help="comma-separated policy.safetensors files to value on the moved states")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--json", type=Path, default=None, help="write the figures here")
    args = parser.parse_args(argv)
    if args.samples < 1:
        parser.error("--samples must be at least 1")
    torch.set_num_threads(args.threads)
    from t2m_core.errors import T2MError

    policies = [Path(p) for p in args.policies.split(",") if p]
    try:
        figures = measure(args.data, args.skill, args.checkpoints, args.samples, args.sigma, args.margin, args.tolerance, policies)
    except (T2MError, FileNotFoundError) as error:
        print(f"error: {error}", file=sys.stderr)
        return 1
    figures = {"skill": args.skill, "data": str(args.data), "samples": args.samples, "sigma": args.sigma, "margin": args.margin,
               "tolerance": args.tolerance, **figures}
    print(f"{args.skill}: {figures['states']} states; moved {figures['moved']}")
    print(f"mean squared distance: policy -> target {figures['own_to_target']}, seed 0 -> seed 1 target {figures['seed_to_seed']}")
    print(f"| on the moved states | mean min-of-8 Q | share >= {REACHED} |\n|---|---|---|")
    for name, row in figures["value"].items():
        print(f"| {name} | {row['mean']:.3f} | {row[f'share_at_least_{REACHED}']:.3f} |")
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(figures, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
