"""The relations the language layer sees in a geometric state: every true ``under``, ``on`` and
``inhand`` over the scene's objects, by the geometry-only tests
(docs/guide/world.md#relations-the-language-model-sees). The same extraction serves real
observations and predicted states.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence

from t2m_core.domain import geometry
from t2m_core.domain.geometry import is_inhand, is_on, is_under
from t2m_core.domain.objects import ObjectKind
from t2m_core.domain.predicates import Scene, evaluate
from t2m_core.domain.propositions import Proposition
from t2m_core.domain.state import GeometricState

RELATION_ORDER: tuple[str, ...] = ("under", "on", "inhand")
"""Order of predicates in a symbolic state (the original's output order)."""


def symbolic_state(state: GeometricState, object_names: Sequence[str] | None = None) -> tuple[Proposition, ...]:
    """The true geometry-only relations of a state (docs/guide/world.md#relations-the-language-model-sees).

    Every ``under(x, y)`` and ``on(x, y)`` over ordered pairs of distinct objects, the table included,
    and ``inhand(x)`` for every object. Grouped by predicate (under, on, inhand), then by the object
    order. Workspace membership is never included.

    Args:
        state: the geometric state (row 0 / the end effector plays no role).
        object_names: objects in task order; defaults to ``state.object_names``. Absent ones are skipped.
    """
    names = [n for n in (object_names if object_names is not None else state.object_names) if n in state.objects]
    objects = [geometry.object_geometry(n, state.objects[n]) for n in names]
    pairs = list(itertools.permutations(objects, 2))
    relations = [Proposition("under", (a.name, b.name)) for a, b in pairs if is_under(a, b)]
    relations += [Proposition("on", (a.name, b.name)) for a, b in pairs if is_on(a, b)]
    relations += [Proposition("inhand", (a.name,)) for a in objects if is_inhand(a)]
    return tuple(relations)


def relation_strings(state: GeometricState, object_names: Sequence[str] | None = None) -> list[str]:
    """:func:`symbolic_state` as strings, ``['on(rack, table)', ...]``, as the prompts show them."""
    return [str(p) for p in symbolic_state(state, object_names)]



SITUATION_ZONES: tuple[str, ...] = ("inworkspace", "beyondworkspace")
"""The zones a situation records for every box."""


def situation(state: GeometricState, object_names: Sequence[str] | None = None) -> frozenset[str]:
    """What a planner compares to tell one planned state from another: the relations of
    :func:`symbolic_state`, plus, for every box not in hand, the zones of :data:`SITUATION_ZONES` it
    lies in and ``infront(box, rack)`` (docs/guide/planners.md#revisited-states).

    The relations alone cannot tell a pulled box from one left where it was, or a box moved out of
    the rack's way from one standing in front of it; the zones and ``infront`` can. Where the hook
    lies is left out, its ``on`` and ``under`` relations too (only ``inhand(hook)`` stays): putting it
    down somewhere else achieves nothing by itself.

    Args:
        state: the geometric state.
        object_names: objects in task order; defaults to ``state.object_names``. Absent ones are skipped.
    """
    names = [n for n in (object_names if object_names is not None else state.object_names) if n in state.objects]
    scene = Scene(state)
    tools = {n for n in names if scene.geometry(n).spec.kind is ObjectKind.HOOK}
    facts = {str(p) for p in symbolic_state(state, names) if p.predicate == "inhand" or not tools & set(p.args)}
    racks = [n for n in names if scene.geometry(n).spec.kind is ObjectKind.RACK]
    for name in names:
        if scene.geometry(name).spec.kind is not ObjectKind.BOX or state.held == name:
            continue
        facts.update(f"{zone}({name})" for zone in SITUATION_ZONES if evaluate(f"{zone}({name})", scene, full=False))
        facts.update(f"infront({name}, {rack})" for rack in racks if evaluate(f"infront({name}, {rack})", scene, full=False))
    return frozenset(facts)
