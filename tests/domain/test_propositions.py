"""The proposition type, its parser, canonical order and validation (docs/guide/world.md#predicates)."""

from __future__ import annotations

import pytest

from t2m_core.domain.literals import LiteralSyntaxError
from t2m_core.domain.propositions import (
    GOAL_PREDICATES,
    PREDICATE_ORDER,
    Proposition,
    PropositionError,
    canonical_order,
    validate_proposition,
)


def test_proposition_spelling_and_parsing() -> None:
    prop = Proposition.parse("  on( red_box ,rack ) ")
    assert prop == Proposition("on", ("red_box", "rack"))
    assert str(prop) == "on(red_box, rack)"
    assert Proposition.parse(str(prop)) == prop
    assert str(Proposition("inhand", ["hook"])) == "inhand(hook)"
    assert hash(prop) == hash(Proposition("on", ("red_box", "rack")))


@pytest.mark.parametrize(
    ("text", "position"),
    [("on(red_box rack)", 11), ("on red_box, rack)", 3), ("on(red_box, rack", 16), ("on(red-box, rack)", 6),
     ("on(red_box, rack) x", 18), ("(a)", 0), ("on(a,)", 5)],
)
def test_malformed_propositions_point_at_the_problem(text: str, position: int) -> None:
    with pytest.raises(LiteralSyntaxError) as caught:
        Proposition.parse(text)
    assert caught.value.position == position
    assert f"position {position}" in str(caught.value)
    assert text in str(caught.value)


def test_canonical_order_is_stable_within_a_predicate() -> None:
    props = ["on(rack, table)", "inhand(hook)", "free(cyan_box)", "on(red_box, table)", "free(blue_box)",
             "beyondworkspace(rack)", "inworkspace(hook)", "nonblocking(a, b)", "infront(c, rack)", "aligned(rack)"]
    ordered = [str(p) for p in canonical_order(props)]
    assert ordered == ["free(cyan_box)", "free(blue_box)", "aligned(rack)", "inworkspace(hook)",
                       "beyondworkspace(rack)", "infront(c, rack)", "nonblocking(a, b)", "on(rack, table)",
                       "on(red_box, table)", "inhand(hook)"]
    assert PREDICATE_ORDER.index("on") < PREDICATE_ORDER.index("inhand")  # on is sampled before inhand
    assert len(PREDICATE_ORDER) == 17


def test_validate_proposition_names_the_problem() -> None:
    objects = ["table", "rack", "red_box"]
    validate_proposition(Proposition.parse("on(red_box, rack)"), objects)
    with pytest.raises(PropositionError, match="unknown object 'shelf'") as caught:
        validate_proposition(Proposition.parse("on(red_box, shelf)"), objects)
    assert "table, rack, red_box" in str(caught.value)
    with pytest.raises(PropositionError, match="unknown predicate 'atop'"):
        validate_proposition(Proposition.parse("atop(red_box, rack)"), objects)
    with pytest.raises(PropositionError, match="takes 1"):
        validate_proposition(Proposition.parse("inhand(red_box, rack)"), objects)
    with pytest.raises(PropositionError, match="unknown predicate 'free'"):
        validate_proposition(Proposition.parse("free(red_box)"), objects, GOAL_PREDICATES)
