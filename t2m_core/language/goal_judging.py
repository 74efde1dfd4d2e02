"""Whether a predicted goal means the true one, judged on what can happen in the scene rather than
on how the goal is written (docs/guide/language-models.md#judging-goals).

Both figures use the states reachable from the scene's symbolic initial state within ``d_max``
skills under the workspace-aware symbolic model (:mod:`t2m_core.tasks.symbolic_model`):

- **strict**: the predicted and the true goal accept exactly the same reachable states (so
  ``[['on(red_box, rack)', 'on(rack, table)']]`` means ``[['on(red_box, rack)']]``: the rack never
  leaves the table), and at least one;
- **plan-level**: every shortest plan that reaches the predicted goal also reaches the true one,
  i.e. every state at the predicted goal's minimal distance that satisfies it satisfies the true
  goal (a prediction that adds a proposition already true, or pins boxes that a shortest plan
  leaves alone, is right here and wrong under strict).

"No valid goal" is a third kind of answer: a prediction of no goal is right, under both figures,
exactly when the truth is no goal.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass

from t2m_core.domain.goals import Goal
from t2m_core.tasks.symbolic_model import Facts, applicable, apply, groundings

D_MAX = 10
"""Longest plan considered, in skills (docs/guide/planners.md#constants)."""


def reachable_states(facts: Facts, objects: Sequence[str], d_max: int = D_MAX) -> dict[Facts, int]:
    """Every symbolic state reachable from ``facts`` in at most ``d_max`` skills, with its distance
    (breadth-first, so the distance is the shortest plan's length)."""
    calls = groundings(objects)
    distance = {facts: 0}
    frontier = deque([facts])
    while frontier:
        state = frontier.popleft()
        if distance[state] >= d_max:
            continue
        for call in calls:
            if applicable(call, state):
                successor = apply(call, state)
                if successor not in distance:
                    distance[successor] = distance[state] + 1
                    frontier.append(successor)
    return distance


@dataclass(frozen=True)
class GoalJudgement:
    """How a prediction compares with the truth.

    Attributes:
        strict: the two goals accept the same reachable states (or both are "no valid goal").
        plan_level: every shortest plan to the prediction reaches the truth (or both are "no valid goal").
        predicted_distance: the prediction's shortest plan length, ``None`` when no reachable state
            satisfies it (or it is "no valid goal").
        true_distance: the same for the truth.
    """

    strict: bool
    plan_level: bool
    predicted_distance: int | None
    true_distance: int | None


def _accepted(goal: Goal, states: dict[Facts, int]) -> set[Facts]:
    return {state for state in states if goal.satisfied_by(state)}


def judge_goal(predicted: Goal | None, truth: Goal | None, states: dict[Facts, int]) -> GoalJudgement:
    """Judge ``predicted`` against ``truth`` over ``states`` (:func:`reachable_states`); ``None``
    stands for "no valid goal"."""
    if predicted is None or truth is None:
        same = predicted is None and truth is None
        true_distance = None if truth is None else min((states[s] for s in _accepted(truth, states)), default=None)
        return GoalJudgement(same, same, None, true_distance)
    accepted_predicted, accepted_truth = _accepted(predicted, states), _accepted(truth, states)
    predicted_distance = min((states[s] for s in accepted_predicted), default=None)
    true_distance = min((states[s] for s in accepted_truth), default=None)
    strict = bool(accepted_truth) and accepted_predicted == accepted_truth
    plan_level = predicted_distance is not None and all(
        state in accepted_truth for state in accepted_predicted if states[state] == predicted_distance
    )
    return GoalJudgement(strict, plan_level, predicted_distance, true_distance)
