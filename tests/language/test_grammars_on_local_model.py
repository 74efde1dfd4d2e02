"""The counted goal grammar and the call-subset grammar compile in llama.cpp and constrain the
embedded model's answers (loads the real model: marked ``llm`` and ``slow``)."""

from __future__ import annotations

import pytest

from t2m_core.language.grammar import call_subset_grammar, goal_grammar
from t2m_core.language.instruction_cues import count_cue
from t2m_core.language.parsing import parse_goal_answer, parse_skill_candidates

OBJECTS = ("table", "rack", "hook", "red_box", "blue_box", "yellow_box")
SCENE = (
    "Available predicates: ['on(a, b)', 'inhand(a)', 'under(a, b)']\n"
    f"Available scene objects: {list(OBJECTS)}\n"
    "Object relationships: ['on(rack, table)', 'on(hook, table)', 'on(red_box, table)', 'on(blue_box, table)', "
    "'on(yellow_box, table)']\n"
)


@pytest.fixture(scope="module")
def local_model():
    from t2m_llm_local.hooks import LocalModelOptions
    from t2m_llm_local.llama import LocalLanguageModel

    return LocalLanguageModel(LocalModelOptions(model="qwen2.5-coder-0.5b", n_ctx=4096))  # mechanics, not quality: the fast model


@pytest.mark.llm
@pytest.mark.slow
def test_counted_goal_grammar_gives_k_boxes_per_alternative(local_model):
    instruction = "Could you put two boxes onto the rack?"
    cue = count_cue(instruction, OBJECTS)
    prompt = SCENE + f"Human instruction: {instruction}\nPredicted goal predicate set (python list of lists):"
    grammar = goal_grammar(OBJECTS, relations=("on",), count=cue)
    answer = local_model.complete(prompt, max_tokens=120, stop=["\n"], grammar=grammar)[0]
    goal = parse_goal_answer(answer, OBJECTS)
    for alternative in goal:
        moved = [p for p in alternative if p.args[1] == "rack"]
        assert len(moved) == 2 and all(p.predicate == "on" for p in moved)
        assert all(str(p) == f"on({p.args[0]}, table)" for p in alternative if p not in moved)


@pytest.mark.llm
@pytest.mark.slow
def test_call_subset_grammar_gives_k_distinct_given_calls(local_model):
    calls = ["pick(hook)", "pick(red_box)", "pick(blue_box)", "pick(yellow_box)", "place(hook, rack)", "pull(red_box, hook)"]
    prompt = SCENE + "Human instruction: Put the red box on the rack.\nTop 5 valid next robot actions (single python list of primitives):"
    answer = local_model.complete(prompt, max_tokens=80, stop=["\n"], grammar=call_subset_grammar(calls, 5))[0]
    candidates = parse_skill_candidates(answer, OBJECTS)
    written = [str(call) for call in candidates.calls]
    assert len(written) == 5 and not candidates.rejected
    assert written == [call for call in calls if call in written]  # distinct, in the given order
