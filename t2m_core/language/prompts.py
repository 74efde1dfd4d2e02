"""Prompt builders for goal prediction, shooting, next-skill generation and candidate scoring
(docs/guide/prompts.md), shared by every planner.

Layout::

    <header lines>                      primitives (planning prompts only), predicates
    <in-context example 1>              objects, relationships, instruction, goal [, plan]
    <blank line>
    ...
    <in-context example 10>
    <blank line>
    <current block>                     objects, relationships, instruction [, predicted goal, history]
    <query line>

Planning prompts use all 10 in-context examples (``examples/tableenv.yaml``), in an order shuffled
once per run with the run seed (:func:`examples_for_seed`), then (by default) sorted so that the
examples most relevant to the instruction stand last, next to the query (:func:`examples_by_relevance`).
Goal prompts (by default) show the 10 examples most relevant to the instruction out of those and
the goal-only examples (``examples/goals.yaml``), the closest last
(:mod:`t2m_core.language.example_retrieval`).

Usage::

    prompts = PromptBuilder(seed=3)
    text = prompts.goal(scene)                                  # -> model.complete(text, **GOAL_REQUEST)
    text = prompts.next_skill(scene, goal, history)             # -> parse K candidates
    prompt, continuations = scoring_request(prompts.scoring_context(scene, goal, history), candidates)
    logprobs = model.score(prompt, continuations)
"""

from __future__ import annotations

import functools
import random
from collections.abc import Sequence
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

import yaml

from t2m_core.domain.goals import Goal
from t2m_core.domain.literals import format_string_list
from t2m_core.domain.skills import SKILLS, STOP
from t2m_core.errors import T2MError
from t2m_core.language.example_retrieval import most_relevant
from t2m_core.language.scene_description import SceneDescription

K = 5
"""Skills or skill sequences proposed per query (docs/guide/planners.md#constants)."""

PREDICATES = ("on(a, b)", "inhand(a)", "under(a, b)")
"""Goal predicates in the order the header lists them."""

PRIMITIVES_LABEL = "Available primitives: "
PREDICATES_LABEL = "Available predicates: "
GOAL_LABEL = "Goal predicate set: "
PREDICTED_GOAL_LABEL = "Predicted goal predicate set: "
PLAN_LABEL = "Top robot action sequence: "
EXECUTED_LABEL = "Executed action:"
NEW_RELATIONSHIPS_LABEL = "New object relationships: "

# Query lines end at the colon, without the reference's trailing space (a documented deviation):
# BPE tokenizers merge the space into the answer's first token (" [["), so a prompt that ends in a
# bare space puts the model off-distribution; the examples' "label: [..." spelling is unchanged.
GOAL_QUERY = "Predicted goal predicate set (python list of lists):"
INSTRUCTION_ACHIEVED_QUERY = "Instruction achieved (True/False):"


def shooting_query(k: int = K) -> str:
    """``Top 5 robot action sequences (python list of lists):``."""
    return f"Top {k} robot action sequences (python list of lists):"


def next_skill_query(k: int = K) -> str:
    """``Top 5 valid next robot actions (single python list of primitives):``."""
    return f"Top {k} valid next robot actions (single python list of primitives):"


# Stop sequences and token budgets. Every answer is one line in the examples, so a
# newline also ends it (docs/guide/deviations.md#a-newline-ends-every-answer: it stops small models that ramble into a new block).
GOAL_REQUEST: dict[str, Any] = {
    "max_tokens": 200,
    "stop": ["\n", "Available scene objects:", "Human instruction:", PLAN_LABEL.strip()],
    "temperature": 0.0,
}
SHOOTING_REQUEST: dict[str, Any] = {
    "max_tokens": 500,
    "stop": ["\n", EXECUTED_LABEL, "New", PLAN_LABEL.strip(), "```"],
    "temperature": 0.0,
}
NEXT_SKILL_REQUEST: dict[str, Any] = {"max_tokens": 100, "stop": ["\n"], "temperature": 0.0}


