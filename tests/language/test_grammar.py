"""GBNF grammars built from the scene."""

from __future__ import annotations

from t2m_core.language.grammar import call_subset_grammar, goal_grammar, skill_list_grammar, skill_sequences_grammar

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
    assert 'root ::= ws ("[]" | "[" alt ("," ws alt){0,2} "]")' in text  # C(3, 2) = 3 alternatives at most, or no goal
    assert 'alt ::= "[" counted ("," ws counted){1} ("," ws pin){0,1} "]"' in text
    assert 'box ::= ("red_box" | "blue_box" | "yellow_box")' in text
    assert 'destination ::= ("rack")' in text and '"under"' not in text


def test_skill_list_grammar_over_given_calls_writes_distinct_entries_in_order():
    text = skill_list_grammar(OBJECTS, 5, calls=["pick(hook)", "pick(red_box)"])
    assert 'root ::= ws "[" pick-0-2 "]"' in text  # no more entries than calls, and no fewer
    assert """pick-0-2 ::= q "pick(hook)" q "," ws pick-1-1""" in text
    assert '"place("' not in text


def test_call_subset_grammar_languages():
    """Expand the grammar's rules by hand: exactly the ordered 2-subsets of three calls."""
    import itertools
    import re

    text = call_subset_grammar(["a(x)", "b(y)", "c(z)"], k=2)
    rules = {}
    for line in text.splitlines():
        name, _, body = line.partition(" ::= ")
        rules[name] = [alternative.strip() for alternative in body.split(" | ")]

    def expand(symbol):
        results = []
        for alternative in rules[symbol]:
            parts = [""]
            for token in re.findall(r'"[^"]*"|[\w-]+', alternative):
                if token.startswith('"'):
                    options = [token[1:-1]]
                elif token in ("q",):
                    options = ["'"]
                elif token == "ws":
                    options = [" "]
                else:
                    options = expand(token)
                parts = [part + option for part in parts for option in options]
            results += parts
        return results

    answers = expand("pick-0-2")
    assert sorted(answers) == sorted(f"'{a}', '{b}'" for a, b in itertools.combinations(["a(x)", "b(y)", "c(z)"], 2))
    assert 'root ::= ws "[" pick-0-2 "]"' in text
