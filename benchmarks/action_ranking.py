"""How well skill checkpoints rank the actions of one skill call in a task's scenes, against the physics.

    python benchmarks/action_ranking.py --task task1 --call "pick(yellow_box)" --seeds 0-9
        --checkpoints plugins/t2m_skills_tableenv/checkpoints,datasets/pick-anchored [--samples 128]
        [--noise 0.3] [--json OUT]

For every seed: reset MuJoCo to the task's scene (base seed = index × 1000, as ``t2m eval`` and
``stap_quality.py`` do), draw ``--samples`` actions and execute each from the same snapshot. Half are
the planner's first population around the first checkpoint's policy (its deterministic action plus
N(0, σ²) per dimension, σ = ``--noise``, clipped to [−1, 1]); the other half the data-generation
sampler's screened draws (``Primitive.screened_action``). Every checkpoint then scores the same
actions with its min-of-8 Q. Per checkpoint it prints, over all seeds: the area under the ROC curve
of the value against the simulated outcome (pooled, and averaged over the seeds that have both
outcomes), precision and recall of ``min Q > 0.5``, and in how many seeds the best-rated action
succeeds. The action set is the same for every checkpoint, so the comparison is paired.

``--after "pick(red_box), place(red_box, rack), pick(hook)"`` first walks those calls in every scene,
each executed as task rollouts advance (the best-valued of 256 noisy policy actions of the first
checkpoint, up to four tries from the reached snapshot): the ranking is then of the call at that
reached state. Seeds where a call of ``--after`` fails are skipped and counted.
"""

from __future__ import annotations

import argparse

import numpy as np


def roc_auc(scores: np.ndarray, labels: np.ndarray) -> float | None:
    """Probability that a random success scores above a random failure (ties count half); None
    without both outcomes."""
    positives, negatives = scores[labels], scores[~labels]
    if len(positives) == 0 or len(negatives) == 0:
        return None
    greater = (positives[:, None] > negatives[None, :]).sum()
    ties = (positives[:, None] == negatives[None, :]).sum()
    return float((greater + 0.5 * ties) / (len(positives) * len(negatives)))