# --------------------------------------------------------------------------------------------------
# In-context examples
# --------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Example:
    """One in-context example (docs/guide/prompts.md#in-context-examples).

    Attributes:
        objects: scene objects, ``table`` first.
        relationships: on/under/inhand relations of the start scene.
        instruction: one sentence.
        goal: the goal alternatives, list of lists of proposition strings; empty when no goal
            expresses the instruction (goal-only examples).
        plan: skill calls that solve it from the start scene (empty for goal-only examples).
    """

    objects: tuple[str, ...]
    relationships: tuple[str, ...]
    instruction: str
    goal: tuple[tuple[str, ...], ...]
    plan: tuple[str, ...]


DEFAULT_EXAMPLES = "tableenv.yaml"
"""The shipped example set under ``t2m_core/language/examples/``."""
GOAL_EXAMPLES = "goals.yaml"
"""The shipped goal-only examples (no plan; goal prompts only)."""
GOAL_EXAMPLES_SHOWN = 10
"""Examples a goal prompt shows, chosen by relevance from the planning and goal-only examples."""


def load_examples(path: str | Path | None = None) -> tuple[Example, ...]:
    """Examples from a YAML file (``examples: [{objects, relationships, instruction, goal, plan}]``);
    the shipped set by default.

    Raises:
        T2MError: a missing field or a wrongly typed value, naming the example.
    """
    if path is None:
        return _shipped_examples()
    return _parse_examples(Path(path).read_text(encoding="utf-8"), str(path))


def load_goal_examples(path: str | Path | None = None) -> tuple[Example, ...]:
    """Goal-only examples (``plan`` optional, ``goal`` may be ``[]``); the shipped set by default."""
    if path is None:
        return _shipped_examples(GOAL_EXAMPLES)
    return _parse_examples(Path(path).read_text(encoding="utf-8"), str(path), goal_only=True)


@functools.cache
def _shipped_examples(name: str = DEFAULT_EXAMPLES) -> tuple[Example, ...]:
    text = resources.files("t2m_core.language").joinpath("examples", name).read_text(encoding="utf-8")
    return _parse_examples(text, name, goal_only=name == GOAL_EXAMPLES)


def _parse_examples(text: str, source: str, goal_only: bool = False) -> tuple[Example, ...]:
    data = yaml.safe_load(text)
    entries = data.get("examples") if isinstance(data, dict) else None
    if not isinstance(entries, list) or not entries:
        raise T2MError(f"{source}: expected a top-level 'examples' list", hint="see t2m_core/language/examples/tableenv.yaml")
    examples = []
    for index, entry in enumerate(entries, start=1):
        try:
            examples.append(
                Example(
                    objects=tuple(_strings(entry["objects"])),
                    relationships=tuple(_strings(entry["relationships"])),
                    instruction=str(entry["instruction"]).strip(),
                    goal=tuple(tuple(_strings(alternative)) for alternative in entry["goal"]),
                    plan=tuple(_strings(entry["plan"] if not goal_only else entry.get("plan", []))),
                )
            )
        except (KeyError, TypeError) as error:
            raise T2MError(
                f"{source}: example {index} is malformed ({error})",
                hint="each example needs objects, relationships, instruction, goal (list of lists) and plan",
            ) from None
    return tuple(examples)


def _strings(value: Any) -> list[str]:
    if not isinstance(value, list) or not all(isinstance(item, str) for item in value):
        raise TypeError(f"expected a list of strings, got {value!r}")
    return value


def examples_for_seed(seed: int, examples: Sequence[Example] | None = None) -> tuple[Example, ...]:
    """All examples, shuffled deterministically by ``seed`` (once per run)."""
    ordered = list(load_examples() if examples is None else examples)
    random.Random(seed).shuffle(ordered)
    return tuple(ordered)


def examples_by_relevance(instruction: str, seed: int, examples: Sequence[Example] | None = None) -> tuple[Example, ...]:
    """All examples, the most relevant to ``instruction`` last (next to the query); ties keep the
    seed's shuffled order. Deterministic for a given instruction and seed."""
    return tuple(most_relevant(instruction, examples_for_seed(seed, examples)))


