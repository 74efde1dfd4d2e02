"""Prompt layout (docs/guide/prompts.md#layout)."""

from __future__ import annotations

import ast

import pytest

from t2m_core.domain.goals import parse_goal
from t2m_core.language.prompts import (
    GOAL_QUERY,
    HistoryStep,
    PromptBuilder,
    examples_for_seed,
    load_examples,
    next_skill_query,
    primitives,
    scoring_request,
    shooting_query,
)
from t2m_core.language.scene_description import SceneDescription

SCENE = SceneDescription(
    objects=("table", "rack", "hook", "red_box", "blue_box"),
    relationships=("on(rack, table)", "on(hook, table)", "on(red_box, table)", "on(blue_box, table)"),
    instruction="Put the red box on the rack.",
)
GOAL = parse_goal("[['on(red_box, rack)']]")


def test_goal_prompt_layout():
    prompt = PromptBuilder(seed=0).goal(SCENE)
    blocks = prompt.split("\n\n")
    assert blocks[0] == "Available predicates: ['on(a, b)', 'inhand(a)', 'under(a, b)']"
    assert len(blocks) == 1 + 10 + 1  # header, all 10 examples, current block
    for block in blocks[1:-1]:
        lines = block.split("\n")
        assert [line.split(":")[0] for line in lines] == [
            "Available scene objects", "Object relationships", "Human instruction", "Goal predicate set"
        ]
    assert blocks[-1].split("\n") == [
        "Available scene objects: ['table', 'rack', 'hook', 'red_box', 'blue_box']",
        "Object relationships: ['on(rack, table)', 'on(hook, table)', 'on(red_box, table)', 'on(blue_box, table)']",
        "Human instruction: Put the red box on the rack.",
        GOAL_QUERY,
    ]
    assert GOAL_QUERY == "Predicted goal predicate set (python list of lists):"


def test_next_skill_prompt_with_history_matches_the_reference_example():
    history = [HistoryStep("pick(hook)", ("on(rack, table)", "on(red_box, table)", "on(blue_box, table)", "inhand(hook)"))]
    prompt = PromptBuilder(seed=0, example_plans="sequence").next_skill(SCENE, GOAL, history)
    header, *examples, current = prompt.split("\n\n")
    assert header.split("\n") == [
        "Available primitives: ['pick(a)', 'place(a, b)', 'pull(a, hook)', 'push(a, hook, rack)']",
        "Available predicates: ['on(a, b)', 'inhand(a)', 'under(a, b)']",
    ]
    assert len(examples) == 10
    assert all(example.split("\n")[-1].startswith("Top robot action sequence: ['") for example in examples)
    assert current.split("\n")[3:] == [
        "Predicted goal predicate set: [['on(red_box, rack)']]",
        "Executed action: pick(hook)",
        "New object relationships: ['on(rack, table)', 'on(red_box, table)', 'on(blue_box, table)', 'inhand(hook)']",
        next_skill_query(5),
    ]


def test_step_examples_write_each_plan_as_executed_actions_and_shooting_keeps_the_list():
    history = [HistoryStep("pick(hook)", ("on(rack, table)", "on(red_box, table)", "on(blue_box, table)", "inhand(hook)"))]
    builder = PromptBuilder(seed=0)
    assert builder.example_plans == "steps"
    stepwise = builder.next_skill(SCENE, GOAL, history)
    listed = PromptBuilder(seed=0, example_plans="sequence").next_skill(SCENE, GOAL, history)
    # the same examples, the same current block; only the plan lines differ
    assert stepwise.split("\n\n")[-1] == listed.split("\n\n")[-1]
    for step_block, list_block in zip(stepwise.split("\n\n")[1:-1], listed.split("\n\n")[1:-1], strict=True):
        step_lines, list_lines = step_block.split("\n"), list_block.split("\n")
        assert step_lines[:4] == list_lines[:4]
        plan = list_lines[4].removeprefix("Top robot action sequence: ")
        assert step_lines[4:] == [f"Executed action: {skill}" for skill in ast.literal_eval(plan)]
    assert "Top robot action sequence" not in stepwise
    assert builder.scoring_context(SCENE, GOAL, history) + next_skill_query(5) == stepwise
    # shooting asks for lists, so its examples show lists
    shooting = builder.shooting(SCENE, GOAL)
    assert shooting.count("Top robot action sequence: [") == 10 and "Executed action" not in shooting
    with pytest.raises(ValueError, match="example plans must be one of steps, sequence"):
        PromptBuilder(example_plans="bullets")


