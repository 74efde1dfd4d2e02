"""How close the primitives' geometry alone, and dynamics models, come to where the moved object ends;
and how much that end moves when the action barely does (docs/guide/skills.md#geometric-prior).

    python benchmarks/dynamics_prior.py --data datasets/tableenv [--checkpoints shipped,DIR,...]
        [--sensitivity-scenes 30] [--epsilon 0.003] [--sim mujoco] [--json OUT]

Per skill with a validation split in ``--data``: the errors (median / 90th percentile, mm and degrees)
of the moved object (the first argument) and of the others over the validation successes, as
``t2m skills report`` measures them, for the geometric prior alone
(:func:`t2m_skills_tableenv.geometric_prior.prior_next_rows`) and for the dynamics model of each
library in ``--checkpoints`` (``shipped`` for the package's).

With ``--sensitivity-scenes N`` (> 0): in N evaluation scenes per skill, the shipped policy's action
is executed twice as it is and twice with N(0, ε²) added to each normalised dimension; where they
succeed, the distance between the moved object's end positions: zero for the repeated action (the
simulation is deterministic), and for the perturbed ones the spread that no model of the next state
can resolve from an action known to ±ε. Prints a table, writes JSON. Exits 1 when a checkpoint is
missing or broken.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

SKILLS = ("pick", "place", "pull", "push")


def model_errors(data: Path, checkpoints: list[str]) -> dict[str, dict[str, dict[str, float]]]:
    """skill -> model name (``prior`` or a checkpoints entry) -> the report's dynamics errors."""
    import torch

    from t2m_core.data.generate import load_split
    from t2m_skills_tableenv.dataset import SkillTensors
    from t2m_skills_tableenv.library import load_library
    from t2m_skills_tableenv.networks import dynamics_architecture
    from t2m_skills_tableenv.prior_dynamics import PriorDynamics
    from t2m_skills_tableenv.options import TableEnvSkillsOptions
    from t2m_skills_tableenv.report import dynamics_errors

    libraries = {name: load_library(TableEnvSkillsOptions() if name == "shipped" else TableEnvSkillsOptions(checkpoints=Path(name))) for name in checkpoints}
    results: dict[str, dict[str, dict[str, float]]] = {}
    for skill in SKILLS:
        split = data / skill / "validation"
        if not split.exists():
            continue
        transitions = load_split(split)
        keep = transitions.success
        successes = SkillTensors.from_transitions(transitions).successes()
        prior = PriorDynamics(skill, dynamics_architecture(skill, "prior")["context_rows"]).prior
        models = {"prior": prior, **{name: library[skill].dynamics for name, library in libraries.items()}}
        with torch.no_grad():
            results[skill] = {
                name: dynamics_errors(model, successes, transitions.row_order[keep], transitions.shuffle_range[keep], transitions.observation[keep], transitions.next_observation[keep])
                for name, model in models.items()
            }
    return results


def sensitivity(skill_name: str, simulator, scenes: int, epsilon: float, seed: int = 5) -> dict[str, float]:
    """Distances (mm) between the moved object's end positions of repeated and of perturbed actions."""
    import torch

    from t2m_skills_tableenv.episodes import evaluation_episodes
    from t2m_skills_tableenv.library import load_library
    from t2m_skills_tableenv.options import TableEnvSkillsOptions

    skill = load_library(TableEnvSkillsOptions())[skill_name]
    noise = np.random.default_rng(seed)
    repeated: list[float] = []
    perturbed: list[float] = []
    for scene in evaluation_episodes(skill_name, simulator, scenes, seed=seed):
        if scene is None:
            continue
        call, state = scene
        start = simulator.get_state()
        with torch.no_grad():
            action = np.asarray(skill.policy(state[None]))[0]
        ends = []
        for attempt in range(4):
            simulator.set_state(start)
            tried = action if attempt < 2 else np.clip(action + epsilon * noise.standard_normal(4), -1.0, 1.0)
            result = simulator.execute(skill_name, call.args, tried)
            ends.append(np.asarray(result.state.objects[call.args[0]].position) if result.success else None)
        if ends[0] is None:
            continue
        if ends[1] is not None:
            repeated.append(1000.0 * float(np.linalg.norm(ends[1] - ends[0])))
        perturbed += [1000.0 * float(np.linalg.norm(end - ends[0])) for end in ends[2:] if end is not None]
    summary = {"repeated_pairs": len(repeated), "perturbed_pairs": len(perturbed)}
    if repeated:
        summary["repeated_mm_max"] = float(np.max(repeated))
    if perturbed:
        summary["perturbed_mm_median"] = float(np.median(perturbed))
        summary["perturbed_mm_p90"] = float(np.percentile(perturbed, 90))
    return summary


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", type=Path, required=True, help="a t2m datagen directory (DATA/<skill>/validation)")
    parser.add_argument("--checkpoints", default="shipped", help="comma-separated checkpoints directories; 'shipped' for the package's")
    parser.add_argument("--sensitivity-scenes", type=int, default=0, help="evaluation scenes per skill for the action sensitivity (0: skip)")
    parser.add_argument("--epsilon", type=float, default=0.003, help="standard deviation of the action perturbation (normalised units)")
    parser.add_argument("--sim", default="mujoco")
    parser.add_argument("--json", dest="json_out", type=Path)
    args = parser.parse_args(argv)
    if args.sensitivity_scenes < 0 or args.epsilon <= 0:
        parser.error("--sensitivity-scenes must be ≥ 0 and --epsilon > 0")

    from t2m_core.atomic_files import write_json_atomic
    from t2m_core.errors import T2MError

    checkpoints = [name for name in args.checkpoints.split(",") if name]
    try:
        errors = model_errors(args.data, checkpoints)
    except T2MError as error:
        print(f"error: {error}", file=sys.stderr)
        return 1
    if not errors:
        print(f"error: no <skill>/validation split under {args.data}; make one with `t2m datagen --split validation`", file=sys.stderr)
        return 1
    print(f"{'skill':6} {'model':40} {'moved mm median / p90':>22} {'moved deg median':>17} {'others mm median':>17}")
    for skill, models in errors.items():
        for name, entry in models.items():
            print(f"{skill:6} {name[-40:]:40} {entry['moved_mm_median']:>11.1f} / {entry['moved_mm_p90']:<8.1f} {entry['moved_deg_median']:>17.1f} {entry.get('others_mm_median', float('nan')):>17.1f}")
    result: dict = {"data": str(args.data), "errors": errors}
    if args.sensitivity_scenes:
        from t2m_core.registry import get_registry

        simulator = get_registry().create("simulator", args.sim)
        result["sensitivity"] = {"epsilon": args.epsilon, "scenes": args.sensitivity_scenes}
        for skill in SKILLS:
            entry = result["sensitivity"][skill] = sensitivity(skill, simulator, args.sensitivity_scenes, args.epsilon)
            print(
                f"{skill:6} repeated action: max {entry.get('repeated_mm_max', float('nan')):.2f} mm ({entry['repeated_pairs']} pairs); "
                f"perturbed by ε = {args.epsilon}: median {entry.get('perturbed_mm_median', float('nan')):.1f} / p90 "
                f"{entry.get('perturbed_mm_p90', float('nan')):.1f} mm ({entry['perturbed_pairs']} pairs)"
            )
    if args.json_out:
        write_json_atomic(args.json_out, result)
    return 0


if __name__ == "__main__":
    sys.exit(main())