# --------------------------------------------------------------------------------------------------
# Prompt parts
# --------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class HistoryStep:
    """One planned or executed skill in the current block.

    Attributes:
        action: the skill call text, ``"pick(hook)"``.
        relationships: relations after it (predicted while planning, observed when executed);
            ``None`` omits the ``New object relationships`` line (saycan-gs).
    """

    action: str
    relationships: tuple[str, ...] | None = None


def primitives(myopic: bool = False) -> list[str]:
    """``['pick(a)', 'place(a, b)', 'pull(a, hook)', 'push(a, hook, rack)']`` (+ ``'stop()'``)."""
    return [str(signature) for signature in SKILLS.values()] + ([str(STOP)] if myopic else [])


def _header(planning: bool, myopic: bool) -> list[str]:
    lines = [PRIMITIVES_LABEL + format_string_list(primitives(myopic))] if planning else []
    return lines + [PREDICATES_LABEL + format_string_list(PREDICATES)]


EXAMPLE_PLANS = ("steps", "sequence")
"""How the in-context examples of the step-wise prompts (next skill, scoring) write their plans:
``"steps"``, one ``Executed action: <skill>`` line per skill, as the current block does; or
``"sequence"``, one ``Top robot action sequence: [...]`` line, as in the reference
(docs/guide/deviations.md#examples-written-as-executed-steps). Shooting prompts always use the list."""


def _example_block(example: Example, planning: bool, myopic: bool, steps: bool = False) -> list[str]:
    lines = [
        f"Available scene objects: {format_string_list(example.objects)}",
        f"Object relationships: {format_string_list(example.relationships)}",
        f"Human instruction: {example.instruction}",
        GOAL_LABEL + "[" + ", ".join(format_string_list(alternative) for alternative in example.goal) + "]",
    ]
    if planning:
        plan = list(example.plan) + (["stop()"] if myopic else [])
        if steps:
            lines += [f"{EXECUTED_LABEL} {skill}" for skill in plan]
        else:
            lines.append(PLAN_LABEL + format_string_list(plan))
    return lines


def _history_lines(history: Sequence[HistoryStep]) -> list[str]:
    lines = []
    for step in history:
        lines.append(f"{EXECUTED_LABEL} {step.action}")
        if step.relationships is not None:
            lines.append(NEW_RELATIONSHIPS_LABEL + format_string_list(step.relationships))
    return lines


def _assemble(header: list[str], blocks: list[list[str]], current: list[str]) -> str:
    parts = ["\n".join(header)]
    parts += ["\n".join(block) for block in blocks]
    return "\n\n".join(parts) + "\n\n" + "\n".join(current)