def test_shooting_prompt_and_k():
    prompt = PromptBuilder(seed=1, k=3).shooting(SCENE, GOAL)
    assert prompt.endswith("Predicted goal predicate set: [['on(red_box, rack)']]\n" + shooting_query(3))
    assert shooting_query(3) == "Top 3 robot action sequences (python list of lists):"


def test_scoring_context_is_the_next_skill_prompt_without_its_query_line():
    builder = PromptBuilder(seed=2)
    history = [HistoryStep("pick(red_box)", None)]  # saycan-gs style: no relationships line
    context = builder.scoring_context(SCENE, GOAL, history)
    assert builder.next_skill(SCENE, GOAL, history) == context + next_skill_query(5)
    assert context.endswith("Executed action: pick(red_box)\n")
    prompt, continuations = scoring_request(context, ["place(red_box, rack)"])
    assert prompt.endswith("\nExecuted action:")
    assert continuations == [" place(red_box, rack)"]


def test_myopic_prompts_list_stop_and_end_every_example_with_it():
    prompt = PromptBuilder(seed=0, myopic=True, example_plans="sequence").next_skill(SCENE, GOAL)
    assert "'stop()']" in prompt.split("\n")[0]
    plans = [line for line in prompt.split("\n") if line.startswith("Top robot action sequence:")]
    assert len(plans) == 10 and all(line.endswith("'stop()']") for line in plans)
    stepwise = PromptBuilder(seed=0, myopic=True).next_skill(SCENE, GOAL).split("\n\n")[1:-1]
    assert len(stepwise) == 10 and all(block.endswith("\nExecuted action: stop()") for block in stepwise)
    assert primitives(myopic=True)[-1] == "stop()"


def test_example_order_is_deterministic_per_seed():
    assert examples_for_seed(4) == examples_for_seed(4)
    assert examples_for_seed(4) != examples_for_seed(5)
    assert sorted(examples_for_seed(4), key=str) == sorted(load_examples(), key=str)


def test_relevance_order_puts_the_closest_example_next_to_the_query():
    from t2m_core.language.example_retrieval import relevance, word_weights
    from t2m_core.language.prompts import examples_by_relevance

    instruction = "Push the cyan box beneath the rack."
    ordered = examples_by_relevance(instruction, seed=0)
    assert sorted(ordered, key=str) == sorted(load_examples(), key=str)
    weights = word_weights(ordered)
    scores = [relevance(instruction, example, weights) for example in ordered]
    assert scores == sorted(scores) and scores[-1] > scores[0]
    assert any(proposition.startswith("under(") for proposition in ordered[-1].goal[0])
    # the builder shows that order; the reference's plain shuffle stays available
    builder = PromptBuilder(seed=0)
    assert builder.examples_for(instruction) == ordered


def test_goal_prompts_show_the_ten_closest_of_all_examples():
    builder = PromptBuilder(seed=0)
    shown = builder.goal_examples_for("Pick up the hook and keep holding it.")
    assert len(shown) == 10 and len(set(shown)) == 10
    assert shown[-1].goal[0][0].startswith("inhand(")  # a goal-only example about holding something
    prompt = builder.goal(SceneDescription(("table", "rack", "hook"), ("on(rack, table)", "on(hook, table)"), "Grab the hook."))
    assert prompt.count("Human instruction:") == 11 and "Top robot action sequence" not in prompt
    # colours name objects, not shapes: every colour reads as one word
    from t2m_core.language.example_retrieval import content_words

    assert content_words("Hold the red boxes") == content_words("holding the cyan box") == {"hold", "<colour>", "box"}
    assert PromptBuilder(seed=0, order="shuffled").goal_examples_for("x") == examples_for_seed(0)
    assert PromptBuilder(seed=0, order="shuffled").examples_for("anything") == examples_for_seed(0)
