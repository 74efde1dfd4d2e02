"""Symbolic validity of groundings and the effects of skill calls (docs/guide/skills.md#data-generation)."""

from __future__ import annotations

from t2m_core.domain.propositions import Proposition
from t2m_core.domain.skills import (
    SkillCall,
)
from t2m_core.domain.symbolic_effects import apply_effects, is_valid_grounding, precondition_problems


def facts(*texts: str) -> frozenset[Proposition]:
    return frozenset(Proposition.parse(t) for t in texts)


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
