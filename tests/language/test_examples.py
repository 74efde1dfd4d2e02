"""The shipped in-context examples are consistent, balanced and about other scenes than the tasks
(docs/guide/prompts.md#in-context-examples)."""

from __future__ import annotations

import pytest

from t2m_core.domain.goals import Goal, validate_goal
from t2m_core.domain.propositions import Proposition
from t2m_core.domain.skills import parse_skill_call
from t2m_core.domain.symbolic_effects import apply_effects, precondition_problems
from t2m_core.language.goal_cases import load_goal_cases, load_heldout_cases
from t2m_core.language.goal_checks import reachable_alternatives
from t2m_core.language.prompts import load_examples, load_goal_examples
from t2m_core.tasks import list_tasks

EXAMPLES = load_examples()
GOAL_EXAMPLES = load_goal_examples()


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


@pytest.mark.parametrize("example", GOAL_EXAMPLES, ids=lambda e: e.instruction[:40])
def test_goal_examples_are_reachable_or_say_no_goal(example):
    mentioned = {arg for text in example.relationships for arg in Proposition.parse(text).args}
    assert set(example.objects) <= mentioned and example.plan == ()
    if example.goal:
        goal = Goal.from_lists(example.goal)
        validate_goal(goal, example.objects)
        assert reachable_alternatives(goal, example.objects, example.relationships) == goal


def test_goal_examples_cover_every_goal_shape():
    goals = [e.goal for e in GOAL_EXAMPLES]
    assert any(not goal for goal in goals), "an example answers [] (no goal)"
    assert any(len(goal) > 1 for goal in goals), "an example enumerates a counted goal"
    assert any(any(p.startswith("inhand(") for alt in goal for p in alt) for goal in goals)
    assert any(any(p.endswith(", table)") for alt in goal for p in alt) for goal in goals)


def test_examples_never_reuse_a_task_or_evaluation_instruction_or_scene():
    asked = [(task.instruction, task.objects, {str(p) for p in task.initial_state if p.predicate in ("on", "under", "inhand")})
             for task in list_tasks()]
    asked += [(case.instruction, case.scene.objects, {str(p) for p in case.scene.initial_state if p.predicate in ("on", "under", "inhand")})
              for case in load_goal_cases() + load_heldout_cases()]
    for instruction, objects, relations in asked:
        for example in EXAMPLES + GOAL_EXAMPLES:
            assert example.instruction.strip().lower() != instruction.strip().lower()
            assert not (set(example.objects) == set(objects) and set(example.relationships) == relations)
