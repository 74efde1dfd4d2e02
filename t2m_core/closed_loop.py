"""Closed-loop execution of a fixed skill sequence (docs/guide/feasibility.md#closed-loop-execution).

Before every skill the remaining sequence is planned again from the simulator's real observation,
the first planned action is executed, and execution stops at the first failed primitive. There is no
task-level replanning here: the skeleton is fixed.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from t2m_core.domain.skills import SkillCall
from t2m_core.protocols import FeasibilityPlanner, PlanResult, PrimitiveResult


@dataclass(frozen=True)
class ExecutedStep:
    """One executed skill.

    Attributes:
        call: the skill. plan: the plan of the remaining skeleton made just before it (its first
        step is this skill). action: ``(4,)`` the executed action, as the simulator received it
        (clipped to [-1, 1]). result: what the simulator did. plan_seconds, execute_seconds: wall
        time of planning and of simulating it. retry: ``None``, or when the re-plan valued this skill
        below ``retry_below``: the ``p_success`` of the first and the second plan and which one was
        executed (``"first"`` or ``"second"``).
    """

    call: SkillCall
    plan: PlanResult
    action: np.ndarray
    result: PrimitiveResult
    plan_seconds: float
    execute_seconds: float
    retry: dict[str, Any] | None = None

    def summary(self) -> dict[str, Any]:
        """JSON-ready: the step's action (at full precision, so that replaying the recorded actions in
        the recorded scene reproduces the physics), values, OOD flags, p_success and outcome."""
        members = self.plan.q_members
        return {
            "skill": str(self.call),
            "action": [float(a) for a in self.action],
            "value": float(self.plan.values[0]),
            "q_members": [round(float(q), 4) for q in members[0]] if members is not None and len(members) else None,
            "ood": bool(self.plan.ood[0]),
            "p_success_remaining": float(self.plan.p_success),
            "success": bool(self.result.success),
            "failure": self.result.failure,
            "plan_seconds": round(self.plan_seconds, 3),
            "execute_seconds": round(self.execute_seconds, 3),
            **({} if self.retry is None else {"retry": self.retry}),
        }


@dataclass
class ClosedLoopResult:
    """What a closed-loop execution did: its steps in order; ``success`` when every skill succeeded."""

    steps: list[ExecutedStep] = field(default_factory=list)
    initial_plan: PlanResult | None = None

    @property
    def success(self) -> bool:
        return bool(self.steps) and all(step.result.success for step in self.steps)


def execute_closed_loop(
    simulator: Any,
    planner: FeasibilityPlanner,
    skills: Mapping[str, Any],
    skeleton: Sequence[SkillCall],
    object_names: Sequence[str],
    *,
    on_step: Callable[[ExecutedStep], None] | None = None,
    closed_loop: bool = True,
    replan_start: str = "policy",
    accepted: PlanResult | None = None,
    retry_below: float | None = None,
) -> ClosedLoopResult:
    """Execute ``skeleton`` in ``simulator`` (already reset), planning with ``planner``.

    Args:
        object_names: the present objects in observation-row order.
        on_step: called after each executed skill.
        closed_loop: re-plan the remaining skills before each one (default); ``False`` executes the
            first plan's actions open loop.
        replan_start: where each re-plan starts: ``"policy"``, from scratch (the feasibility
            planner's own start); ``"planned"``, from the actions planned before it for the same
            skills (``accepted``'s for the first skill, then the previous plan's remaining ones).
        accepted: the plan a task planner accepted for ``skeleton`` from this start (or ``None``).
        retry_below: when a re-plan values the skill it is about to execute below this, plan the
            remaining skills once more from the other start (``planned`` for ``policy`` and the
            other way round; no second plan where there are no planned actions yet) and execute the
            plan with the higher ``p_success``. ``None``: never.
    """
    if replan_start not in ("policy", "planned"):
        raise ValueError(f"replan_start must be 'policy' or 'planned', got {replan_start!r}")
    outcome = ClosedLoopResult()
    first_plan: PlanResult | None = None
    previous = accepted.actions if accepted is not None else None  # (remaining skills, 4) planned before for skeleton[index:]
    for index, call in enumerate(skeleton):
        started = time.perf_counter()
        retry = None
        if closed_loop or first_plan is None:
            observation, remaining = simulator.observation(), list(skeleton[index:])
            planned_start = {"initial_actions": previous} if previous is not None else None
            start = planned_start if replan_start == "planned" and planned_start is not None else {}
            plan = planner.plan(observation, remaining, skills, object_names, **start)
            if retry_below is not None and float(plan.values[0]) < retry_below:
                other = planned_start if not start else {}  # after a policy start the planned one, and vice versa
                if other is not None:
                    second = planner.plan(observation, remaining, skills, object_names, **other)
                    chosen = "second" if float(second.p_success) > float(plan.p_success) else "first"
                    retry = {"first_p_success": float(plan.p_success), "second_p_success": float(second.p_success), "chosen": chosen}
                    plan = second if chosen == "second" else plan
            previous = np.asarray(plan.actions)[1:]
            offset = 0
        else:
            plan, offset = first_plan, index
        first_plan = first_plan or plan
        planned = time.perf_counter()
        action = np.clip(np.asarray(plan.actions[offset], dtype=np.float64), -1.0, 1.0)
        result = simulator.execute(call.name, call.args, action)
        step = ExecutedStep(call, _from_step(plan, offset), action, result, planned - started, time.perf_counter() - planned, retry)
        outcome.steps.append(step)
        if on_step is not None:
            on_step(step)
        if not result.success:
            break
    outcome.initial_plan = first_plan
    return outcome


def _from_step(plan: PlanResult, offset: int) -> PlanResult:
    """``plan`` seen from its step ``offset`` on (the open-loop case reuses one plan)."""
    if offset == 0:
        return plan
    values, ood = plan.values[offset:], plan.ood[offset:]
    return PlanResult(
        plan.actions[offset:], plan.states[offset:], values, ood, float(np.prod(values * ~ood)),
        None if plan.variances is None else plan.variances[offset:],
        None if plan.q_members is None else plan.q_members[offset:],
    )
