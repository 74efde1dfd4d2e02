"""The three questions Text2Motion asks a language model, for one task scene: the goal, the next
skills worth trying (with their usefulness scores), and whole skill sequences. Used by ``t2m llm``
and ``benchmarks/llm_quality.py``; planners call the same prompt builders and query functions.

Relationships after planned skills come from the symbolic effects of the skills
(:func:`~t2m_core.domain.symbolic_effects.apply_effects`) when no feasibility planner has predicted them.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

from t2m_core.domain.enumeration import candidate_groundings
from t2m_core.domain.goals import Goal
from t2m_core.domain.literals import LiteralSyntaxError, parse_string_lists
from t2m_core.domain.propositions import GOAL_PREDICATES, Proposition, canonical_order
from t2m_core.domain.skills import SKILLS, SkillCall, SkillError
from t2m_core.domain.symbolic_effects import apply_effects, precondition_problems
from t2m_core.language.parsing import inst
from t2m_core.language.prompts import HistoryStep, K, PromptBuilder, scoring_request
from t2m_core.language.queries import Attempt, GoalQuery, query_goal, query_next_skills, query_skill_sequences
from t2m_core.language.scene_description import SceneDescription
from t2m_core.language.scoring import BETA, dampened_softmax
from t2m_core.protocols import LanguageModel


def symbolic_relationships(
    objects: Sequence[str], relationships: Sequence[str], executed: Sequence[SkillCall]
) -> list[tuple[str, ...]]:
    """Relationships after each executed skill, by its symbolic effects; one tuple per skill, in the
    scene description's order (under, on, inhand; then by the objects' order)."""
    position = {name: index for index, name in enumerate(objects)}
    facts = frozenset(Proposition.coerce(text) for text in relationships)
    after = []
    for call in executed:
        facts = apply_effects(call, facts)
        by_objects = sorted(facts, key=lambda p: [position.get(arg, len(position)) for arg in p.args])
        after.append(tuple(str(p) for p in canonical_order(by_objects) if p.predicate in GOAL_PREDICATES))
    return after


def valid_groundings(objects: Sequence[str], relationships: Sequence[str]) -> list[SkillCall]:
    """Every grounded skill that is symbolically valid given only the described relationships.

    Workspace facts are not part of a description, so the one rule that needs them (push needs the
    rack beyond the workspace) is not applied: the Q-functions judge reachability.
    """
    facts = [Proposition.coerce(text) for text in relationships]
    calls = []
    for skill in SKILLS:
        for call in candidate_groundings(skill, objects):
            problems = precondition_problems(call, facts)
            if all(problem.endswith("is not beyond the workspace") for problem in problems):
                calls.append(call)
    return calls


def parse_executed(text: str, objects: Sequence[str]) -> list[SkillCall]:
    """``"pick(a),place(a, rack)"`` or ``"['pick(a)', 'place(a, rack)']"`` -> validated skill calls.

    Raises:
        SkillError: naming the entry that is not a valid skill call in this scene.
    """
    text = text.strip()
    if not text:
        return []
    if text.startswith("["):
        try:
            entries = parse_string_lists(text)
        except LiteralSyntaxError as error:
            raise SkillError(f"cannot read the executed skills: {error.message}", error.hint) from None
    else:
        entries, depth, start = [], 0, 0
        for index, char in enumerate(text + ","):
            depth += {"(": 1, ")": -1}.get(char, 0)
            if char == "," and depth == 0:
                entries.append(text[start:index].strip())
                start = index + 1
    return [inst(str(entry), objects) for entry in entries if str(entry).strip()]


@dataclass
class ScoredCandidates:
    """Candidates of one next-skill query with their scores.

    Attributes:
        calls: the candidate skill calls.
        logprobs: ℓ_k, summed candidate-token log-probabilities (nats).
        usefulness: S_llm = softmax(β ℓ), β = 0.3.
        attempts: the generation attempts that produced the candidates (empty for a given set).
    """

    calls: list[SkillCall]
    logprobs: list[float]
    usefulness: list[float]
    attempts: list[Attempt] = field(default_factory=list)

    def ranked(self) -> list[tuple[SkillCall, float, float]]:
        """``(call, logprob, usefulness)``, best first."""
        return sorted(zip(self.calls, self.logprobs, self.usefulness, strict=True), key=lambda row: -row[1])


class LanguageSession:
    """Language queries about one scene with one example order.

    Args:
        model: any language model.
        scene: the scene description (objects, initial relationships, instruction).
        seed: the run seed (example order).
        k: candidates per query.
        constrained: use grammar-constrained decoding where the model supports it.
        beta: softmax dampening.
        grounded: with constrained decoding, next-skill answers may name only the symbolically valid
            groundings of the described relationships (:func:`valid_groundings`; a documented
            deviation: the reference leaves semantic validity to the Q-functions). ``False`` keeps the
            scene grammar, where any skill over any scene object is allowed.
        cues: let the instruction's relation and count cues shape the goal answer
            (:mod:`t2m_core.language.instruction_cues`).
        example_plans: how the step-wise prompts' examples write their plans
            (:data:`t2m_core.language.prompts.EXAMPLE_PLANS`).
    """

    def __init__(
        self,
        model: LanguageModel,
        scene: SceneDescription,
        *,
        seed: int = 0,
        k: int = K,
        constrained: bool = True,
        beta: float = BETA,
        grounded: bool = True,
        cues: bool = True,
        example_plans: str = "steps",
    ) -> None:
        self.model = model
        self.scene = scene
        self.prompts = PromptBuilder(seed=seed, k=k, example_plans=example_plans)
        self.k = k
        self.constrained = constrained
        self.beta = beta
        self.grounded = grounded
        self.cues = cues

    def predict_goal(self) -> GoalQuery:
        """The goal query (bounded re-query; ``goal`` is ``None`` when the instruction has no valid
        goal, ``no_goal`` saying why, or when every attempt was invalid)."""
        return query_goal(
            self.model,
            self.prompts.goal(self.scene),
            self.scene.objects,
            constrained=self.constrained,
            instruction=self.scene.instruction,
            relationships=self.scene.relationships,
            cues_on=self.cues,
        )

    def history(self, executed: Sequence[SkillCall]) -> list[HistoryStep]:
        """History lines for ``executed`` with symbolically predicted relationships."""
        after = symbolic_relationships(self.scene.objects, self.scene.relationships, executed)
        return [HistoryStep(str(call), relationships) for call, relationships in zip(executed, after, strict=True)]

    def current_relationships(self, executed: Sequence[SkillCall]) -> tuple[str, ...]:
        """Relationships after ``executed`` (the initial ones when it is empty)."""
        after = symbolic_relationships(self.scene.objects, self.scene.relationships, executed)
        return after[-1] if after else self.scene.relationships

    def _history(self, executed: Sequence[SkillCall], history: Sequence[HistoryStep] | None) -> list[HistoryStep]:
        return list(history) if history is not None else self.history(executed)

    def generate_next(
        self, goal: Goal, executed: Sequence[SkillCall], history: Sequence[HistoryStep] | None = None
    ) -> tuple[list[SkillCall], list[Attempt]]:
        """K candidate next skills from the next-skill prompt. ``history`` (the planned prefix with the
        relationships a feasibility planner predicted) replaces the symbolically predicted one."""
        history = self._history(executed, history)
        prompt = self.prompts.next_skill(self.scene, goal, history)
        calls = self.groundings(executed, history) if self.grounded else None
        candidates, attempts = query_next_skills(
            self.model,
            prompt,
            self.scene.objects,
            self.k,
            constrained=self.constrained,
            calls=[str(call) for call in calls] if calls else None,
        )
        return candidates.calls, attempts

    def groundings(self, executed: Sequence[SkillCall], history: Sequence[HistoryStep] | None = None) -> list[SkillCall]:
        """Every skill symbolically valid after ``executed`` (:func:`valid_groundings` of the last
        history step's relationships; ``history`` as in :meth:`generate_next`)."""
        history = self._history(executed, history)
        relationships = history[-1].relationships if history and history[-1].relationships is not None else self.scene.relationships
        return valid_groundings(self.scene.objects, relationships)

    def generate_sequences(
        self, goal: Goal, executed: Sequence[SkillCall] = (), history: Sequence[HistoryStep] | None = None
    ) -> tuple[list[tuple[SkillCall, ...]], list[Attempt]]:
        """K whole skill sequences (shooting) continuing ``executed``."""
        prompt = self.prompts.shooting(self.scene, goal, self._history(executed, history))
        return query_skill_sequences(self.model, prompt, self.scene.objects, self.k, constrained=self.constrained)

    def score(
        self, goal: Goal, executed: Sequence[SkillCall], calls: Sequence[SkillCall], history: Sequence[HistoryStep] | None = None
    ) -> ScoredCandidates:
        """ℓ and S_llm of each call as the next skill after ``executed``."""
        context = self.prompts.scoring_context(self.scene, goal, self._history(executed, history))
        prompt, continuations = scoring_request(context, [str(call) for call in calls])
        logprobs = self.model.score(prompt, continuations) if calls else []
        finite = [value if math.isfinite(value) else -math.inf for value in logprobs]
        return ScoredCandidates(list(calls), finite, dampened_softmax(finite, self.beta))
