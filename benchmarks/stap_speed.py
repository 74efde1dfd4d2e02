"""Speed of the feasibility planner: one ``plan()`` per skeleton length, against this CPU's dense-MLP rate.

    python benchmarks/stap_speed.py --json OUT [--planner policy-cem] [--population 10000] [--lengths 1-10]
        [--repeats 2] [--threads N] [--checkpoints DIR]

In one run it measures (1) the reference rate: the 8-member 100-256-256-1 Q-ensemble forward on
40 000 samples in float32, in GFLOP/s; (2) the wall time of one ``plan()`` of the chosen planner for
skeletons of each length (a task3 scene, skills cycling pick/place/pull/push where valid is not
required: speed does not depend on it), its sample-steps per second, the FLOP rate those imply
(each step's Q-ensemble, MLP or relational, + dynamics, counted from the loaded networks; the
policy's once-per-plan rollout ignored) and that rate as a fraction of the reference; (3) the
process's peak resident memory.
"""

from __future__ import annotations

import argparse
import resource
import time

import numpy as np


def reference_rate(repeats: int = 5) -> float:
    """GFLOP/s of the ensemble forward on 40 000 samples (best of ``repeats``)."""
    import torch

    from t2m_skills_tableenv.networks import QEnsemble

    q = QEnsemble().eval()
    states, actions = torch.randn(40_000, 96), torch.randn(40_000, 4)
    best = float("inf")
    with torch.no_grad():
        q(states, actions)
        for _ in range(repeats):
            started = time.perf_counter()
            q(states, actions)
            best = min(best, time.perf_counter() - started)
    return 40_000 * q.flops_per_sample() / best / 1e9


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", dest="json_out", required=True)
    parser.add_argument("--planner", default="policy-cem")
    parser.add_argument("--population", type=int, default=10_000)
    parser.add_argument("--lengths", default="1-10", help="skeleton lengths, e.g. 1-10 or 1,4")
    parser.add_argument("--repeats", type=int, default=2, help="plans per length (the fastest counts)")
    parser.add_argument("--threads", type=int, default=None, help="torch threads (default: torch's)")
    parser.add_argument("--checkpoints", default=None, help="skill checkpoints directory (default: the shipped ones)")
    args = parser.parse_args()

    import torch

    from t2m_core.atomic_files import write_json_atomic
    from t2m_core.domain.observation import encode_observation
    from t2m_core.domain.sampling import sample_task
    from t2m_core.domain.skills import SkillCall
    from t2m_core.registry import get_registry
    from t2m_core.tasks import load_task

    if args.threads:
        torch.set_num_threads(args.threads)
    lengths = _lengths(args.lengths)
    registry = get_registry()
    skills = registry.create("skill_library", "tableenv", {"checkpoints": args.checkpoints} if args.checkpoints else {})
    options = {"population": args.population} if args.planner != "policy" else {}
    planner = registry.create("feasibility_planner", args.planner, options)
    task = load_task("task3")
    observation = encode_observation(sample_task(task, 0).state, task.objects)
    cycle = [SkillCall("pick", ("hook",)), SkillCall("pull", ("blue_box", "hook")), SkillCall("place", ("hook", "table")),
             SkillCall("pick", ("blue_box",)), SkillCall("place", ("blue_box", "rack"))]
    iterations = getattr(getattr(planner, "options", None), "iterations", 1)
    reference = reference_rate()
    print(f"reference: 8-member ensemble forward on 40 000 samples: {reference:.1f} GFLOP/s ({torch.get_num_threads()} threads)")
    rows = []
    for length in lengths:
        skeleton = [cycle[i % len(cycle)] for i in range(length)]
        seconds = min(_timed(planner, observation, skeleton, skills, task.objects) for _ in range(args.repeats))
        samples = planner.options.samples(length) if hasattr(planner.options, "samples") else 1
        sample_steps = samples * length * iterations
        flops = samples * iterations * sum(_step_flops(skills[call.name]) for call in skeleton)
        rate = flops / seconds / 1e9
        rows.append({"length": length, "seconds": round(seconds, 3), "sample_steps_per_second": round(sample_steps / seconds),
                     "gflops": round(rate, 2), "fraction_of_reference": round(rate / reference, 3)})
        print(f"T={length:2d}: {seconds:7.3f} s per plan, {sample_steps / seconds:10.0f} sample-steps/s, "
              f"{rate:5.1f} GFLOP/s = {rate / reference:.0%} of the reference", flush=True)
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"peak resident memory: {peak_mb:.0f} MB")
    write_json_atomic(args.json_out, {"planner": args.planner, "population": args.population, "threads": torch.get_num_threads(),
                                      "reference_gflops": round(reference, 2), "plans": rows, "peak_rss_mb": round(peak_mb)})


def _step_flops(skill) -> int:
    """FLOPs of one sample-step of ``skill``: its Q-ensemble and its dynamics."""
    return skill.q_ensemble.flops_per_sample() + skill.dynamics.flops_per_sample()


def _timed(planner, observation, skeleton, skills, objects) -> float:
    started = time.perf_counter()
    planner.plan(observation, skeleton, skills, objects)
    return time.perf_counter() - started


def _lengths(text: str) -> list[int]:
    if "-" in text:
        low, high = (int(x) for x in text.split("-"))
        return list(range(low, high + 1))
    return [int(x) for x in text.split(",")]


if __name__ == "__main__":
    np.set_printoptions(precision=3)
    main()
