"""Predicates of the TableEnv world: propositions, their value() checks, the canonical order and the
symbolic state (docs/guide/world.md#predicates).

Two flavours of check:

- *geometry only* (``full=False``): the geometric tests on poses; used by the language layer, also on
  predicted states. ``on`` does not require uprightness.
- *full* (``full=True``, the default of :func:`evaluate`): as simulated task success and resets use
  it; ``on(a, b)`` also requires a to be upright unless ``tippable(a)`` is in the context.

``evaluate`` receives the *context*: the task's initial-state propositions, because some predicates
read others (``free`` looks for ``infront``; ``on`` for ``tippable``).
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from t2m_core.domain import geometry
from t2m_core.domain.constants import (
    MAX_LIFT_HEIGHT,
    ON_CONTACT_GAP,
    ZONES,
)
from t2m_core.domain.geometry import ObjectGeometry
from t2m_core.domain.literals import format_call, parse_call
from t2m_core.domain.objects import ObjectKind
from t2m_core.domain.state import GeometricState
from t2m_core.errors import T2MError

PREDICATE_ORDER: tuple[str, ...] = (
    "handlegrasp",
    "upperhandlegrasp",
    "free",
    "aligned",
    "tippable",
    "poslimit",
    "inworkspace",
    "incollisionzone",
    "inoperationalzone",
    "inobstructionzone",
    "beyondworkspace",
    "inoodzone",
    "under",
    "infront",
    "nonblocking",
    "on",
    "inhand",
)
"""Canonical predicate order (docs/guide/world.md#canonical-order): initial states are sampled in this order (``on`` before ``inhand``)."""

PREDICATE_ARITY: dict[str, int] = {
    name: (2 if name in ("under", "infront", "nonblocking", "on") else 1) for name in PREDICATE_ORDER
}
"""Number of arguments of every predicate."""

GOAL_PREDICATES: tuple[str, ...] = ("on", "under", "inhand")
"""The only predicates of goals, the language interface and task success."""

RELATION_ORDER: tuple[str, ...] = ("under", "on", "inhand")
"""Order of predicates in a symbolic state (the original's output order)."""

ZONE_PREDICATES: tuple[str, ...] = tuple(ZONES)
"""The zone predicates, in canonical order."""


class PropositionError(T2MError, ValueError):
    """A proposition names an unknown predicate or object, or has the wrong number of arguments."""


@dataclass(frozen=True, order=True)
class Proposition:
    """A grounded predicate, e.g. ``on(red_box, rack)``.

    Attributes:
        predicate: the predicate's name (``"on"``).
        args: object names, in order.
    """

    predicate: str
    args: tuple[str, ...]

    def __post_init__(self) -> None:
        object.__setattr__(self, "args", tuple(self.args))

    def __str__(self) -> str:
        return format_call(self.predicate, self.args)

    @classmethod
    def parse(cls, text: str) -> Proposition:
        """Parse ``"on(red_box,rack)"`` (any spacing). Syntax only: see :func:`validate_proposition`.

        Raises:
            LiteralSyntaxError: naming the offending position.
        """
        name, args = parse_call(text, "proposition")
        return cls(name, args)

    @classmethod
    def coerce(cls, value: Proposition | str) -> Proposition:
        """``value`` itself, or parsed from a string."""
        return value if isinstance(value, Proposition) else cls.parse(value)

    @property
    def canonical_rank(self) -> int:
        """Index of the predicate in :data:`PREDICATE_ORDER` (unknown predicates sort last)."""
        try:
            return PREDICATE_ORDER.index(self.predicate)
        except ValueError:
            return len(PREDICATE_ORDER)


def canonical_order(propositions: Iterable[Proposition | str]) -> tuple[Proposition, ...]:
    """Sort by :data:`PREDICATE_ORDER`, keeping the given order within one predicate."""
    props = [Proposition.coerce(p) for p in propositions]
    return tuple(sorted(props, key=lambda p: p.canonical_rank))  # sorted() is stable


def validate_proposition(
    proposition: Proposition,
    object_names: Sequence[str],
    predicates: Sequence[str] = PREDICATE_ORDER,
) -> None:
    """Check the predicate is one of ``predicates``, the arity is right and every argument is in
    ``object_names``.

    Raises:
        PropositionError: naming the problem and listing what exists.
    """
    if proposition.predicate not in predicates:
        raise PropositionError(
            f"unknown predicate {proposition.predicate!r} in {proposition}",
            f"use one of: {', '.join(predicates)}",
        )
    arity = PREDICATE_ARITY[proposition.predicate]
    if len(proposition.args) != arity:
        raise PropositionError(
            f"{proposition} has {len(proposition.args)} argument(s); {proposition.predicate} takes {arity}",
            f"write {proposition.predicate}({', '.join('xy'[:arity])})",
        )
    for arg in proposition.args:
        if arg not in object_names:
            raise PropositionError(
                f"unknown object {arg!r} in {proposition}", f"objects in this scene: {', '.join(object_names)}"
            )


# --------------------------------------------------------------------------------------------------
# Geometric classifiers on object geometries
# --------------------------------------------------------------------------------------------------


def is_inhand(obj: ObjectGeometry) -> bool:
    """inhand(o): origin z > 0.40 − 0.5·size_z (the original's live test; the rack's origin is its top plate)."""
    return float(obj.position[2]) > MAX_LIFT_HEIGHT - 0.5 * obj.spec.size[2]


def is_on(a: ObjectGeometry, b: ObjectGeometry) -> bool:
    """Geometry-only on(a, b): above, footprints intersect, a not in hand, |min_z(a) − max_z(b)| < 0.04."""
    return (
        a.name != b.name
        and geometry.is_above(a, b)
        and abs(a.min_z - b.max_z) < ON_CONTACT_GAP
        and not is_inhand(a)
        and geometry.is_intersecting(a, b)
    )


def is_under(a: ObjectGeometry, b: ObjectGeometry) -> bool:
    """under(a, b): b is a receptacle (the original required the name "rack"), neither is the table, a is not above b, and the
    footprints intersect. Never true together with on(a, b), which requires above."""
    return (
        a.name != b.name
        and b.spec.kind is ObjectKind.RACK
        and a.spec.kind is not ObjectKind.TABLE
        and not geometry.is_above(a, b)
        and geometry.is_intersecting(a, b)
    )


# --------------------------------------------------------------------------------------------------
# Evaluating propositions in a scene
# --------------------------------------------------------------------------------------------------

DistanceFn = Callable[[str, str], float]
"""Closest distance in metres between two named objects (e.g. a simulator's closest-point query)."""

FREE_MIN_DISTANCE: dict[frozenset[ObjectKind], float] = {
    frozenset({ObjectKind.BOX}): 0.05,
    frozenset({ObjectKind.BOX, ObjectKind.HOOK}): 0.05,
    frozenset({ObjectKind.BOX, ObjectKind.RACK}): 0.10,
    frozenset({ObjectKind.HOOK, ObjectKind.RACK}): 0.10,
}
"""d_min of ``free`` per unordered type pair, metres; unlisted pairs are ignored."""
FREE_REDUCED_MIN_DISTANCE = 0.04
"""d_min when the other object is a rack beyond the workspace, or an ``infront(·, rack)`` is involved."""

NONBLOCKING_GROWTH: dict[tuple[ObjectKind, ObjectKind], dict[str | None, float]] = {
    (ObjectKind.BOX, ObjectKind.RACK): {"inworkspace": 3.0, "beyondworkspace": 1.5, None: 1.0},
    (ObjectKind.BOX, ObjectKind.BOX): {"inworkspace": 3.0, "beyondworkspace": 3.0, None: 3.0},
    (ObjectKind.RACK, ObjectKind.HOOK): {"inworkspace": 0.25, "beyondworkspace": 0.25, None: 0.25},
}
"""``nonblocking(t, o)`` hull growth scale by (t's type, o's type) and o's zone: the hull of o
grows by scale·max(size_x, size_y of t). The original applied 1.0 to every pair whose obstacle is in
neither zone; the reference's table gives Box–Box 3.0 and Rack–Hook 0.25 unconditionally, which we
follow."""


class Scene:
    """A geometric state plus the proposition context, with per-object geometry computed once.

    Args:
        state: object poses; objects missing from ``state.objects`` are *absent*.
        context: the task's initial-state propositions (strings or :class:`Proposition`).
        distance: closest-distance query for ``free``; defaults to the analytic
            :func:`geometry.closest_distance`.
    """

    def __init__(
        self,
        state: GeometricState,
        context: Iterable[Proposition | str] = (),
        *,
        distance: DistanceFn | None = None,
    ) -> None:
        self.state = state
        self.context = frozenset(str(Proposition.coerce(p)) for p in context)
        self._distance = distance
        self._geometry: dict[str, ObjectGeometry] = {}

    def present(self, name: str) -> bool:
        """Whether ``name`` has a pose in this state."""
        return name in self.state.objects

    def geometry(self, name: str) -> ObjectGeometry:
        """World geometry of a present object (cached)."""
        if name not in self._geometry:
            if name not in self.state.objects:
                raise KeyError(f"object {name!r} is not in the scene; present: {', '.join(self.state.objects)}")
            self._geometry[name] = geometry.object_geometry(name, self.state.objects[name])
        return self._geometry[name]

    def has(self, text: str) -> bool:
        """Whether the proposition spelled ``text`` is in the context."""
        return text in self.context

    def distance(self, a: str, b: str) -> float:
        """Closest distance between two present objects, metres."""
        if self._distance is not None:
            return self._distance(a, b)
        return geometry.closest_distance(self.geometry(a), self.geometry(b))

    def held(self, name: str) -> bool:
        """Held by the gripper, or declared ``inhand`` in the context."""
        return self.state.held == name or self.has(f"inhand({name})")


def _always(scene: Scene, *args: str, full: bool) -> bool:
    return True


def _inhand(scene: Scene, obj: str, *, full: bool) -> bool:
    return is_inhand(scene.geometry(obj))


def _on(scene: Scene, child: str, parent: str, *, full: bool) -> bool:
    a = scene.geometry(child)
    if not is_on(a, scene.geometry(parent)):
        return False
    return not full or scene.has(f"tippable({child})") or geometry.is_upright(a.quaternion)


def _under(scene: Scene, child: str, parent: str, *, full: bool) -> bool:
    return is_under(scene.geometry(child), scene.geometry(parent))


def _zone(zone_name: str) -> Callable[..., bool]:
    zone = ZONES[zone_name]

    def value(scene: Scene, obj: str, *, full: bool) -> bool:
        if zone_name == "inworkspace" and scene.geometry(obj).spec.kind is ObjectKind.RACK:
            return True  # the rack is placed by poslimit, never tested against the workspace
        x, y = scene.geometry(obj).position[:2]
        return bool(zone.contains(x, y))

    return value


def _free(scene: Scene, obj: str, *, full: bool) -> bool:
    me = scene.geometry(obj)
    for other in scene.state.objects:
        if other == obj or scene.held(other):
            continue
        them = scene.geometry(other)
        if is_under(me, them):
            return False
        d_min = FREE_MIN_DISTANCE.get(frozenset({me.spec.kind, them.spec.kind}))
        if d_min is None:
            continue
        if (
            (them.spec.kind is ObjectKind.RACK and scene.has(f"beyondworkspace({other})"))
            or scene.has(f"infront({obj}, rack)")
            or scene.has(f"infront({other}, rack)")
        ):
            d_min = FREE_REDUCED_MIN_DISTANCE
        if scene.distance(obj, other) <= d_min and not geometry.is_above(me, them):
            return False
    return True


def _infront(scene: Scene, obj: str, rack: str, *, full: bool) -> bool:
    me, them = scene.geometry(obj), scene.geometry(rack)
    x, y = me.position[:2]
    return bool(x < them.aabb[0, 0] and them.aabb[0, 1] < y < them.aabb[1, 1] and not is_under(me, them))


def zone_of(x: float, y: float) -> str | None:
    """``"inworkspace"``, ``"beyondworkspace"`` or ``None`` for a world xy position, metres."""
    for name in ("inworkspace", "beyondworkspace"):
        if ZONES[name].contains(x, y):
            return name
    return None


def _nonblocking(scene: Scene, target: str, obstacle: str, *, full: bool) -> bool:
    t, o = scene.geometry(target), scene.geometry(obstacle)
    hull = o.bounding_box_footprint()
    growth = NONBLOCKING_GROWTH.get((t.spec.kind, o.spec.kind))
    if growth is not None:
        scale = growth[zone_of(*o.position[:2])]
        hull = geometry.grow_polygon(hull, scale * max(t.spec.size[:2]))
    return not geometry.segment_intersects_polygon(np.zeros(2), t.position[:2], hull)


_VALUE: dict[str, Callable[..., bool]] = {
    "handlegrasp": _always,
    "upperhandlegrasp": _always,
    "free": _free,
    "aligned": _always,
    "tippable": _always,
    "poslimit": _always,
    **{name: _zone(name) for name in ZONES},
    "under": _under,
    "infront": _infront,
    "nonblocking": _nonblocking,
    "on": _on,
    "inhand": _inhand,
}
# Keyed in canonical order, so this table also checks PREDICATE_ORDER.
assert tuple(_VALUE) == PREDICATE_ORDER


def evaluate(
    proposition: Proposition | str,
    scene: Scene | GeometricState,
    context: Iterable[Proposition | str] = (),
    *,
    full: bool = True,
) -> bool:
    """The value() check of one proposition.

    Args:
        proposition: e.g. ``"on(red_box, rack)"``.
        scene: a :class:`Scene`, or a state (then ``context`` gives the proposition context).
        context: initial-state propositions, when ``scene`` is a bare state.
        full: the full check (``on`` requires uprightness unless ``tippable``); ``False`` for the
            geometry-only check of the language layer.

    Returns:
        Whether the proposition holds. A proposition about an *absent* object holds (absent objects
        are neither physical nor observed: docs/guide/world.md#absent-objects), except the goal predicates, which are false.

    Raises:
        PropositionError: unknown predicate or wrong arity.
    """
    prop = Proposition.coerce(proposition)
    if prop.predicate not in _VALUE:
        raise PropositionError(f"unknown predicate {prop.predicate!r} in {prop}", f"use one of: {', '.join(_VALUE)}")
    if len(prop.args) != PREDICATE_ARITY[prop.predicate]:
        raise PropositionError(f"{prop} takes {PREDICATE_ARITY[prop.predicate]} argument(s)")
    view = scene if isinstance(scene, Scene) else Scene(scene, context)
    if not all(view.present(arg) for arg in prop.args):
        return prop.predicate not in GOAL_PREDICATES
    return _VALUE[prop.predicate](view, *prop.args, full=full)


def holds_all(
    propositions: Iterable[Proposition | str],
    scene: Scene | GeometricState,
    context: Iterable[Proposition | str] | None = None,
    *,
    full: bool = True,
) -> bool:
    """Whether every proposition holds; the propositions are their own context unless one is given
    (the reset's final verification)."""
    props = [Proposition.coerce(p) for p in propositions]
    view = scene if isinstance(scene, Scene) else Scene(scene, props if context is None else context)
    return all(evaluate(p, view, full=full) for p in props)


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

