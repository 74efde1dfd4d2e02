"""The symbolic states and groundings of skill-data generation (docs/guide/skills.md#data-generation)."""

from __future__ import annotations

import pytest

from t2m_core.domain.enumeration import candidate_groundings, enumerate_groundings, enumerate_symbolic_states
from t2m_core.domain.propositions import PREDICATE_ORDER
from t2m_core.domain.skills import SKILLS, SkillError


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
