"""The shipped in-context examples are consistent, balanced and about other scenes than the tasks
(docs/guide/prompts.md#in-context-examples)."""

from __future__ import annotations

import pytest

from t2m_core.domain.goals import Goal, validate_goal
from t2m_core.domain.propositions import Proposition
from t2m_core.domain.skills import parse_skill_call
from t2m_core.domain.symbolic_effects import apply_effects, precondition_problems
from t2m_core.language.prompts import load_examples
from t2m_core.tasks import list_tasks

EXAMPLES = load_examples()


def test_there_are_ten_with_the_documented_balance():
    assert len(EXAMPLES) == 10
    reach = [e for e in EXAMPLES if any(step.startswith("pull(") for step in e.plan)]
    push = [e for e in EXAMPLES if any(step.startswith("push(") for step in e.plan)]
    assert len(reach) == 5 and len(push) == 5
    in_hand = [e for e in EXAMPLES if any(r.startswith("inhand(") for r in e.relationships)]
    assert 2 <= len(in_hand) <= 3
    lifted = [e for e in EXAMPLES if len(e.goal) > 1]
    assert 1 <= len(lifted) <= 2
    assert all(5 <= len(e.objects) <= 7 and e.objects[:3] == ("table", "rack", "hook") for e in EXAMPLES)


@pytest.mark.parametrize("example", EXAMPLES, ids=lambda e: e.instruction[:40])
def test_plan_replays_symbolically_and_reaches_the_goal(example):
    goal = Goal.from_lists(example.goal)
    validate_goal(goal, example.objects)
    # every movable object appears in some relationship
    mentioned = {arg for text in example.relationships for arg in Proposition.parse(text).args}
    assert set(example.objects) <= mentioned
    facts = frozenset(Proposition.parse(text) for text in example.relationships)
    # push examples keep the rack beyond the workspace (the rule needs that zone fact)
    facts |= {Proposition("beyondworkspace", ("rack",))}
    for step in example.plan:
        call = parse_skill_call(step, example.objects)
        assert precondition_problems(call, facts) == [], f"{step} is not valid in {sorted(map(str, facts))}"
        facts = apply_effects(call, facts)
    assert goal.satisfied_by(facts), f"the plan ends in {sorted(map(str, facts))}, not in {goal}"


def test_examples_never_reuse_a_task_instruction_or_scene():
    for task in list_tasks():
        task_relations = {str(p) for p in task.initial_state if p.predicate in ("on", "under", "inhand")}
        for example in EXAMPLES:
            assert example.instruction.strip().lower() != task.instruction.strip().lower()
            assert not (set(example.objects) == set(task.objects) and set(example.relationships) == task_relations)
