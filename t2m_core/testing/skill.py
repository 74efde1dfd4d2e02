"""Conformance check for :class:`t2m_core.protocols.Skill` implementations."""

from __future__ import annotations

from typing import Any

import numpy as np

from t2m_core.domain.observation import STATE_DIM, argument_first_order, encode_observation, skill_state
from t2m_core.domain.sampling import sample_initial_state

SCENE_OBJECTS = ("table", "rack", "hook", "red_box", "blue_box")
SCENE_STATE = ("aligned(rack)", "poslimit(rack)", "on(rack, table)", "on(hook, table)", "on(red_box, table)", "on(blue_box, rack)")
CALLS = {"pick": ("red_box",), "place": ("red_box", "rack"), "pull": ("red_box", "hook"), "push": ("red_box", "hook", "rack")}


def sample_skill_states(skill_name: str, count: int = 16, seed: int = 0) -> np.ndarray:
    """``(count, 96) float32`` encodings of sampled TableEnv scenes for a typical call of the skill
    (half of them real scenes, half uniform noise in the normalised range)."""
    rng = np.random.default_rng(seed)
    arguments = CALLS.get(skill_name, ("red_box",))
    order = argument_first_order(SCENE_OBJECTS, arguments)
    real = []
    for index in range(count - count // 2):
        scene = sample_initial_state(SCENE_OBJECTS, SCENE_STATE, seed + 1000 * index)
        real.append(skill_state(encode_observation(scene.state, SCENE_OBJECTS), order))
    noise = rng.uniform(-0.5, 0.5, (count // 2, STATE_DIM)).astype(np.float32)
    return np.concatenate([np.stack(real), noise]).astype(np.float32)


def check_skill(skill: Any, states: np.ndarray | None = None, *, seed: int = 0) -> None:
    """Assert that ``skill`` behaves as the Skill protocol requires.

    Checks: ``name`` and ``action_dim`` (4); a float ``ood_threshold``; ``policy`` gives ``(N, 4)``
    finite actions in [−1, 1]; ``q_values`` gives ``(N, B)`` probabilities in [0, 1]; ``predict``
    gives ``(N, 96)`` finite states; an ``ood_variance`` (a separate OOD detector, optional) gives
    ``(N,)`` variances in [0, 0.25]; every method is deterministic and gives the same rows for a
    batch as for its samples one by one (to 1e-5).

    Raises:
        AssertionError: naming the first violation.
    """
    name = getattr(skill, "name", None)
    assert isinstance(name, str) and name, f"skill.name must be a non-empty string, got {name!r}"
    assert getattr(skill, "action_dim", None) == 4, f"{name}: action_dim must be 4, got {getattr(skill, 'action_dim', None)!r}"
    threshold = getattr(skill, "ood_threshold", None)
    assert isinstance(threshold, float) and threshold > 0, f"{name}: ood_threshold must be a positive float, got {threshold!r}"
    states = sample_skill_states(name, seed=seed) if states is None else np.asarray(states, dtype=np.float32)
    count = len(states)
    actions = np.asarray(skill.policy(states))
    assert actions.shape == (count, 4), f"{name}: policy gave shape {actions.shape}, expected {(count, 4)}"
    assert np.all(np.isfinite(actions)) and np.all(np.abs(actions) <= 1.0), f"{name}: policy actions must be finite and in [-1, 1]"
    random_actions = np.random.default_rng(seed).uniform(-1, 1, (count, 4)).astype(np.float32)
    q = np.asarray(skill.q_values(states, random_actions))
    assert q.ndim == 2 and q.shape[0] == count and q.shape[1] >= 1, f"{name}: q_values gave shape {q.shape}, expected ({count}, B)"
    assert np.all((q >= 0.0) & (q <= 1.0)), f"{name}: q_values must be probabilities in [0, 1]"
    predicted = np.asarray(skill.predict(states, random_actions))
    assert predicted.shape == (count, STATE_DIM), f"{name}: predict gave shape {predicted.shape}, expected {(count, STATE_DIM)}"
    assert np.all(np.isfinite(predicted)), f"{name}: predict gave non-finite values"
    checked = [("policy", actions, (states,)), ("q_values", q, (states, random_actions)), ("predict", predicted, (states, random_actions))]
    if getattr(skill, "ood_variance", None) is not None:
        variance = np.asarray(skill.ood_variance(states, random_actions, q))
        assert variance.shape == (count,), f"{name}: ood_variance gave shape {variance.shape}, expected {(count,)}"
        # a population variance of probabilities lies in [0, 1/4]
        assert np.all((variance >= 0.0) & (variance <= 0.25 + 1e-6)), f"{name}: ood_variance must be a variance of probabilities, in [0, 0.25]"
        checked.append(("ood_variance", variance, (states, random_actions, q)))
    for method, result, args in checked:
        again = np.asarray(getattr(skill, method)(*args))
        assert np.array_equal(again, result), f"{name}: {method} is not deterministic"
        singles = np.concatenate([np.asarray(getattr(skill, method)(*(a[i : i + 1] for a in args))) for i in range(count)])
        assert np.allclose(singles, result, atol=1e-5), f"{name}: {method} of a batch differs from its samples one by one"
