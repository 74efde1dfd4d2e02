"""The myopic baselines saycan-gs and innermono-gs (docs/guide/planners.md#saycan-gs): plan one
skill, execute it, repeat. The language model generates K candidates, which are scored together with
``stop()``; each candidate's feasibility is its skill's Q-value for the policy's action in the *real*
current state, masked by the OOD flag; no lookahead, no goal test (the predicted goal only appears in
the prompt). innermono-gs also shows the model the relationships observed after every execution.
"""

from __future__ import annotations

import math

import numpy as np

from t2m_core.domain.observation import argument_first_order, skill_state
from t2m_core.domain.skills import SkillCall
from t2m_core.language.prompts import HistoryStep, PromptBuilder, scoring_request
from t2m_core.language.queries import query_next_skills
from t2m_core.language.scene_description import relationships_of
from t2m_core.language.scoring import dampened_softmax
from t2m_core.language.session import valid_groundings
from t2m_core.ood import ood_variance
from t2m_core.protocols import PlanningContext, TaskPlan
from t2m_planners.options import MyopicOptions

STOP = "stop()"


class MyopicPlanner:
    """``saycan-gs`` (``scene_feedback=False``) and ``innermono-gs`` (``True``)."""

    def __init__(self, options: MyopicOptions | None = None, scene_feedback: bool = False) -> None:
        self.options = options or MyopicOptions()
        self.scene_feedback = scene_feedback

    def plan(self, context: PlanningContext) -> TaskPlan:
        if context.simulator is None:
            raise ValueError("the myopic baselines execute as they plan: the planning context needs a simulator")
        options = self.options
        session = context.session
        builder = PromptBuilder(seed=session.prompts.seed, k=options.k, myopic=True, example_plans=session.prompts.example_plans)
        objects = tuple(context.object_names)
        history: list[HistoryStep] = []
        executed: list[SkillCall] = []
        llm_calls = 0
        for _ in range(options.max_depth):
            state = context.simulator.geometric_state()
            observation = context.simulator.observation()
            relationships = relationships_of(state, objects)
            prompt = builder.next_skill(session.scene, context.goal, history)
            grounded = [str(c) for c in valid_groundings(objects, relationships)] if session.grounded else None
            proposed, attempts = query_next_skills(session.model, prompt, objects, options.k, constrained=session.constrained, calls=grounded or None)
            llm_calls += len(attempts)
            calls = list(dict.fromkeys(proposed.calls))
            options_text = [str(c) for c in calls] + [STOP]
            request, continuations = scoring_request(builder.scoring_context(session.scene, context.goal, history), options_text)
            logprobs = [v if math.isfinite(v) else -math.inf for v in session.model.score(request, continuations)]
            llm_calls += 1
            usefulness = dampened_softmax(logprobs, options.beta)
            values = [self._value(context, call, observation, objects) for call in calls]
            stop_first = int(np.argmax(logprobs)) == len(calls)
            values.append(options.stop_value_when_top if stop_first else options.stop_value)
            scores = [u * v for u, v in zip(usefulness, values, strict=True)]
            best = int(np.argmax(scores))
            if context.on_event is not None:
                context.on_event({
                    "event": "myopic_step",
                    "executed": [str(c) for c in executed],
                    "candidates": [
                        {"skill": text, "logprob": round(lp, 4) if math.isfinite(lp) else None, "usefulness": round(u, 4), "value": round(v, 4), "chosen": i == best}
                        for i, (text, lp, u, v) in enumerate(zip(options_text, logprobs, usefulness, values, strict=True))
                    ],
                })
            if best == len(calls) or stop_first:
                break
            call = calls[best]
            action = context.skills[call.name].policy(skill_state(observation, argument_first_order(objects, call.args))[None])[0]
            result = context.simulator.execute(call.name, call.args, np.clip(np.asarray(action, dtype=np.float64), -1.0, 1.0))
            executed.append(call)
            if context.on_event is not None:
                context.on_event({"event": "executed", "skill": str(call), "success": bool(result.success), "failure": result.failure})
            after = relationships_of(result.state, objects) if self.scene_feedback else None
            history.append(HistoryStep(str(call), after))
        # the episode ends on stop() or after max_depth skills; the ground-truth check judges it
        return TaskPlan(executed, None, None, True, llm_calls, 0)

    @staticmethod
    def _value(context: PlanningContext, call: SkillCall, observation: np.ndarray, objects: tuple[str, ...]) -> float:
        """clip(min_i Q_i(s, π(s)), 0, 1) · (1 − OOD) in the real current state."""
        skill = context.skills.get(call.name)
        if skill is None:
            return 0.0
        state = skill_state(observation, argument_first_order(objects, call.args))[None]
        action = np.asarray(skill.policy(state))
        q = np.asarray(skill.q_values(state, action))[0]
        variance = float(np.asarray(ood_variance(skill, state, action, q[None]))[0])
        out_of_distribution = variance >= float(getattr(skill, "ood_threshold", math.inf))
        return 0.0 if out_of_distribution else float(np.clip(q.min(), 0.0, 1.0))


def saycan_gs(options: MyopicOptions) -> MyopicPlanner:
    return MyopicPlanner(options, scene_feedback=False)


def innermono_gs(options: MyopicOptions) -> MyopicPlanner:
    return MyopicPlanner(options, scene_feedback=True)
