"""Conformance check for :class:`t2m_core.protocols.TaskPlanner` implementations."""

from __future__ import annotations

from typing import Any

import numpy as np

from t2m_core.domain.goals import goal_satisfied
from t2m_core.domain.observation import decode_observation
from t2m_core.domain.skills import SkillCall
from t2m_core.protocols import PlanningContext, TaskPlan


def check_task_planner(planner: Any, context: PlanningContext) -> TaskPlan:
    """Run ``planner`` once on ``context`` and assert that its answer is well formed.

    Checks: a :class:`TaskPlan` of :class:`SkillCall` s over the scene's objects, within the planner's
    ``max_depth`` when it has one; non-negative call counts; a failure has a reason; a found lookahead
    plan carries its feasibility plan (one action per skill, one more state) and its last predicted
    state satisfies the goal. Returns the plan for further checks.

    Raises:
        AssertionError: naming the first violation.
    """
    result = planner.plan(context)
    assert isinstance(result, TaskPlan), f"plan() must return a TaskPlan, got {type(result).__name__}"
    assert all(isinstance(call, SkillCall) for call in result.skeleton), "the skeleton must hold SkillCall objects"
    for call in result.skeleton:
        assert set(call.args) <= set(context.object_names), f"{call} names an object that is not in the scene"
    depth = getattr(getattr(planner, "options", None), "max_depth", None)
    assert depth is None or len(result.skeleton) <= depth, f"{len(result.skeleton)} skills exceed max_depth {depth}"
    assert result.llm_calls >= 0 and result.stap_calls >= 0, "call counts must be non-negative"
    if not result.found:
        assert isinstance(result.failure, str) and result.failure, "a planning failure must say why"
    elif not result.executed:
        plan = result.plan
        assert plan is not None, "a found lookahead plan must carry its feasibility plan"
        assert np.asarray(plan.actions).shape == (len(result.skeleton), 4), "one (4,) action per planned skill"
        assert np.asarray(plan.states).shape == (len(result.skeleton) + 1, 8, 12), "one more predicted state than skills"
        final = decode_observation(plan.states[-1], context.object_names)
        assert goal_satisfied(context.goal, final, context.object_names), "the found plan's last predicted state must satisfy the goal"
    return result
