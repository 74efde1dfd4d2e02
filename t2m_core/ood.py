"""The OOD statistic every planner thresholds (docs/guide/skills.md#ood-detection).

A skill is out of distribution at a (state, action) when the population variance of its ensemble's
member probabilities reaches the skill's ``ood_threshold``. By default that ensemble is the skill's
Q-ensemble (the published detector); a skill library may give a skill a separate detector ensemble
by defining ``ood_variance(states, actions, q_members)``, which then answers instead
(docs/guide/skills.md#a-separate-detector).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from t2m_core.protocols import Batch


def ood_variance(skill: Any, states: Batch, actions: Batch, q_members: Batch) -> Batch:
    """``(N,)`` the statistic compared with ``skill.ood_threshold``.

    Args:
        skill: a :class:`t2m_core.protocols.Skill`, with or without ``ood_variance``.
        states: ``(N, 96)`` skill states; actions: ``(N, 4)``.
        q_members: ``(N, B)`` what ``skill.q_values(states, actions)`` returned (its variance is the
            statistic when the skill has no separate detector).
    """
    detector = getattr(skill, "ood_variance", None)
    if detector is not None:
        return detector(states, actions, q_members)
    return members_variance(q_members)


def members_variance(q_members: Batch) -> Batch:
    """``(N,)`` population variance of ``(N, B)`` member probabilities (the published statistic)."""
    if isinstance(q_members, np.ndarray):
        return q_members.var(axis=1)
    return q_members.var(dim=1, unbiased=False)
