"""Conformance check for :class:`t2m_core.protocols.FeasibilityPlanner` implementations."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from t2m_core.domain.skills import SkillCall


class _AlwaysOutOfDistribution:
    """A skill that delegates to another but flags every (state, action): threshold 0."""

    def __init__(self, skill: Any) -> None:
        self._skill = skill
        self.name, self.action_dim, self.ood_threshold = skill.name, skill.action_dim, 0.0

    def __getattr__(self, name: str) -> Any:
        return getattr(self._skill, name)


def check_feasibility_planner(
    planner: Any, observation: np.ndarray, skeleton: Sequence[SkillCall], skills: Mapping[str, Any], object_names: Sequence[str]
) -> None:
    """Assert that ``planner`` behaves as the FeasibilityPlanner protocol requires on one problem.

    Checks: shapes and dtypes of the plan result; actions in [−1, 1]; the first state is the given
    observation; values in [0, 1]; ``p_success`` equals the product of the OOD-masked values; the
    same call twice gives the same plan; ``initial_actions`` (the plan's own first actions) is
    accepted and gives a plan of the same shapes; with every skill's OOD threshold at 0 every step is
    flagged and ``p_success`` is 0.

    Raises:
        AssertionError: naming the first violation.
    """
    horizon = len(skeleton)
    result = planner.plan(observation, list(skeleton), skills, object_names)
    actions, states = np.asarray(result.actions), np.asarray(result.states)
    values, ood = np.asarray(result.values), np.asarray(result.ood)
    assert actions.shape == (horizon, 4), f"actions shape {actions.shape}, expected {(horizon, 4)}"
    assert np.all(np.isfinite(actions)) and np.all(np.abs(actions) <= 1.0), "actions must be finite and in [-1, 1]"
    assert states.shape == (horizon + 1, 8, 12), f"states shape {states.shape}, expected {(horizon + 1, 8, 12)}"
    np.testing.assert_allclose(states[0], observation, atol=1e-6, err_msg="states[0] must be the given observation")
    assert values.shape == (horizon,) and np.all((values >= 0) & (values <= 1)), "values must be (T,) in [0, 1]"
    assert ood.shape == (horizon,) and ood.dtype == bool, f"ood must be (T,) bool, got {ood.shape} {ood.dtype}"
    expected = float(np.prod(values * ~ood))
    assert abs(result.p_success - expected) <= 1e-5, f"p_success {result.p_success} != product of masked values {expected}"
    again = planner.plan(observation, list(skeleton), skills, object_names)
    assert np.array_equal(np.asarray(again.actions), actions) and again.p_success == result.p_success, "plan is not deterministic"
    started = planner.plan(observation, list(skeleton), skills, object_names, initial_actions=actions[: max(horizon - 1, 1)])
    assert np.asarray(started.actions).shape == (horizon, 4), "a plan given initial_actions must still cover the whole skeleton"
    flagged_skills = {name: _AlwaysOutOfDistribution(skill) for name, skill in skills.items()}
    flagged = planner.plan(observation, list(skeleton), flagged_skills, object_names)
    assert np.all(np.asarray(flagged.ood)), "a step whose variance reaches the threshold must be flagged OOD"
    assert flagged.p_success == 0.0, f"an OOD step must zero p_success, got {flagged.p_success}"
