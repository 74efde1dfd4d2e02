"""The value() check of every predicate of the TableEnv world, on a scene
(docs/guide/world.md#predicates). Propositions themselves are :mod:`t2m_core.domain.propositions`,
the relations the language layer sees :mod:`t2m_core.domain.relations`.

Two flavours of check:

- *geometry only* (``full=False``): the geometric tests on poses; used by the language layer, also on
  predicted states. ``on`` does not require uprightness.
- *full* (``full=True``, the default of :func:`evaluate`): as simulated task success and resets use
  it; ``on(a, b)`` also requires a to be upright unless ``tippable(a)`` is in the context.

``evaluate`` receives the *context*: the task's initial-state propositions, because some predicates
read others (``free`` looks for ``infront``; ``on`` for ``tippable``).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable

import numpy as np

from t2m_core.domain import geometry
from t2m_core.domain.constants import (
    FREE_MIN_DISTANCE,
    FREE_REDUCED_MIN_DISTANCE,
    NONBLOCKING_GROWTH,
    ZONES,
    zone_of,
)
from t2m_core.domain.geometry import ObjectGeometry, is_inhand, is_on, is_under
from t2m_core.domain.objects import ObjectKind
from t2m_core.domain.propositions import (
    GOAL_PREDICATES,
    PREDICATE_ARITY,
    PREDICATE_ORDER,
    Proposition,
    PropositionError,
    canonical_order,  # noqa: F401  (t2m_core/data, t2m_core/simulation, t2m_mujoco import it from here)
)
from t2m_core.domain.state import GeometricState

DistanceFn = Callable[[str, str], float]
"""Closest distance in metres between two named objects (e.g. a simulator's closest-point query)."""


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
