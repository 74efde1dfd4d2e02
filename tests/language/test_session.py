"""Language session helpers: symbolic history, valid groundings, executed-skill parsing, scoring."""

from __future__ import annotations

import math

import pytest

from t2m_core.domain.goals import parse_goal
from t2m_core.domain.skills import SkillCall, SkillError
from t2m_core.language.scene_description import SceneDescription, describe_task_scene
from t2m_core.language.session import LanguageSession, parse_executed, symbolic_relationships, valid_groundings
from t2m_core.protocols import LanguageModelCapabilities
from t2m_core.tasks import load_task

OBJECTS = ("table", "rack", "hook", "red_box", "blue_box")
RELATIONS = ("on(rack, table)", "on(hook, table)", "on(red_box, table)", "on(blue_box, table)")


def test_symbolic_relationships_follow_skill_effects_in_canonical_order():
    calls = [SkillCall("pick", ("hook",)), SkillCall("pull", ("red_box", "hook")), SkillCall("place", ("hook", "rack"))]
    after = symbolic_relationships(OBJECTS, RELATIONS, calls)
    assert after[0] == ("on(rack, table)", "on(red_box, table)", "on(blue_box, table)", "inhand(hook)")
    assert after[1] == after[0]
    assert after[2] == ("on(rack, table)", "on(hook, rack)", "on(red_box, table)", "on(blue_box, table)")


def test_valid_groundings_use_only_described_relationships():
    initial = {str(call) for call in valid_groundings(OBJECTS, RELATIONS)}
    assert initial == {"pick(hook)", "pick(red_box)", "pick(blue_box)"}
    holding_hook = ("on(rack, table)", "on(red_box, table)", "on(blue_box, table)", "inhand(hook)")
    calls = {str(call) for call in valid_groundings(OBJECTS, holding_hook)}
    assert calls == {
        "place(hook, table)", "place(hook, rack)", "pull(red_box, hook)", "pull(blue_box, hook)",
        "push(red_box, hook, rack)", "push(blue_box, hook, rack)",
    }


def test_parse_executed_accepts_both_spellings_and_rejects_bad_skills():
    expected = [SkillCall("pick", ("hook",)), SkillCall("place", ("hook", "rack"))]
    assert parse_executed("pick(hook),place(hook, rack)", OBJECTS) == expected
    assert parse_executed("['pick(hook)', 'place(hook,rack)']", OBJECTS) == expected
    assert parse_executed("  ", OBJECTS) == []
    with pytest.raises(SkillError, match="green_box"):
        parse_executed("pick(green_box)", OBJECTS)


def test_describe_task_scene_lists_the_sampled_relationships():
    task = load_task("task1")
    scene, state = describe_task_scene(task, 0)
    assert scene.objects == task.objects and scene.instruction == task.instruction
    assert set(scene.relationships) == {str(p) for p in task.initial_state if p.predicate == "on"}
    assert not any("workspace" in relation for relation in scene.relationships)


class LengthScorer:
    """Test double whose log-likelihood is minus the candidate length; records the scoring prompts."""

    capabilities = LanguageModelCapabilities(exact_scoring=True)

    def __init__(self):
        self.prompts = []

    def complete(self, prompt, **_):
        return ["['pick(hook)']"]

    def score(self, prompt, candidates):
        self.prompts.append(prompt)
        return [-float(len(candidate)) for candidate in candidates]


def test_session_scores_with_the_dampened_softmax():
    model = LengthScorer()
    scene = SceneDescription(OBJECTS, RELATIONS, "Put the red box on the rack.")
    session = LanguageSession(model, scene, seed=0)
    calls = [SkillCall("pick", ("hook",)), SkillCall("pick", ("red_box",))]
    scored = session.score(parse_goal("[['on(red_box, rack)']]"), [SkillCall("pick", ("hook",))], calls)
    assert scored.logprobs == [-11.0, -14.0]  # " pick(hook)", " pick(red_box)"
    assert scored.usefulness[0] == pytest.approx(1 / (1 + math.exp(-0.9)))
    assert scored.ranked()[0][0] == calls[0]
    assert model.prompts[0].endswith("Executed action: pick(hook)\nNew object relationships: "
                                     "['on(rack, table)', 'on(red_box, table)', 'on(blue_box, table)', 'inhand(hook)']\n"
                                     "Executed action:")


class GrammarRecorder(LengthScorer):
    """Test double that accepts grammars and records them."""

    capabilities = LanguageModelCapabilities(exact_scoring=True, grammar=True)

    def __init__(self):
        super().__init__()
        self.grammars = []

    def complete(self, prompt, *, grammar=None, **_):
        self.grammars.append(grammar)
        return ["['pick(hook)']"]


@pytest.mark.parametrize("grounded", [True, False])
def test_grounded_sessions_offer_only_valid_groundings_to_the_next_skill_grammar(grounded):
    model = GrammarRecorder()
    scene = SceneDescription(OBJECTS, RELATIONS, "Put the red box on the rack.")
    session = LanguageSession(model, scene, seed=0, grounded=grounded, k=2)
    calls, _ = session.generate_next(parse_goal("[['on(red_box, rack)']]"), [])
    assert calls == [SkillCall("pick", ("hook",))]
    if grounded:
        grammar = model.grammars[0]
        assert 'root ::= ws "[" pick-0-2 "]"' in grammar  # two of the three valid picks, nothing else
        assert all(f'"pick({name})"' in grammar for name in ("hook", "red_box", "blue_box")) and '"place(' not in grammar
        # with K = 5 the three valid picks are the only answer the grammar admits: no model call
        forced = LanguageSession(model, scene, seed=0)
        calls, _ = forced.generate_next(parse_goal("[['on(red_box, rack)']]"), [])
        assert [str(call) for call in calls] == ["pick(hook)", "pick(red_box)", "pick(blue_box)"]
        assert len(model.grammars) == 1
    else:
        assert '"place("' in model.grammars[0] and "pick-arg0" in model.grammars[0]
