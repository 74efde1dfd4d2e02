"""Episode metrics (docs/guide/tasks.md#success-and-subgoal-completion): failure types and the
subgoal-completion rate, computed with the workspace-aware symbolic model."""

from __future__ import annotations

from collections.abc import Sequence

from t2m_core.domain.skills import SkillCall
from t2m_core.tasks.model import Task
from t2m_core.tasks.symbolic_model import initial_facts, replay, shortest_plan

PLANNING_FAILURE = "planning_failure"
EXECUTION_FAILURE = "execution_failure"
"""The two failure types: no plan was found (nothing executed); or a plan was found but a skill
failed or the goal does not hold after it."""


def subgoal_completion(task: Task, executed: Sequence[SkillCall], success: bool) -> float:
    """1 for a success; otherwise the share of the way to the goal that the executed skills covered:
    ``c_done / (c_done + c_togo)``, where ``c_done`` counts the executed skills that were symbolically
    valid in order and ``c_togo`` is the shortest remaining plan; when the symbolic goal already holds
    but the episode failed geometrically, ``(c_opt − Δ) / c_opt`` with Δ = 1 if ``c_done ≤ c_opt``
    else ``c_done − c_opt``."""
    if success:
        return 1.0
    facts, done = replay(task, executed)
    remaining = shortest_plan(facts, task.goal, task.objects)
    if remaining.plan is None:
        return 0.0 if done == 0 else done / (done + 20)  # no plan within depth 20: at most this much progress
    to_go = len(remaining.plan)
    if to_go > 0:
        return done / (done + to_go)
    optimal = shortest_plan(initial_facts(task), task.goal, task.objects).plan
    optimal_length = len(optimal) if optimal else max(done, 1)
    delta = 1 if done <= optimal_length else done - optimal_length
    return max(0.0, (optimal_length - delta) / optimal_length)
