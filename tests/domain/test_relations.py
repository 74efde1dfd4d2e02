"""The relations a state shows the language model (docs/guide/world.md#relations-the-language-model-sees)."""

from __future__ import annotations

import itertools

import numpy as np
from hypothesis import given, settings

from t2m_core.domain.predicates import Scene, evaluate
from t2m_core.domain.propositions import (
    Proposition,
)
from t2m_core.domain.relations import relation_strings, situation, symbolic_state
from t2m_core.domain.state import ObjectPose
from tests.domain.scenes import RACK_BEYOND, RACK_IN_WORKSPACE, on_table, random_scenes, scene


def test_symbolic_state_order_follows_the_object_order() -> None:
    state = scene(
        rack=RACK_IN_WORKSPACE,
        hook=ObjectPose([0.5, 0.2, 0.40]),
        red_box=ObjectPose([0.44, -0.33, 0.16 + 0.059]),
        cyan_box=on_table("cyan_box", 0.45, -0.35),
        blue_box=on_table("blue_box", 0.6, 0.25),
    )
    assert relation_strings(state) == [
        "under(cyan_box, rack)",
        "on(rack, table)",
        "on(red_box, rack)",
        "on(cyan_box, table)",
        "on(blue_box, table)",
        "inhand(hook)",
    ]
    reordered = ["table", "blue_box", "cyan_box", "red_box", "hook", "rack"]
    assert relation_strings(state, reordered)[1:3] == ["on(blue_box, table)", "on(cyan_box, table)"]
    assert "inworkspace" not in " ".join(relation_strings(state))


@settings(max_examples=150, deadline=None)
@given(random_scenes())
def test_on_and_under_never_hold_together(state) -> None:
    relations = set(symbolic_state(state))
    for a, b in itertools.permutations(state.object_names, 2):
        assert not (Proposition("on", (a, b)) in relations and Proposition("under", (a, b)) in relations)


@settings(max_examples=100, deadline=None)
@given(random_scenes())
def test_symbolic_state_is_exactly_the_true_groundings(state) -> None:
    names = state.object_names
    view = Scene(state)
    candidates = [Proposition(name, pair) for name in ("under", "on") for pair in itertools.permutations(names, 2)]
    candidates += [Proposition("inhand", (n,)) for n in names]
    expected = [p for p in candidates if evaluate(p, view, full=False)]
    assert list(symbolic_state(state)) == expected
    assert all(p.args[0] != p.args[-1] or p.predicate == "inhand" for p in expected)
    assert not any(p.args[0] == "table" and p.predicate == "under" for p in expected)


def test_symbolic_state_skips_absent_names() -> None:
    state = scene(red_box=on_table("red_box", 0.5, 0.0))
    assert relation_strings(state, ["table", "rack", "red_box"]) == ["on(red_box, table)"]
    assert np.asarray(state.ee_position).shape == (3,)


def test_a_situation_tells_a_pulled_box_and_a_cleared_rack_front_apart_but_not_where_the_hook_lies() -> None:
    def at(box_xy, hook_xy=(0.45, 0.25)):
        return scene(rack=RACK_BEYOND, hook=on_table("hook", *hook_xy), blue_box=on_table("blue_box", *box_xy))

    far, near, beside = at((0.78, 0.25)), at((0.50, -0.25)), at((0.50, 0.0))  # rack spans y in about ±0.15 at x 0.82
    assert relation_strings(far) == relation_strings(near) == relation_strings(beside)  # the relations cannot tell
    assert "beyondworkspace(blue_box)" in situation(far) and "inworkspace(blue_box)" in situation(near)
    assert "infront(blue_box, rack)" in situation(beside) and "infront(blue_box, rack)" not in situation(near)
    assert len({situation(far), situation(near), situation(beside)}) == 3
    assert situation(at((0.50, -0.25), hook_xy=(0.55, 0.30))) == situation(near)  # the hook moved: same situation
    assert set(relation_strings(near)) - situation(near) == {"on(hook, table)"}
    below_the_rack = at((0.50, -0.25), hook_xy=(0.55, -0.25))  # the hook's head reaches under the rack
    assert "under(hook, rack)" in relation_strings(below_the_rack)
    assert situation(below_the_rack) == situation(near)  # its relations are where it lies, too
