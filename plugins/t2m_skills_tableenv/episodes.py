"""A policy's success in simulated evaluation scenes (docs/guide/skills.md#evaluation-scenes): what
the quality report measures and what selects the policy during training."""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np

REPORT_SEED = 0
"""Seed of the report's episodes."""
SELECTION_SEED = 1
"""Seed of the episodes that select the policy during training: other scenes than the report's, so
that the reported success is not measured on the scenes the policy was chosen on."""


def evaluation_episodes(skill: str, simulator: Any, episodes: int, seed: int = REPORT_SEED) -> Iterator[tuple[Any, np.ndarray] | None]:
    """Reset ``simulator`` into each of ``episodes`` evaluation scenes of ``skill`` in turn.

    Yields:
        ``(call, state)`` per scene, the simulator left in the scene's initial state: the skill's
        call (``.args``) and its skill state ``(96,)``; ``None`` for a scene that could not be reset.
        The same ``seed`` gives the same scenes and reset seeds.
    """
    from t2m_core.data.evaluation_scenes import evaluation_task
    from t2m_core.domain.observation import argument_first_order, skill_state
    from t2m_core.domain.sampling import SamplingError

    rng = np.random.default_rng(seed)
    for _ in range(episodes):
        task = evaluation_task(skill, rng)
        try:
            reset = simulator.reset(task, seed=int(rng.integers(2**31 - 1)))
        except SamplingError:
            yield None
            continue
        yield task.call, skill_state(reset.observation, argument_first_order(task.objects, task.call.args))


def policy_outcomes(skill: str, policy: Callable[[np.ndarray], Any], simulator: Any, episodes: int, seed: int = REPORT_SEED) -> list[str]:
    """The outcome of a deterministic policy in each of ``episodes`` evaluation scenes of ``skill``, simulated.

    Args:
        policy: skill states ``(1, 96)`` -> actions ``(1, 4)`` in [−1, 1].
        seed: the scenes (the same seed gives the same scenes and reset seeds).

    Returns:
        per scene, in order: ``"success"``, the failure reason, or ``"reset_failed"`` for a scene
        that could not be reset.
    """
    outcomes = []
    for scene in evaluation_episodes(skill, simulator, episodes, seed):
        if scene is None:
            outcomes.append("reset_failed")
            continue
        call, state = scene
        action = np.asarray(policy(state[None]))[0]
        outcomes.append(simulator.execute(skill, call.args, action).failure or "success")
    return outcomes


def policy_success(skill: str, policy: Callable[[np.ndarray], Any], simulator: Any, episodes: int, seed: int = REPORT_SEED) -> dict[str, Any]:
    """Success of a deterministic policy over ``episodes`` evaluation scenes of ``skill``, simulated
    (:func:`policy_outcomes`, summarised by :func:`outcome_summary`).

    Returns:
        ``episodes`` simulated (scenes that could not be reset are not counted), ``success_rate``,
        and ``outcomes``: the count of each failure reason and of ``success``.
    """
    return outcome_summary(Counter(policy_outcomes(skill, policy, simulator, episodes, seed)))


def outcome_summary(outcomes: Counter[str]) -> dict[str, Any]:
    """``episodes`` (simulated, so not ``reset_failed``), ``success_rate`` and ``outcomes`` of a count
    of outcomes by name (``success`` or a failure reason)."""
    simulated = sum(v for k, v in outcomes.items() if k != "reset_failed")
    return {"episodes": simulated, "success_rate": outcomes["success"] / simulated if simulated else 0.0, "outcomes": dict(outcomes)}
