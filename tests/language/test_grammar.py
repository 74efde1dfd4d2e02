"""GBNF grammars built from the scene."""

from __future__ import annotations

from t2m_core.language.grammar import goal_grammar, skill_list_grammar, skill_sequences_grammar

OBJECTS = ("table", "rack", "hook", "red_box")


def test_goal_grammar_names_only_scene_objects_and_goal_predicates():
    text = goal_grammar(OBJECTS)
    assert 'obj ::= ("table" | "rack" | "hook" | "red_box")' in text
    assert '("on" | "under")' in text and '"inhand("' in text
    assert "{0,5}" in text  # at most 6 alternatives


def test_typed_skill_grammar_restricts_argument_kinds():
    typed = skill_list_grammar(OBJECTS, 5, typed=True)
    assert 'pick-arg0 ::= ("hook" | "red_box")' in typed
    assert 'push-arg2 ::= ("rack")' in typed
    untyped = skill_list_grammar(OBJECTS, 5)
    assert 'pick-arg0 ::= ("table" | "rack" | "hook" | "red_box")' in untyped
    assert '"stop()"' in skill_list_grammar(OBJECTS, 5, allow_stop=True)
    # a scene without a hook cannot ground pull or push when typed
    no_hook = skill_list_grammar(("table", "rack", "red_box"), 5, typed=True)
    assert '"pull("' not in no_hook and '"push("' not in no_hook


def test_sequence_grammar_bounds_sequences_and_length():
    text = skill_sequences_grammar(OBJECTS, k=5, d_max=10)
    assert 'root ::= ws "[" seq ("," ws seq){0,4} "]"' in text
    assert 'seq ::= "[" item ("," ws item){0,9} "]"' in text


def test_goal_grammar_keeps_the_named_relations_only():
    text = goal_grammar(OBJECTS, relations=("on",))
    assert 'binary ::= ("on") "("' in text and "under" not in text


def test_counted_goal_grammar_fixes_boxes_per_alternative():
    from t2m_core.language.instruction_cues import count_cue

    objects = ("table", "rack", "hook", "red_box", "blue_box", "yellow_box")
    text = goal_grammar(objects, relations=("on",), count=count_cue("Put two boxes on the rack.", objects))
    assert 'root ::= ws "[" alt ("," ws alt){0,2} "]"' in text  # C(3, 2) = 3 alternatives at most
    assert 'alt ::= "[" counted ("," ws counted){1} ("," ws pin){0,1} "]"' in text
    assert 'box ::= ("red_box" | "blue_box" | "yellow_box")' in text
    assert 'destination ::= ("rack")' in text and '"under"' not in text


def test_skill_list_grammar_over_given_calls():
    text = skill_list_grammar(OBJECTS, 5, calls=["pick(hook)", "pick(red_box)"])
    assert 'call ::= ("pick(hook)" | "pick(red_box)")' in text
    assert 'root ::= ws "[" item ("," ws item){0,1} "]"' in text  # no more entries than calls
    assert '"place("' not in text