class PromptBuilder:
    """Builds every prompt of one run with one example order.

    Args:
        seed: the run seed; fixes the example order.
        examples: the example set (default: the shipped one).
        goal_examples: the goal-only examples goal prompts also choose from (default: the
            shipped ones).
        k: candidates per query (K = 5).
        myopic: prompts of the saycan-gs / innermono-gs baselines (``stop()`` is a primitive and every
            example plan ends with it).
        order: ``"relevance"`` (default): the seed's shuffle, then the examples most relevant to the
            instruction moved next to the query (:func:`examples_by_relevance`); ``"shuffled"``: the
            seed's shuffle only, as in the reference. The order is a free choice; relevance
            order keeps a small model from copying the goal relation of an unrelated last example.
            With ``"relevance"`` goal prompts show the :data:`GOAL_EXAMPLES_SHOWN` most relevant
            of the examples and goal-only examples; with ``"shuffled"`` all examples, as in the reference.
        example_plans: how the next-skill and scoring prompts' examples write their plans, one of
            :data:`EXAMPLE_PLANS` (``"steps"`` by default; ``"sequence"`` as in the reference).
    """

    def __init__(
        self,
        seed: int = 0,
        examples: Sequence[Example] | None = None,
        k: int = K,
        myopic: bool = False,
        order: str = "relevance",
        goal_examples: Sequence[Example] | None = None,
        example_plans: str = "steps",
    ) -> None:
        if order not in ("relevance", "shuffled"):
            raise ValueError(f"example order must be 'relevance' or 'shuffled', got {order!r}")
        if example_plans not in EXAMPLE_PLANS:
            raise ValueError(f"example plans must be one of {', '.join(EXAMPLE_PLANS)}, got {example_plans!r}")
        self.example_plans = example_plans
        self.seed = seed
        self.example_set = tuple(load_examples() if examples is None else examples)
        self.goal_example_set = tuple(load_goal_examples() if goal_examples is None else goal_examples)
        self.k = k
        self.myopic = myopic
        self.order = order

    def examples_for(self, instruction: str) -> tuple[Example, ...]:
        """The examples in the order the prompts for ``instruction`` show them."""
        if self.order == "shuffled":
            return examples_for_seed(self.seed, self.example_set)
        return examples_by_relevance(instruction, self.seed, self.example_set)

    def goal_examples_for(self, instruction: str) -> tuple[Example, ...]:
        """The examples the goal prompt for ``instruction`` shows, in order."""
        if self.order == "shuffled":
            return examples_for_seed(self.seed, self.example_set)
        pool = examples_for_seed(self.seed, self.example_set + self.goal_example_set)
        return tuple(most_relevant(instruction, pool, GOAL_EXAMPLES_SHOWN))

    def goal(self, scene: SceneDescription) -> str:
        """Goal-prediction prompt, ending with the goal query line."""
        header = _header(planning=False, myopic=False)
        blocks = [_example_block(example, planning=False, myopic=False) for example in self.goal_examples_for(scene.instruction)]
        return _assemble(header, blocks, [*scene.lines(), GOAL_QUERY])

    def _planning_context(self, scene: SceneDescription, goal: Goal | str, history: Sequence[HistoryStep]) -> list[str]:
        return [*scene.lines(), PREDICTED_GOAL_LABEL + str(goal), *_history_lines(history)]

    def _planning(self, instruction: str, current: list[str], steps: bool = False) -> str:
        header = _header(planning=True, myopic=self.myopic)
        blocks = [_example_block(example, planning=True, myopic=self.myopic, steps=steps) for example in self.examples_for(instruction)]
        return _assemble(header, blocks, current)

    def shooting(self, scene: SceneDescription, goal: Goal | str, history: Sequence[HistoryStep] = ()) -> str:
        """Shooting prompt: K whole sequences, continuing ``history`` when it is not empty (the
        examples' plans are always lists here: they show the answer's form)."""
        return self._planning(scene.instruction, [*self._planning_context(scene, goal, history), shooting_query(self.k)])

    def next_skill(self, scene: SceneDescription, goal: Goal | str, history: Sequence[HistoryStep] = ()) -> str:
        """Next-skill prompt: K candidate next skills."""
        current = [*self._planning_context(scene, goal, history), next_skill_query(self.k)]
        return self._planning(scene.instruction, current, steps=self.example_plans == "steps")

    def scoring_context(self, scene: SceneDescription, goal: Goal | str, history: Sequence[HistoryStep] = ()) -> str:
        """The next-skill prompt without its query line, ending with a newline."""
        current = self._planning_context(scene, goal, history)
        return self._planning(scene.instruction, current, steps=self.example_plans == "steps") + "\n"


def scoring_request(context: str, candidates: Sequence[str]) -> tuple[str, list[str]]:
    """The prompt and continuations to pass to :meth:`LanguageModel.score`
    (docs/guide/prompts.md#scoring-prompt).

    The prompt ends with ``Executed action:``; each continuation is ``" " + candidate``, so the
    summed log-probability covers the leading space and every candidate token, with no terminator.
    """
    return context + EXECUTED_LABEL, [" " + candidate for candidate in candidates]
