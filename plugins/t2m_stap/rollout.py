"""Batched rollouts of a skeleton through the skills' learned models (docs/guide/feasibility.md#rollout).

All trajectories of a batch advance together, one skill at a time: encode the predicted raw
observations for the skill (argument-first rows, normalised, flattened), take the actions (given or
the policy's), evaluate the Q-ensemble once for the whole batch, predict the next observations with
the dynamics and decode them back to raw rows. Everything stays in torch; no Python loop runs over
samples or ensemble members.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import torch

from t2m_core.domain.observation import FEATURE_HIGH, FEATURE_LOW, STATIC_FEATURES, argument_first_order
from t2m_core.domain.skills import SkillCall
from t2m_core.ood import members_variance, ood_variance
from t2m_core.protocols import Skill
from t2m_stap.geometric_veto import Veto, geometric_veto

_MID = torch.from_numpy(0.5 * (FEATURE_LOW + FEATURE_HIGH))
_SPAN = torch.from_numpy(FEATURE_HIGH - FEATURE_LOW)


@dataclass(frozen=True)
class Step:
    """One skill of the skeleton, ready to roll out.

    Attributes:
        call: the grounded skill. skill: its learned models.
        order: ``(8,) int64`` argument-first order of the raw rows; inverse: its inverse.
        present: number of present objects (rows 1..present).
        veto: ``None``, or the actions whose value is set to 0 whatever the ensemble says
            (:mod:`~t2m_stap.geometric_veto`).
    """

    call: SkillCall
    skill: Skill
    order: torch.Tensor
    inverse: torch.Tensor
    present: int
    veto: Veto | None = None


def prepare_steps(
    skeleton: Sequence[SkillCall],
    skills: Mapping[str, Skill],
    object_names: Sequence[str],
    *,
    vetoed: frozenset[str] = frozenset(),
    vetoed_first: frozenset[str] = frozenset(),
) -> list[Step]:
    """Row orders and models of every skill in ``skeleton``; for the calls ``vetoed`` names (by skill
    or lifted call, :func:`~t2m_stap.options.veto_entry`), and for the first call also those
    ``vetoed_first`` names, the geometric veto of their actions
    (:func:`~t2m_stap.geometric_veto.geometric_veto`).

    Raises:
        KeyError: a skill the library does not have, naming the ones it has.
    """
    steps = []
    for index, call in enumerate(skeleton):
        if call.name not in skills:
            raise KeyError(f"the skill library has no {call.name!r} skill; it has {', '.join(sorted(skills))}")
        row_order = argument_first_order(object_names, call.args)
        order = torch.from_numpy(row_order.order)
        entries = vetoed | vetoed_first if index == 0 else vetoed
        veto = geometric_veto(call, object_names) if entries & {call.name, call.lifted} else None
        steps.append(Step(call, skills[call.name], order, torch.from_numpy(row_order.inverse), row_order.num_present, veto))
    return steps


def encode(observations: torch.Tensor, step: Step) -> torch.Tensor:
    """``(N, 8, 12)`` raw observations → ``(N, 96)`` skill (and dynamics) states of ``step``."""
    return ((observations[:, step.order] - _MID) / _SPAN).reshape(observations.shape[0], -1)


def decode(prediction: torch.Tensor, observations: torch.Tensor, step: Step) -> torch.Tensor:
    """A dynamics prediction ``(N, 96)`` back to raw observations ``(N, 8, 12)``: clamped to
    [−0.5, 0.5], un-normalised, rows scattered back, static features copied from the pre-state, rows
    beyond the present objects zeroed."""
    rows = prediction.clamp(-0.5, 0.5).reshape(-1, 8, 12) * _SPAN + _MID
    restored = rows[:, step.inverse]
    restored[..., STATIC_FEATURES] = observations[..., STATIC_FEATURES]
    restored[:, 1 + step.present :] = 0.0
    return restored


@dataclass
class Rollouts:
    """A batch of rolled-out trajectories.

    Attributes:
        actions: ``(N, T, 4)``. states: ``(N, T + 1, 8, 12)`` raw observations (the first given).
        values: ``(N, T)`` clip(min_i Q_i, 0, 1). variances: ``(N, T)`` the OOD statistic: population
        variance of the members, or of the skills' separate detectors after :func:`with_detectors`.
        q_members: ``(N, T, B)``.
    """

    actions: torch.Tensor
    states: torch.Tensor
    values: torch.Tensor
    variances: torch.Tensor
    q_members: torch.Tensor

    def ood(self, thresholds: torch.Tensor) -> torch.Tensor:
        """``(N, T) bool`` variance ≥ the step's skill threshold."""
        return self.variances >= thresholds

    def p_success(self, thresholds: torch.Tensor | None = None) -> torch.Tensor:
        """``(N,)`` product of the values, OOD-masked when ``thresholds`` are given."""
        values = self.values if thresholds is None else self.values * (~self.ood(thresholds))
        return values.prod(dim=1)


