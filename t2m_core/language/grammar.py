"""GBNF grammars (llama.cpp constrained decoding) for goals, skill lists and skill sequences, built
from the scene's objects, so a constrained model can only write well-formed answers that name
objects that exist.

Every answer may start with one space (the prompt's query line ends at its colon). Lists are bounded (at most ``max_alternatives`` goal alternatives, ``k`` skills, ``d_max`` skills per
sequence) so a constrained small model cannot loop until it runs out of tokens.

Goal propositions are restricted to 𝒫 (docs/guide/world.md#goals) by construction except for ``x = y`` pairs, which
:func:`~t2m_core.domain.goals.validate_goal` still rejects. Skill calls can optionally be typed
(``pick`` only movable objects, ``push`` only ``box, hook, rack``...); by default any scene object
fits any argument, as INST (docs/guide/planners.md#shared-steps) leaves semantic validity to the Q-functions.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence

from t2m_core.domain.objects import OBJECTS, ObjectKind
from t2m_core.domain.skills import SKILLS, STOP
from t2m_core.language.instruction_cues import GOAL_RELATIONS, CountCue

MAX_GOAL_ALTERNATIVES = 6
"""The most alternatives any task needs (task5: six pairs); more would not fit in 200 tokens."""
MAX_PROPOSITIONS_PER_ALTERNATIVE = 4


def _literal(text: str) -> str:
    return json.dumps(text)


def _alternation(options: Sequence[str]) -> str:
    return "(" + " | ".join(_literal(option) for option in options) + ")"


def _repeat(item: str, at_least: int, at_most: int) -> str:
    """``item ("," ws item){at_least-1, at_most-1}`` as GBNF."""
    return f'{item} ("," ws {item}){{{max(at_least - 1, 0)},{max(at_most - 1, 0)}}}'


_COMMON = 'ws ::= " "?\nq ::= "\'"\n'


def _holdable(objects: Sequence[str]) -> list[str]:
    """The scene's boxes and hook (all its objects when it has none)."""
    movable = [name for name in objects if name in OBJECTS and OBJECTS[name].kind in (ObjectKind.BOX, ObjectKind.HOOK)]
    return movable or list(objects)


def goal_grammar(
    objects: Sequence[str],
    max_alternatives: int = MAX_GOAL_ALTERNATIVES,
    max_propositions: int = MAX_PROPOSITIONS_PER_ALTERNATIVE,
    *,
    relations: Sequence[str] = GOAL_RELATIONS,
    count: CountCue | None = None,
) -> str:
    """Grammar of ``[['on(a, b)', ...], ...]`` over this scene's objects, or ``[]``: no goal
    expresses the instruction (docs/guide/language-models.md#no-valid-goal).

    Args:
        objects: the scene's objects.
        max_alternatives, max_propositions: list bounds (without ``count``).
        relations: the binary relations allowed (``("on",)`` when the instruction names only *on*;
            none: only ``inhand`` propositions, and ``count`` is not used).
        count: a counted box phrase: every alternative then holds exactly ``count.k`` propositions
            ``relation(box, destination)`` followed by at most one ``on(box, table)`` per other box,
            and there are at most C(boxes, k) alternatives.
    """
    relation = "(" + " | ".join(_literal(name) for name in relations) + ")"
    if not relations:
        return (
            f'root ::= ws ("[]" | "[" {_repeat("alt", 1, max_alternatives)} "]")\n'
            f'alt ::= "[" {_repeat("prop", 1, max_propositions)} "]"\n'
            'prop ::= q "inhand(" obj ")" q\n'
            f"obj ::= {_alternation(_holdable(objects))}\n" + _COMMON
        )
    if count is not None:
        others = len(count.boxes) - count.k
        more_counted = f'("," ws counted){{{count.k - 1}}} ' if count.k > 1 else ""
        pins = f'("," ws pin){{0,{others}}} ' if count.pins and others > 0 else ""
        return (
            f'root ::= ws ("[]" | "[" {_repeat("alt", 1, math.comb(len(count.boxes), count.k))} "]")\n'
            f'alt ::= "[" counted {more_counted}{pins}"]"\n'
            f'counted ::= q {relation} "(" box "," ws destination ")" q\n'
            'pin ::= q "on(" box ", table)" q\n'
            f"box ::= {_alternation(count.boxes)}\n"
            f"destination ::= {_alternation(count.destinations)}\n" + _COMMON
        )
    return (
        f'root ::= ws ("[]" | "[" {_repeat("alt", 1, max_alternatives)} "]")\n'
        f'alt ::= "[" {_repeat("prop", 1, max_propositions)} "]"\n'
        'prop ::= q (binary | inhand) q\n'
        f'binary ::= {relation} "(" obj "," ws obj ")"\n'
        'inhand ::= "inhand(" obj ")"\n'
        f"obj ::= {_alternation(objects)}\n" + _COMMON
    )


