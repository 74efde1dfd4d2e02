"""Asking a model with a bounded re-query (docs/guide/prompts.md#parsing-and-validation)."""

from __future__ import annotations

from t2m_core.domain.skills import SkillCall
from t2m_core.language.queries import query_goal, query_next_skills, query_skill_sequences, with_error_note
from t2m_core.protocols import LanguageModelCapabilities

OBJECTS = ("table", "rack", "hook", "red_box", "blue_box")


class ScriptedModel:
    """Test double answering with a fixed script, recording prompts and grammars."""

    def __init__(self, answers, grammar=False):
        self.answers = list(answers)
        self.prompts = []
        self.grammars = []
        self.capabilities = LanguageModelCapabilities(exact_scoring=True, grammar=grammar)

    def complete(self, prompt, *, max_tokens=256, stop=(), temperature=0.0, n=1, grammar=None):
        self.prompts.append(prompt)
        self.grammars.append(grammar)
        return [self.answers.pop(0)] * n

    def score(self, prompt, candidates):
        return [0.0] * len(candidates)


def test_error_note_goes_before_the_query_line():
    prompt = "context\nPredicted goal predicate set (python list of lists):"
    noted = with_error_note(prompt, "[['on(x, y)']]", "unknown object x")
    lines = noted.split("\n")
    assert lines[0] == "context" and lines[-1] == "Predicted goal predicate set (python list of lists):"
    assert "unknown object x" in lines[1] and "[['on(x, y)']]" in lines[1]


def test_goal_query_retries_at_most_twice_with_a_note():
    model = ScriptedModel(["[['on(x, rack)']]", "garbage", "[['on(red_box, rack)']]"], grammar=True)
    query = query_goal(model, "ctx\nQ:", OBJECTS)
    assert str(query.goal) == "[['on(red_box, rack)']]"
    assert [attempt.problem is None for attempt in query.attempts] == [False, False, True]
    assert model.prompts[0] == "ctx\nQ:" and "Note:" in model.prompts[1] and "Note:" in model.prompts[2]
    assert all(grammar and "red_box" in grammar for grammar in model.grammars)

    failing = ScriptedModel(["nope"] * 5)
    query = query_goal(failing, "ctx\nQ:", OBJECTS)
    assert query.goal is None and len(query.attempts) == 3 and len(failing.answers) == 2
    assert failing.grammars == [None, None, None]  # no grammar without the capability


def test_unconstrained_query_sends_no_grammar_and_next_skill_requery():
    model = ScriptedModel(["['fly(hook)']", "['pick(hook)', 'place(red_box, rack)']"], grammar=True)
    candidates, attempts = query_next_skills(model, "ctx\nQ:", OBJECTS, constrained=False)
    assert [str(c) for c in candidates.calls] == ["pick(hook)", "place(red_box, rack)"]
    assert len(attempts) == 2 and model.grammars == [None, None]
    sequences, attempts = query_skill_sequences(ScriptedModel(["[['pick(hook)']]"]), "ctx\nQ:", OBJECTS)
    assert sequences == [(SkillCall("pick", ("hook",)),)] and attempts[0].problem is None


def test_goal_query_with_the_instruction_constrains_and_completes_a_counted_goal():
    model = ScriptedModel(["[['on(red_box, rack)']]"], grammar=True)
    query = query_goal(model, "ctx\nQ:", OBJECTS, instruction="Put one box onto the rack.")
    assert query.goal.to_lists() == [["on(red_box, rack)"], ["on(blue_box, rack)"]]
    assert "counted" in model.grammars[0] and '"under"' not in model.grammars[0]
    plain = ScriptedModel(["[['on(red_box, rack)']]"], grammar=True)
    assert query_goal(plain, "ctx\nQ:", OBJECTS).goal.to_lists() == [["on(red_box, rack)"]]
    assert '"under"' in plain.grammars[0]


def test_next_skill_query_over_given_calls_sends_their_grammar():
    calls = ["pick(hook)", "pick(red_box)", "pick(blue_box)"]
    model = ScriptedModel(["['pick(hook)', 'pick(blue_box)']"], grammar=True)
    candidates, _ = query_next_skills(model, "ctx\nQ:", OBJECTS, 2, calls=calls)
    assert [str(c) for c in candidates.calls] == ["pick(hook)", "pick(blue_box)"]
    assert 'pick-0-2 ::= q "pick(hook)" q' in model.grammars[0]


def test_next_skill_query_over_at_most_k_calls_needs_no_model():
    # the grammar admits one answer: every call in order; the model is not asked
    model = ScriptedModel([], grammar=True)
    candidates, attempts = query_next_skills(model, "ctx\nQ:", OBJECTS, calls=["pick(hook)", "pick(red_box)"])
    assert [str(c) for c in candidates.calls] == ["pick(hook)", "pick(red_box)"]
    assert model.prompts == [] and [a.problem for a in attempts] == [None]
    stopping, _ = query_next_skills(model, "ctx\nQ:", OBJECTS, calls=["pick(hook)"], allow_stop=True)
    assert [str(c) for c in stopping.calls] == ["pick(hook)", "stop()"]
    unconstrained = ScriptedModel(["['pick(hook)']"], grammar=False)
    query_next_skills(unconstrained, "ctx\nQ:", OBJECTS, calls=["pick(hook)"])
    assert len(unconstrained.prompts) == 1