def _percent(value: float | None, form: str = ".1%") -> str:
    return "n/a" if value is None else format(value, form)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--task", required=True)
    parser.add_argument("--call", required=True, help='the skill call, e.g. "pick(yellow_box)"')
    parser.add_argument("--seeds", default="0-9", help="seed indices: 0-9 or 0,3,5 (base seed = index x 1000)")
    parser.add_argument("--checkpoints", default="plugins/t2m_skills_tableenv/checkpoints",
                        help="comma-separated skill checkpoint directories; the first one's policy proposes")
    parser.add_argument("--after", default="", help='calls executed before it, e.g. "pick(red_box), place(red_box, rack)"')
    parser.add_argument("--samples", type=int, default=128, help="actions per seed")
    parser.add_argument("--noise", type=float, default=0.3, help="σ around the policy's action, normalised units")
    parser.add_argument("--sim", default="mujoco")
    parser.add_argument("--json", dest="json_out", default=None)
    args = parser.parse_args()
    if args.samples < 2:
        parser.error("--samples must be at least 2 (half near the policy, half screened)")

    from rich.progress import track

    from t2m_core.atomic_files import write_json_atomic
    from t2m_core.data.proposals import ProposalSampler
    from t2m_core.data.rollouts import advance
    from t2m_core.domain.primitives import get_primitive
    from t2m_core.domain.skills import parse_skeleton, parse_skill_call
    from t2m_core.errors import T2MError
    from t2m_core.evaluation import SEED_SPACING, parse_seed_indices
    from t2m_core.registry import get_registry
    from t2m_core.tasks import load_task

    try:
        call = parse_skill_call(args.call)
        task = load_task(args.task)
        before = parse_skeleton(args.after, task.objects) if args.after.strip() else ()
        seeds = parse_seed_indices(args.seeds)
        directories = [d for d in args.checkpoints.split(",") if d]
        registry = get_registry()
        simulator = registry.create("simulator", args.sim)
        libraries = [registry.create("skill_library", "tableenv", {"checkpoints": d}) for d in directories]
    except T2MError as error:
        raise SystemExit(f"{error.message}\n{error.hint or ''}".rstrip()) from None
    primitive = get_primitive(call.name)
    samplers = {c.name: ProposalSampler(get_primitive(c.name), libraries[0][c.name]) for c in (*before, call)}

    def reached(objects: tuple[str, ...]) -> bool:
        """Walk ``--after`` from the reset scene as task rollouts advance; whether every call succeeded."""
        for earlier in before:
            encoded, policy_action = samplers[earlier.name].policy_action(simulator.observation(), objects, earlier.args)
            if not advance(simulator, samplers[earlier.name], earlier, simulator.get_state(), encoded, policy_action, rng):
                return False
        return True

    states, actions, outcomes, seed_of, not_reached = [], [], [], [], []
    rng = np.random.default_rng(0)
    for seed in track(seeds, description=f"{args.task} {args.call}", transient=True):
        objects = tuple(simulator.reset(task, seed=seed * SEED_SPACING).state.object_names)
        if not reached(objects):
            not_reached.append(seed)
            continue
        snapshot = simulator.get_state()
        state, mean = samplers[call.name].policy_action(simulator.observation(), objects, call.args)
        near_policy = np.clip(mean + rng.normal(0.0, args.noise, (args.samples // 2, 4)), -1.0, 1.0)
        geometric = simulator.geometric_state()
        screened = np.stack([primitive.screened_action(geometric, call.args, rng) for _ in range(args.samples - len(near_policy))])
        for action in np.concatenate([near_policy, screened]):
            simulator.set_state(snapshot)
            result = simulator.execute(call.name, call.args, action)
            states.append(state)
            actions.append(action)
            outcomes.append(bool(result.success))
            seed_of.append(seed)
    if not states:
        raise SystemExit(f"no seed reached {args.call}: a call of --after failed in every one "
                         f"(seeds {not_reached}); try more --seeds or a shorter --after")
    seeds = [s for s in seeds if s not in not_reached]
    states_array, actions_array = np.stack(states).astype(np.float32), np.stack(actions).astype(np.float32)
    success, seed_index = np.array(outcomes), np.array(seed_of)
    successes_per_seed = [int(success[seed_index == s].sum()) for s in seeds]
    print(f"{args.task} {args.call}: {len(success)} actions over {len(seeds)} seeds, {success.mean():.1%} succeed; "
          f"seeds with a success: {len(set(seed_index[success].tolist()))}"
          + (f"; --after failed in seeds {not_reached}" if not_reached else ""))
    print("  successes per seed: " + ", ".join(f"{s}: {n}" for s, n in zip(seeds, successes_per_seed)))

    report = {"task": args.task, "call": args.call, "after": args.after, "seeds": seeds, "not_reached": not_reached,
              "samples": args.samples, "noise": args.noise, "success_rate": float(success.mean()),
              "successes_per_seed": successes_per_seed, "checkpoints": {}}
    for directory, library in zip(directories, libraries):
        values = np.asarray(library[call.name].q_values(states_array, actions_array)).min(axis=1)
        predicted = values > 0.5
        per_seed = [roc_auc(values[seed_index == s], success[seed_index == s]) for s in seeds]
        best = [bool(success[seed_index == s][np.argmax(values[seed_index == s])]) for s in seeds]
        entry = {
            "auc": roc_auc(values, success),
            "auc_per_seed_mean": float(np.mean([a for a in per_seed if a is not None])) if any(a is not None for a in per_seed) else None,
            "precision": float(success[predicted].mean()) if predicted.any() else None,
            "recall": float(predicted[success].mean()) if success.any() else None,
            "best_rated_succeeds": int(sum(best)),
            "best_rated_per_seed": best,
        }
        report["checkpoints"][directory] = entry
        print(f"  {directory}: AUC {_percent(entry['auc'], '.3f')} (per seed {_percent(entry['auc_per_seed_mean'], '.3f')}), "
              f"precision {_percent(entry['precision'])}, recall {_percent(entry['recall'])}, "
              f"best-rated action succeeds in {entry['best_rated_succeeds']} / {len(seeds)} seeds")
    if args.json_out:
        write_json_atomic(args.json_out, report)


if __name__ == "__main__":
    main()
