"""Skill signatures, calls and their parsing (docs/guide/world.md#skills-symbolic-side)."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from t2m_core.domain.skills import (
    SKILLS,
    SkillCall,
    SkillError,
    check_argument_types,
    format_skill_sequence,
    parse_skill_call,
    parse_skeleton,
    parse_skill_sequence,
    validate_skill_call,
)

SCENE = ["table", "rack", "hook", "red_box", "blue_box"]


def test_signatures_as_the_prompts_show_them() -> None:
    assert [str(s) for s in SKILLS.values()] == ["pick(a)", "place(a, b)", "pull(a, hook)", "push(a, hook, rack)"]
    assert SKILLS["pick"].arity == 1  # one signature everywhere


def test_parse_skill_call_normalises() -> None:
    call = parse_skill_call("  Place( red_box,rack ) ", SCENE)
    assert call == SkillCall("place", ("red_box", "rack"))
    assert str(call) == "place(red_box, rack)"
    assert parse_skill_call(str(call)) == call
    assert parse_skill_call("stop()", allow_stop=True) == SkillCall("stop", ())


def test_a_lifted_call_names_the_object_kinds() -> None:
    assert SkillCall("place", ("red_box", "rack")).lifted == "place(box, rack)"
    assert SkillCall("place", ("hook", "table")).lifted == "place(hook, table)"
    assert SkillCall("push", ("cyan_box", "hook", "rack")).lifted == "push(box, hook, rack)"
    with pytest.raises(KeyError, match="unknown object 'shelf'"):
        _ = SkillCall("place", ("red_box", "shelf")).lifted


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





def test_parse_skeleton_splits_at_commas_outside_parentheses() -> None:
    calls = parse_skeleton(" pick(hook),pull( blue_box, hook ) , place(hook, table),", SCENE)
    assert calls == (SkillCall("pick", ("hook",)), SkillCall("pull", ("blue_box", "hook")), SkillCall("place", ("hook", "table")))
    with pytest.raises(SkillError, match="empty skeleton"):
        parse_skeleton(" , ")
    with pytest.raises(SkillError, match="entry 2"):
        parse_skeleton("pick(hook), pull(green_box, hook)", SCENE)
