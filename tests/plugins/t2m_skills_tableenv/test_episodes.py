"""The evaluation scenes the report and the policy selection run in."""

from __future__ import annotations

import numpy as np
from t2m_skills_tableenv.episodes import evaluation_episodes, outcome_summary, policy_success

from t2m_core.registry import get_registry


def test_evaluation_episodes_repeat_with_their_seed_and_are_what_the_policy_sees() -> None:
    simulator = get_registry().create("simulator", "mujoco")
    first = [(call.args, state.copy()) for call, state in filter(None, evaluation_episodes("push", simulator, 3, seed=7))]
    again = [(call.args, state.copy()) for call, state in filter(None, evaluation_episodes("push", simulator, 3, seed=7))]
    other = [state.copy() for _, state in filter(None, evaluation_episodes("push", simulator, 3, seed=8))]
    assert len(first) == 3 and [a for a, _ in first] == [a for a, _ in again]
    assert all(np.array_equal(s, t) for (_, s), (_, t) in zip(first, again, strict=True))
    assert not np.array_equal(first[0][1], other[0])
    assert all(s.shape == (96,) for _, s in first)
    seen: list[np.ndarray] = []

    def recording_policy(states: np.ndarray) -> np.ndarray:
        seen.append(states[0].copy())
        return np.zeros((1, 4), dtype=np.float32)

    result = policy_success("push", recording_policy, simulator, 3, seed=7)
    assert result["episodes"] == 3 and sum(result["outcomes"].values()) == 3
    assert all(np.array_equal(s, t) for s, (_, t) in zip(seen, first, strict=True))


def test_outcome_summary_leaves_out_scenes_that_were_not_reset() -> None:
    from collections import Counter

    summary = outcome_summary(Counter({"success": 3, "not_under": 1, "reset_failed": 2}))
    assert summary == {"episodes": 4, "success_rate": 0.75, "outcomes": {"success": 3, "not_under": 1, "reset_failed": 2}}
    assert outcome_summary(Counter())["success_rate"] == 0.0
