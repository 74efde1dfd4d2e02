"""What the reach of a heuristic Pull does to the pulled box, per backend: touched, tipped, shoved.

    python benchmarks/pull_reach_contact.py --sim mujoco,pybullet [--samples 60]

In the Pull evaluation scenes (those of ``primitive_success.py --scenes evaluation``) each sample
draws the heuristic action, runs the primitive's pre-pose move and its reach (the descent the hook
makes before sweeping) and reports whether the hook touched the box on the way down (closest distance
under 1 mm at some tick), whether the box is still upright after it, and whether an upright box was
shoved more than 1 cm; counts are split by the sign of the action's lateral offset y (y > 0 puts the
handle over the box).
"""

from __future__ import annotations

import argparse
import sys
from collections import Counter
from pathlib import Path

import numpy as np

TOUCH_DISTANCE = 0.001
"""Metres: closer than this, the hook touches the box."""
SHOVED_DISTANCE = 0.01
"""Metres the box's centre moved in the plane during the reach to count as shoved."""


def reach_outcomes(name: str, samples: int) -> Counter:
    sys.path.insert(0, str(Path(__file__).parent))
    from sim_throughput import EVALUATION_CASES, distinct_scenes, evaluation_scene, prepare

    from t2m_core.cli.sim_cmd import resolve_simulator
    from t2m_core.domain.geometry import is_upright
    from t2m_core.domain.primitives import get_primitive

    objects, propositions, setup, (_primitive, arguments) = EVALUATION_CASES["pull"]
    task, pull, target = evaluation_scene(objects, propositions), get_primitive("pull"), arguments[0]
    sim = resolve_simulator(name)
    counts: Counter = Counter()
    rng = np.random.default_rng(1)
    try:
        for _reset in distinct_scenes(sim, task, samples):
            if not prepare(sim, setup, rng):
                continue
            state = sim.geometric_state()
            action = pull.heuristic_action(state, arguments, rng)
            world, motions = sim.world, sim.executor
            world.canonicalize()
            motions.begin_primitive()
            pre_pose, reach = pull.motion(state, arguments, action)[:2]
            motions.run(pre_pose)
            before = world.geometric_state().objects[target].position
            touched = [False]
            tick = world.tick

            def watched_tick(count: int = 1, tick=tick, touched=touched) -> None:
                touched[0] |= world.distance("hook", target) < TOUCH_DISTANCE
                tick(count)

            world.tick = watched_tick
            try:
                motions.run(reach)
            finally:
                del world.tick
            after = world.geometric_state().objects[target]
            side = "y>0" if pull.to_physical(action)[2] > 0 else "y<=0"
            upright = is_upright(after.quaternion)
            shoved = upright and float(np.linalg.norm(after.position[:2] - before[:2])) > SHOVED_DISTANCE
            counts[f"{side} touched={touched[0]} upright={upright}{' shoved' if shoved else ''}"] += 1
    finally:
        sim.close()
    return counts


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sim", default="mujoco,pybullet", help="comma-separated simulator plugins")
    parser.add_argument("--samples", type=int, default=60)
    args = parser.parse_args()
    for name in args.sim.split(","):
        counts = reach_outcomes(name, args.samples)
        print(f"{name}: " + ", ".join(f"{key}: {value}" for key, value in sorted(counts.items())), flush=True)


if __name__ == "__main__":
    main()
