"""Test doubles for the task planners: a language model answering by rule, and a feasibility
planner that predicts states geometrically from the skills' symbolic effects with scripted values,
so that a planner's decisions can be checked against answers the test knows."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from t2m_core.domain.objects import object_spec
from t2m_core.domain.skills import SkillCall
from t2m_core.language.prompts import GOAL_QUERY, next_skill_query, shooting_query
from t2m_core.protocols import LanguageModelCapabilities, PlanResult


class RuleModel:
    """Answers shooting prompts with ``sequences`` (one answer, or one per query with the last
    repeated), next-skill prompts with ``next_skills`` (one list per greedy step, the last repeated),
    and scores candidates from ``scores`` (default −5 nats)."""

    def __init__(self, sequences: str | Sequence[str] = "[]", next_skills: Sequence[str] = ("[]",), scores: Mapping[str, float] | None = None,
                 goal: str = "[]") -> None:
        self.goal = goal
        self.sequences = [sequences] if isinstance(sequences, str) else list(sequences)
        self.next_skills = list(next_skills)
        self.scores = dict(scores or {})
        self.capabilities = LanguageModelCapabilities(exact_scoring=True, grammar=False)
        self.requests: list[str] = []

    def complete(self, prompt, *, max_tokens=256, stop=(), temperature=0.0, n=1, grammar=None):
        if prompt.endswith(shooting_query()):
            self.requests.append("shooting")
            answer = self.sequences[0] if len(self.sequences) == 1 else self.sequences.pop(0)
            return [answer] * n
        if prompt.endswith(next_skill_query()):
            self.requests.append("next")
            answer = self.next_skills[0] if len(self.next_skills) == 1 else self.next_skills.pop(0)
            return [answer] * n
        if prompt.endswith(GOAL_QUERY):
            self.requests.append("goal")
            return [self.goal] * n
        self.requests.append("other")
        return ["[]"] * n

    def score(self, prompt, candidates):
        self.requests.append("score")
        return [self.scores.get(c.strip(), -5.0) for c in candidates]


class SymbolicFeasibility:
    """Predicts each step's state by moving objects where the skill's symbolic effect says (a picked
    object to the gripper, a placed one onto its support), with ``values[str(call)]`` (default 0.9)
    as every step's value (0.05 for placing an object that is not held: infeasible) and the calls in
    ``ood`` flagged. ``drift`` (metres per step, along x) moves every object the skill does not name,
    as a learned dynamics model's error would."""

    def __init__(self, values: Mapping[str, float] | None = None, ood: Sequence[str] = (), drift: float = 0.0) -> None:
        self.values = dict(values or {})
        self.ood = set(ood)
        self.drift = drift
        self.calls: list[list[str]] = []
        self.starts: list[np.ndarray | None] = []
        """The ``initial_actions`` of every call (``None`` when none were given)."""

    def plan(self, observation, skeleton: Sequence[SkillCall], skills, object_names, *, initial_actions=None) -> PlanResult:
        self.calls.append([str(c) for c in skeleton])
        self.starts.append(None if initial_actions is None else np.asarray(initial_actions).copy())
        rows = {name: 1 + i for i, name in enumerate(object_names)}
        states = [np.asarray(observation, np.float32).copy()]
        held, values = None, []
        for call in skeleton:
            values.append(0.05 if call.name == "place" and call.args[0] != held else self.values.get(str(call), 0.9))
            held = call.args[0] if call.name == "pick" else None
            state = states[-1].copy()
            for name, row in rows.items():
                if name not in call.args and name != "table":
                    state[row, 0] += self.drift
            target = call.args[0]
            size_z = object_spec(target).size[2]
            if call.name == "pick":
                state[rows[target], :3] = (0.4, 0.0, 0.40)
            elif call.name == "place":
                support = call.args[1]
                top = state[rows[support], 2] if object_spec(support).kind.value == "rack" else 0.0
                x, y = (state[rows[support], 0], state[rows[support], 1]) if support != "table" else (0.5, 0.3)
                state[rows[target], :3] = (x, y, top + size_z / 2 + 0.002)
            states.append(state)
        values = np.array(values, np.float32)
        ood = np.array([str(c) in self.ood for c in skeleton], bool)
        actions = np.tile(np.linspace(-0.5, 0.5, len(skeleton), dtype=np.float32)[:, None], (1, 4))  # step k's, for tracing
        return PlanResult(actions, np.stack(states), values, ood, float(np.prod(values * ~ood)))