_FIELDS = ("actions", "states", "values", "variances", "q_members")


def _as_tensor(values: Any) -> torch.Tensor:
    return values if isinstance(values, torch.Tensor) else torch.as_tensor(np.asarray(values, dtype=np.float32))


@torch.no_grad()
def rollout(
    steps: Sequence[Step],
    observation: torch.Tensor,
    actions: torch.Tensor | None = None,
    *,
    count: int = 1,
    policy_noise: float = 0.0,
    generator: torch.Generator | None = None,
    prefix_actions: torch.Tensor | None = None,
) -> Rollouts:
    """Roll out ``count`` trajectories from one ``(8, 12)`` observation.

    Args:
        steps: the prepared skeleton.
        observation: the start.
        actions: ``(N, T, 4)`` actions to evaluate; ``None``: the policy acts at every predicted
            state (plus N(0, policy_noise²) noise, clipped, when ``policy_noise > 0``).
        count: trajectories when ``actions`` is ``None``.
        prefix_actions: ``(T0, 4)``, ``T0 <= T``: when ``actions`` is ``None``, every trajectory takes
            these actions at its first ``T0`` steps (no noise) and the policy's after them.
    """
    n = actions.shape[0] if actions is not None else count
    current = observation.expand(n, -1, -1).clone()
    states, chosen, values, variances, members = [current], [], [], [], []
    for t, step in enumerate(steps):
        encoded = encode(current, step)
        if actions is not None:
            action = actions[:, t]
        elif prefix_actions is not None and t < prefix_actions.shape[0]:
            action = prefix_actions[t].expand(n, -1)
        else:
            action = _as_tensor(step.skill.policy(encoded))
            if policy_noise > 0:
                noise = torch.randn(action.shape, generator=generator) * policy_noise
                action = (action + noise).clamp(-1.0, 1.0)
        q = _as_tensor(step.skill.q_values(encoded, action))
        value = q.min(dim=1).values.clamp(0.0, 1.0)
        if step.veto is not None:
            value = value.masked_fill(step.veto(current, action), 0.0)
        current = decode(_as_tensor(step.skill.predict(encoded, action)), current, step)
        chosen.append(action)
        values.append(value)
        variances.append(members_variance(q))
        members.append(q)
        states.append(current)
    return Rollouts(
        torch.stack(chosen, 1), torch.stack(states, 1), torch.stack(values, 1), torch.stack(variances, 1), torch.stack(members, 1)
    )


def with_detectors(steps: Sequence[Step], rollouts: Rollouts, index: int | None = None) -> Rollouts:
    """``rollouts`` (trajectory ``index`` alone when given, as a batch of one) whose variances are each
    step's OOD statistic from :func:`t2m_core.ood.ood_variance`: a skill's separate detector where it
    has one (evaluated here, on the stored states and actions), its members' variance elsewhere.
    Planners call it on the trajectory they return, and on every sample only when the flags score
    them, so that a detector costs the search nothing."""
    part = rollouts if index is None else Rollouts(*(getattr(rollouts, f)[index : index + 1] for f in _FIELDS))
    columns = []
    for t, step in enumerate(steps):
        if getattr(step.skill, "ood_variance", None) is None:
            columns.append(part.variances[:, t])
        else:
            encoded = encode(part.states[:, t], step)
            columns.append(_as_tensor(ood_variance(step.skill, encoded, part.actions[:, t], part.q_members[:, t])))
    return replace(part, variances=torch.stack(columns, 1) if columns else part.variances)


def rollout_in_chunks(steps: Sequence[Step], observation: torch.Tensor, actions: torch.Tensor, chunk_size: int) -> Rollouts:
    """:func:`rollout` of many given action sequences, ``chunk_size`` trajectories at a time."""
    parts = [rollout(steps, observation, actions[start : start + chunk_size]) for start in range(0, actions.shape[0], chunk_size)]
    if len(parts) == 1:
        return parts[0]
    return Rollouts(*(torch.cat([getattr(p, f) for p in parts]) for f in _FIELDS))


def thresholds_of(steps: Sequence[Step]) -> torch.Tensor:
    """``(T,)`` the OOD threshold of each step's skill (∞ when a skill has none)."""
    return torch.tensor([float(getattr(step.skill, "ood_threshold", float("inf"))) for step in steps])
