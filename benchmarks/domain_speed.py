"""Speed of the world model's hot paths: the symbolic state of a full scene (what the planners compute
for every predicted state), the observation encoding and the batched skill-state encoding.

Usage: python benchmarks/domain_speed.py [--json OUT]
"""

from __future__ import annotations

import argparse
import timeit

import numpy as np

from t2m_core.atomic_files import write_json_atomic
from t2m_core.domain.geometry import yaw_to_quat
from t2m_core.domain.goals import goal_satisfied, parse_goal
from t2m_core.domain.observation import argument_first_order, decode_observation, encode_observation, skill_state
from t2m_core.domain.relations import symbolic_state
from t2m_core.domain.state import GeometricState, ObjectPose

FULL_SCENE = GeometricState(
    {
        "table": ObjectPose([0, 0, 0]),
        "rack": ObjectPose([0.44, -0.33, 0.16], yaw_to_quat(np.pi / 2)),
        "hook": ObjectPose([0.5, 0.25, 0.02], yaw_to_quat(0.3)),
        "red_box": ObjectPose([0.44, -0.33, 0.219]),
        "blue_box": ObjectPose([0.6, 0.1, 0.053], yaw_to_quat(1.0)),
        "yellow_box": ObjectPose([0.45, -0.3, 0.033]),
        "cyan_box": ObjectPose([0.8, 0.1, 0.035]),
    }
)


def per_call_ms(fn, number: int) -> float:
    """Mean wall time of one call, milliseconds (best of 3 repeats)."""
    return min(timeit.repeat(fn, number=number, repeat=3)) / number * 1e3


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", metavar="OUT", help="also write the figures to this JSON file")
    args = parser.parse_args()

    names = FULL_SCENE.object_names
    observation = encode_observation(FULL_SCENE)
    order = argument_first_order(names, ["red_box", "rack"])
    batch = np.broadcast_to(observation, (10_000, 8, 12))
    goal = parse_goal("[['on(red_box, rack)', 'on(blue_box, rack)'], ['on(cyan_box, rack)']]")
    rng = np.random.default_rng(0)
    figures = {
        "symbolic_state_7_objects_ms": per_call_ms(lambda: symbolic_state(FULL_SCENE), 200),
        "decode_observation_and_goal_check_ms": per_call_ms(
            lambda: goal_satisfied(goal, decode_observation(observation, names)), 200
        ),
        "encode_observation_ms": per_call_ms(lambda: encode_observation(FULL_SCENE), 500),
        "skill_state_10k_batch_shuffled_ms": per_call_ms(lambda: skill_state(batch, order, rng), 5),
    }
    for name, value in figures.items():
        print(f"{name:40s} {value:8.3f}")
    if args.json:
        write_json_atomic(args.json, figures)


if __name__ == "__main__":
    main()
