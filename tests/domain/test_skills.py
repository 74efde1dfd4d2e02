"""The symbolic side of the skills: signatures, parsing, validity, effects and the enumerations of
skill-data generation (docs/guide/world.md#skills-symbolic-side, docs/guide/skills.md#data-generation)."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from t2m_core.domain.predicates import PREDICATE_ORDER, Proposition
from t2m_core.domain.enumeration import candidate_groundings, enumerate_groundings, enumerate_symbolic_states
from t2m_core.domain.skills import (
    SKILLS,
    SkillCall,
    SkillError,
    apply_effects,
    check_argument_types,
    format_skill_sequence,
    is_valid_grounding,
    parse_skill_call,
    parse_skill_sequence,
    precondition_problems,
    validate_skill_call,
)

SCENE = ["table", "rack", "hook", "red_box", "blue_box"]


def facts(*texts: str) -> frozenset[Proposition]:
    return frozenset(Proposition.parse(t) for t in texts)


def test_signatures_as_the_prompts_show_them() -> None:
    assert [str(s) for s in SKILLS.values()] == ["pick(a)", "place(a, b)", "pull(a, hook)", "push(a, hook, rack)"]
    assert SKILLS["pick"].arity == 1  # one signature everywhere


def test_parse_skill_call_normalises() -> None:
    call = parse_skill_call("  Place( red_box,rack ) ", SCENE)
    assert call == SkillCall("place", ("red_box", "rack"))
    assert str(call) == "place(red_box, rack)"
    assert parse_skill_call(str(call)) == call
    assert parse_skill_call("stop()", allow_stop=True) == SkillCall("stop", ())


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("grasp(red_box)", "unknown skill 'grasp'"),
        ("pick(red_box, table)", "pick takes 1 argument"),
        ("place(red_box)", "place takes 2 argument"),
        ("pull(red_box, red_box)", "repeated argument"),
        ("pick(green_box)", "unknown object.*green_box.*scene objects: table, rack"),
        ("pick(red_box", "expected ',' or '\\)'"),
        ("stop()", "unknown skill 'stop'"),
        ("pick red_box", "expected '\\('"),
    ],
)
def test_invalid_skill_calls(text: str, message: str) -> None:
    with pytest.raises(SkillError, match=message):
        parse_skill_call(text, SCENE)


def test_syntax_check_leaves_semantics_to_the_q_values() -> None:
    # INST accepts pick(table): symbolic validity is not its job.
    call = parse_skill_call("pick(table)", SCENE)
    assert check_argument_types(call) == ["pick: table is not a movable object (box or hook)"]
    with pytest.raises(SkillError, match="table is not a movable object"):
        validate_skill_call(call, SCENE)
    validate_skill_call(call, SCENE, check_types=False)
    assert check_argument_types(SkillCall("push", ("hook", "red_box", "table"))) == [
        "push: hook is not a box",
        "push: red_box is not the tool (hook)",
        "push: table is not a receptacle (rack)",
    ]


def test_parse_skill_sequence() -> None:
    text = "```python\n[\"pick(hook)\", 'pull(red_box,hook)',\n 'place(hook, table)',]\n```"
    calls = parse_skill_sequence(text, SCENE)
    assert format_skill_sequence(calls) == "['pick(hook)', 'pull(red_box, hook)', 'place(hook, table)']"
    assert parse_skill_sequence(format_skill_sequence(calls)) == calls
    chatty = "Sure! ['pick(red_box)'] is best."
    assert parse_skill_sequence(chatty, SCENE, extract=True) == (SkillCall("pick", ("red_box",)),)
    assert parse_skill_sequence("['pick(red_box)', 'stop()']", SCENE, allow_stop=True)[-1].name == "stop"
    with pytest.raises(SkillError, match="entry 2: invalid skill call pick\\(rack, hook\\)"):
        parse_skill_sequence("['pick(hook)', 'pick(rack, hook)']", SCENE)
    with pytest.raises(SkillError, match="entry 1 is a list"):
        parse_skill_sequence("[['pick(hook)']]", SCENE)
    with pytest.raises(SkillError, match="cannot parse"):
        parse_skill_sequence("pick(hook), place(hook, table)", SCENE)


calls = st.builds(
    lambda name, objs: SkillCall(name, tuple(objs[: SKILLS[name].arity])),
    st.sampled_from(list(SKILLS)),
    st.permutations(SCENE),
)


@given(st.lists(calls, max_size=6))
def test_skill_sequences_round_trip(sequence: list[SkillCall]) -> None:
    assert parse_skill_sequence(format_skill_sequence(sequence), SCENE) == tuple(sequence)


# --------------------------------------------------------------------------------------------------
# Validity and effects
# --------------------------------------------------------------------------------------------------

ON_TABLE = facts("on(rack, table)", "on(hook, table)", "on(red_box, table)", "on(blue_box, rack)", "inworkspace(rack)")


def test_pick_validity() -> None:
    assert is_valid_grounding(SkillCall("pick", ("red_box",)), ON_TABLE)
    assert is_valid_grounding(SkillCall("pick", ("blue_box",)), ON_TABLE)
    holding = apply_effects(SkillCall("pick", ("hook",)), ON_TABLE)
    assert precondition_problems(SkillCall("pick", ("red_box",)), holding) == ["hook is already in hand"]
    assert not is_valid_grounding(SkillCall("pick", ("rack",)), ON_TABLE)
    stacked = ON_TABLE | facts("on(cyan_box, red_box)")
    problems = precondition_problems(SkillCall("pick", ("cyan_box",)), stacked)
    assert problems == ["cyan_box is not on the table or the rack"]


def test_place_validity() -> None:
    holding = apply_effects(SkillCall("pick", ("red_box",)), ON_TABLE)
    assert is_valid_grounding(SkillCall("place", ("red_box", "rack")), holding)
    assert is_valid_grounding(SkillCall("place", ("red_box", "table")), holding)
    assert not is_valid_grounding(SkillCall("place", ("red_box", "blue_box")), holding)  # onto a movable
    assert precondition_problems(SkillCall("place", ("blue_box", "table")), holding) == ["blue_box is not in hand"]
    assert not is_valid_grounding(SkillCall("place", ("red_box", "table")), ON_TABLE)  # nothing held


def test_pull_and_push_validity() -> None:
    with_hook = apply_effects(SkillCall("pick", ("hook",)), ON_TABLE)
    assert is_valid_grounding(SkillCall("pull", ("red_box", "hook")), with_hook)
    assert precondition_problems(SkillCall("pull", ("blue_box", "hook")), with_hook) == ["blue_box is not on the table"]
    assert precondition_problems(SkillCall("pull", ("red_box", "hook")), ON_TABLE) == ["hook is not in hand"]
    push = SkillCall("push", ("red_box", "hook", "rack"))
    assert precondition_problems(push, with_hook) == ["rack is not beyond the workspace"]
    beyond = with_hook - facts("inworkspace(rack)") | facts("beyondworkspace(rack)")
    assert is_valid_grounding(push, beyond)
    pushed = apply_effects(push, beyond)
    assert precondition_problems(push, pushed) == ["red_box is already under rack"]


def test_effects() -> None:
    picked = apply_effects(SkillCall("pick", ("red_box",)), ON_TABLE | facts("under(red_box, rack)"))
    assert Proposition.parse("inhand(red_box)") in picked
    assert not any(p.args[0] == "red_box" and p.predicate in ("on", "under") for p in picked)
    placed = apply_effects(SkillCall("place", ("red_box", "rack")), picked)
    assert placed == ON_TABLE - facts("on(red_box, table)") | facts("on(red_box, rack)")
    pulled = apply_effects(SkillCall("pull", ("red_box", "hook")), ON_TABLE)
    assert pulled == ON_TABLE  # symbolically unchanged: still on(red_box, table)
    pushed = apply_effects(SkillCall("push", ("red_box", "hook", "rack")), ON_TABLE)
    assert pushed == ON_TABLE | facts("under(red_box, rack)")


# --------------------------------------------------------------------------------------------------
# Enumerations
# --------------------------------------------------------------------------------------------------


def test_symbolic_state_enumeration() -> None:
    states = enumerate_symbolic_states()
    assert len(states) == 1296
    assert sum(s.rack_zone == "inworkspace" for s in states) == 648
    assert len({s.propositions for s in states}) == 1296
    for state in states[:: 37]:
        ranks = [PREDICATE_ORDER.index(p.predicate) for p in state.propositions]
        assert ranks == sorted(ranks)
        assert state.objects[:2] == ("table", "rack")
        assert sum(p.predicate == "inhand" for p in state.propositions) <= 1
        assert {"aligned(rack)", "poslimit(rack)", "on(rack, table)"} <= {str(p) for p in state.propositions}
        mentioned = {p.args[0] for p in state.propositions}
        assert set(state.objects[1:]) == mentioned
    assert states[0].objects == ("table", "rack")
    assert [str(p) for p in states[-1].propositions][-5:] == [
        "on(hook, rack)", "on(red_box, rack)", "on(blue_box, rack)", "on(yellow_box, rack)", "on(cyan_box, rack)"
    ]


def test_grounding_counts_match_the_original() -> None:
    states = enumerate_symbolic_states()
    counts = {}
    for skill in SKILLS:
        valid = invalid = 0
        for state in states:
            good, bad = enumerate_groundings(skill, state)
            valid, invalid = valid + len(good), invalid + len(bad)
            assert not set(good) & set(bad)
        counts[skill] = (valid, invalid)
    assert counts == {"pick": (1620, 5562), "place": (1620, 32292), "pull": (216, 33696), "push": (108, 21924)}


def test_candidate_groundings() -> None:
    objects = ("table", "rack", "hook", "red_box")
    assert len(candidate_groundings("pick", objects)) == 4
    assert len(candidate_groundings("place", objects)) == 12
    pushes = candidate_groundings("push", objects)
    assert len(pushes) == 6 and all(c.args[2] == "rack" for c in pushes)
    with pytest.raises(SkillError, match="unknown skill 'wipe'"):
        candidate_groundings("wipe", objects)
