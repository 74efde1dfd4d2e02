"""Primitive executions per second per core, per primitive, with heuristic actions, and the ratio of
their cost to raw ``mj_step`` for the same simulated time.

    python benchmarks/sim_throughput.py --sim mujoco --json OUT [--samples 40]

Each sample resets a task scene, brings it to the primitive's precondition (pick: nothing; place,
pull, push: the object or hook picked first, not timed) and times one execution from a snapshot.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

HANDLE_TAIL_GRASP = (-0.1, -0.09, 0.0, 0.0)
"""Physical Pick action on the hook: the handle, 0.1 m behind the centre, yaw 0. Pulls and pushes
of boxes beyond reach need a grasp on the tail half of the handle (a head grasp puts the EE past the
box, beyond the Panda's 0.73 m reach at the lift height), like the feasible-instance evaluation
scenes of tableenv.md §12.5."""

CASES = {  # primitive -> (task, setup skills with a physical action or None, measured call)
    "pick": ("task0", [], ("pick", ("yellow_box",))),
    "place": ("task0", [("pick", ("yellow_box",), None)], ("place", ("yellow_box", "rack"))),
    "pull": ("task3", [("pick", ("hook",), HANDLE_TAIL_GRASP)], ("pull", ("blue_box", "hook"))),
    "push": ("task1", [("pick", ("hook",), HANDLE_TAIL_GRASP)], ("push", ("cyan_box", "hook", "rack"))),
}


def prepare(sim, setup, rng) -> bool:
    """Run the setup skills (heuristic or the given physical action first, then the exploration
    sampler); False when one of them does not succeed in 20 tries."""
    from t2m_core.domain.primitives import get_primitive

    for skill, skill_args, physical in setup:
        spec = get_primitive(skill)
        for attempt in range(20):
            snapshot = sim.get_state()
            state = sim.geometric_state()
            if attempt == 0:
                action = spec.heuristic_action(state, skill_args, rng) if physical is None else spec.to_normalized(np.array(physical))
            else:
                action = spec.exploration_action(state, skill_args, rng)
            if sim.execute(skill, skill_args, np.clip(action, -1, 1)).success:
                break
            sim.set_state(snapshot)
        else:
            return False
    return True


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sim", default="mujoco")
    parser.add_argument("--json", dest="json_out", required=True)
    parser.add_argument("--samples", type=int, default=40)
    args = parser.parse_args()

    from rich.progress import track

    from t2m_core.cli.sim_cmd import resolve_simulator
    from t2m_core.domain.primitives import get_primitive
    from t2m_core.tasks import load_task

    sim = resolve_simulator(args.sim)
    results = {}
    for name, (task_id, setup, (primitive, arguments)) in CASES.items():
        task = load_task(task_id)
        rng = np.random.default_rng(0)
        wall, ticks, successes, samples = 0.0, 0, 0, 0
        for seed in track(range(args.samples), description=f"{name:5s}", transient=True):
            sim.reset(task, seed=seed)
            if not prepare(sim, setup, rng):
                continue
            action = get_primitive(primitive).heuristic_action(sim.geometric_state(), arguments, rng)
            start_ticks = sim.world.ticks
            started = time.perf_counter()
            result = sim.execute(primitive, arguments, action)
            wall += time.perf_counter() - started
            ticks += sim.world.ticks - start_ticks
            successes += int(result.success)
            samples += 1
        # raw physics for the same simulated time: mj_step on the same scene, nothing else
        world = sim.world
        snapshot = world.snapshot()
        started = time.perf_counter()
        world.tick(max(ticks, 1))
        raw = time.perf_counter() - started
        world.restore(snapshot)
        results[name] = {
            "samples": samples,
            "executions_per_second": samples / wall if wall else 0.0,
            "mean_ticks": ticks / max(samples, 1),
            "heuristic_success_rate": successes / max(samples, 1),
            "ratio_to_raw_mj_step": wall / raw if raw else None,
        }
        print(f"{name:5s} {results[name]['executions_per_second']:6.1f} exec/s  "
              f"{results[name]['mean_ticks']:6.0f} ticks  ratio to raw mj_step {results[name]['ratio_to_raw_mj_step']:.2f}  "
              f"(n={samples})")
    with open(args.json_out, "w") as stream:
        json.dump({"simulator": args.sim, "primitives": results}, stream, indent=2)


if __name__ == "__main__":
    main()
