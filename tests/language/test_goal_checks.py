"""When an instruction has no valid goal: objects missing from the scene, the model's [] answer,
goals no plan reaches."""

from __future__ import annotations

from t2m_core.domain.goals import parse_goal
from t2m_core.language.goal_checks import absent_object_reason, absent_objects, reachable_alternatives
from t2m_core.language.queries import query_goal
from t2m_core.protocols import LanguageModelCapabilities

OBJECTS = ("table", "rack", "hook", "red_box", "blue_box")
RELATIONS = ("on(rack, table)", "on(hook, table)", "on(red_box, table)", "on(blue_box, rack)")


def test_objects_named_but_missing_from_the_scene():
    assert absent_objects("Put the cyan box and the red box on the rack.", OBJECTS) == ("cyan_box",)
    assert absent_objects("Use the hook.", ("table", "rack", "red_box")) == ("hook",)
    assert absent_objects("Put the red one on the rack.", OBJECTS) == ()
    reason = absent_object_reason("Hand me the yellow box", OBJECTS)
    assert reason.kind == "absent" and "the yellow box" in reason.reason and "red_box" in reason.reason


def test_unreachable_alternatives_are_dropped_and_none_left_means_no_goal():
    def reach(text):
        return reachable_alternatives(parse_goal(text), OBJECTS, RELATIONS)

    assert reach("[['on(red_box, blue_box)']]") is None  # boxes rest on the table or the rack only
    assert reach("[['on(rack, red_box)']]") is None  # the rack stays put
    assert reach("[['inhand(red_box)', 'inhand(blue_box)']]") is None  # one gripper
    assert reach("[['under(hook, rack)']]") is None  # only boxes go under the rack
    kept = reach("[['on(red_box, blue_box)'], ['under(red_box, rack)'], ['on(blue_box, rack)']]")
    assert str(kept) == "[['under(red_box, rack)'], ['on(blue_box, rack)']]"  # already true counts too


class Answering:
    capabilities = LanguageModelCapabilities(exact_scoring=True, grammar=True)

    def __init__(self, answer):
        self.answer, self.prompts, self.grammars = answer, [], []

    def complete(self, prompt, *, grammar=None, **_):
        self.prompts.append(prompt)
        self.grammars.append(grammar)
        return [self.answer]


def test_goal_queries_end_in_no_valid_goal_with_a_reason():
    absent = Answering("[['on(red_box, rack)']]")
    query = query_goal(absent, "ctx\nQ:", OBJECTS, instruction="Put the yellow box on the rack.", relationships=RELATIONS)
    assert query.goal is None and query.no_goal.kind == "absent" and absent.prompts == []  # refused before asking

    empty = Answering(" []")  # an instruction no check reads as refused: the model's [] decides
    query = query_goal(empty, "ctx\nQ:", OBJECTS, instruction="Make the rack look tidy.", relationships=RELATIONS)
    assert query.goal is None and query.no_goal.kind == "none_expresses" and query.attempts[0].problem is None
    assert '"[]"' in empty.grammars[0]

    stacked = Answering("[['on(red_box, blue_box)']]")
    query = query_goal(stacked, "ctx\nQ:", OBJECTS, instruction="Stack the red box on the blue box.", relationships=RELATIONS)
    assert query.goal is None and query.no_goal.kind == "unreachable" and "on(red_box, blue_box)" in query.no_goal.reason

    fine = Answering("[['on(red_box, rack)']]")
    query = query_goal(fine, "ctx\nQ:", OBJECTS, instruction="Put the red box on the rack.", relationships=RELATIONS)
    assert str(query.goal) == "[['on(red_box, rack)']]" and query.no_goal is None


def test_alternatives_about_named_objects_are_preferred():
    from t2m_core.language.goal_checks import prefer_named_objects

    def prefer(goal, instruction):
        return str(prefer_named_objects(parse_goal(goal), instruction, OBJECTS))

    listed = "[['on(blue_box, rack)'], ['on(red_box, rack)']]"
    assert prefer(listed, "Set the blue box on the rack.") == "[['on(blue_box, rack)']]"
    assert prefer(listed, "Put one box on the rack.") == listed  # names no box: a lifted goal
    only = "[['on(blue_box, rack)', 'on(red_box, table)']]"
    assert prefer(only, "Make the blue box the only one on the rack.") == only  # every alternative involves others


def test_a_goal_that_already_holds_is_asked_again_and_kept_if_repeated():
    class Script(Answering):
        def __init__(self, answers):
            super().__init__(None)
            self.answers = list(answers)

        def complete(self, prompt, *, grammar=None, **_):
            self.prompts.append(prompt)
            return [self.answers.pop(0)]

    fixed = Script(["[['on(blue_box, rack)']]", "[['inhand(blue_box)']]"])
    query = query_goal(fixed, "ctx\nQ:", OBJECTS, instruction="Hold the blue box.", relationships=RELATIONS)
    assert str(query.goal) == "[['inhand(blue_box)']]" and "already holds" in query.attempts[0].problem
    assert "already holds" in fixed.prompts[1]
    stubborn = Script(["[['on(blue_box, rack)']]"] * 3)
    query = query_goal(stubborn, "ctx\nQ:", OBJECTS, instruction="Keep the blue box on the rack.", relationships=RELATIONS)
    assert str(query.goal) == "[['on(blue_box, rack)']]" and len(query.attempts) == 3


def test_instructions_outside_the_world_and_goals_listed_as_parts():
    from t2m_core.language.goal_checks import merge_mixed_alternatives, unrelated_reason

    assert unrelated_reason("Sing me a song.").kind == "unrelated"
    assert unrelated_reason("Grab the hook.") is None and unrelated_reason("Put the boxes away") is None
    # alternatives of different shapes are the parts of one goal; same-shaped ones stay a lifted goal
    parts = parse_goal("[['on(red_box, rack)'], ['inhand(hook)']]")
    assert str(merge_mixed_alternatives(parts, OBJECTS, RELATIONS)) == "[['on(red_box, rack)', 'inhand(hook)']]"
    same = parse_goal("[['on(red_box, rack)'], ['on(hook, rack)']]")
    assert merge_mixed_alternatives(same, OBJECTS, RELATIONS) == same
    clash = parse_goal("[['on(hook, table)'], ['inhand(hook)']]")  # merged, it cannot be reached
    assert merge_mixed_alternatives(clash, OBJECTS, RELATIONS) == clash