def _call_rules(objects: Sequence[str], typed: bool, allow_stop: bool) -> str:
    """Rules ``call`` (one skill call) and the object classes it needs."""
    rules, alternatives = [], []
    for signature in SKILLS.values():
        parts = []
        for index, parameter in enumerate(signature.parameters):
            allowed = [name for name in objects if not typed or (name in OBJECTS and OBJECTS[name].kind in parameter.kinds)]
            if not allowed:
                break
            rule = f"{signature.name}-arg{index}"
            rules.append(f"{rule} ::= {_alternation(allowed)}")
            parts.append(rule)
        else:
            alternatives.append(f'"{signature.name}(" ' + ' "," ws '.join(parts) + ' ")"')
    if allow_stop:
        alternatives.append(_literal(f"{STOP.name}()"))
    return "call ::= " + " | ".join(alternatives) + "\n" + "\n".join(rules) + "\n"


def skill_list_grammar(
    objects: Sequence[str],
    k: int = 5,
    *,
    typed: bool = False,
    allow_stop: bool = False,
    calls: Sequence[str] | None = None,
) -> str:
    """Grammar of ``['pick(a)', 'place(a, b)', ...]`` with 1..k calls over this scene's objects.

    With ``calls`` (e.g. the symbolically valid groundings of the described relationships), the answer
    is ``min(k, len(calls))`` distinct entries of ``calls``, in their given order
    (:func:`call_subset_grammar`).
    """
    if calls:
        return call_subset_grammar([*calls, *([f"{STOP.name}()"] if allow_stop else [])], k)
    rules = _call_rules(objects, typed, allow_stop)
    return f'root ::= ws "[" {_repeat("item", 1, k)} "]"\nitem ::= q call q\n' + rules + _COMMON


def call_subset_grammar(calls: Sequence[str], k: int = 5) -> str:
    """Grammar of a list of exactly ``min(k, len(calls))`` distinct entries of ``calls``, in order.

    Rule ``pick-I-J`` writes J entries chosen from ``calls[I:]``: entry I and J - 1 more after it, or
    J entries from ``calls[I + 1:]``; a small model asked for K candidates then cannot stop at one
    or repeat an entry.
    """
    if not calls:
        raise ValueError("a call-subset grammar needs at least one call")
    n, wanted = len(calls), min(k, len(calls))
    rules = [f'root ::= ws "[" pick-0-{wanted} "]"']
    for j in range(1, wanted + 1):
        for i in range(n - j + 1):
            take = f"q {_literal(calls[i])} q" + (f' "," ws pick-{i + 1}-{j - 1}' if j > 1 else "")
            skip = f" | pick-{i + 1}-{j}" if n - i - 1 >= j else ""
            rules.append(f"pick-{i}-{j} ::= {take}{skip}")
    return "\n".join(rules) + "\n" + _COMMON


def skill_sequences_grammar(objects: Sequence[str], k: int = 5, d_max: int = 10, *, typed: bool = False) -> str:
    """Grammar of ``[['pick(a)', ...], ...]``: 1..k sequences of 1..d_max calls."""
    return (
        f'root ::= ws "[" {_repeat("seq", 1, k)} "]"\n'
        f'seq ::= "[" {_repeat("item", 1, d_max)} "]"\n'
        "item ::= q call q\n" + _call_rules(objects, typed, False) + _COMMON
    )
