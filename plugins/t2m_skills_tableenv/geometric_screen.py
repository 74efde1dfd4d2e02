"""The primitives' geometric screen as an input of the Q-ensemble (docs/guide/skills.md#geometric-q-ensemble).

Each primitive predicts from the domain's geometry alone whether an action drives the gripper, the
hook or the carried object into another object (``in_the_way``: for Pick, an open finger coming down
on a part of a bystander that rises above the fingertips; for Place, the carried object set down
against a bystander; for Pull and Push, the hook, the box or the hand swept through one).
Some also give the margins behind such flags, in metres (:data:`MARGIN_SCALES`).
:func:`screen_values` evaluates the predictions for skill states as the networks see them: raw
argument-first rows, the objects identified by their shape features (every object of the world has
its own), so that a Q-ensemble can read them beside the state and the action without knowing the
objects' names.

A prediction, not a label: on the data scenes' validation transitions ``in_the_way`` flags 97 / 59 /
99.6 / 80 % of the collisions of Pick / Place / Pull / Push and 3.5 / 9.5 / 10 / 17.5 % of their
successes, so the ensemble learns how far to trust it.
"""

from __future__ import annotations

import numpy as np

from t2m_core.domain.objects import OBJECTS, ObjectKind
from t2m_core.domain.observation import FEATURES, OBSERVATION_ROWS, STATIC_FEATURES, decode_observation
from t2m_core.domain.primitives import PRIMITIVES
from t2m_core.domain.primitives.base import Primitive
from t2m_core.domain.state import GeometricState

SCREEN_FEATURES: dict[str, tuple[str, ...]] = {
    "pick": ("in_the_way",),
    "place": ("in_the_way", "too_high", "clearance", "footprint_gap", "support_gap", "workspace_margin", "support_margin", "balance_margin"),
    "pull": ("clearance", "reach_margin"),
    "push": ("clearance", "sweep_gap", "reach_margin"),
}
"""The predictions a skill's geometric Q-ensemble reads by default (``t2m train --q-network
geometric``; ``--screen`` picks others): for Pick, the flag ``in_the_way``; for the hook sweeps,
the margins behind their flags ``in_the_way`` and ``unreachable`` (on the data scenes' validation
they took Pull's precision / recall from 96.1 / 94.2 % with the flags to 96.9 / 96.8 %); for Place,
its two flags and six margins (without ``support_margin``, task1's plans set boxes down beyond the
table's edge; without ``balance_margin``, task6's set the hook down with its head beyond it, and it
rolled off about its handle; ``too_high`` marks releases the descent's drop check fails, which a
search found where the data are thin; ``footprint_gap`` took Place's recall from 93.35 to 94.85 %
on the same data: docs/guide/skills.md#pull-push-and-place); for Push, also ``sweep_gap``, which
tells a sweep under a box standing on the rack (57 % of those validation pushes succeed) from one
into a box on the table (5 %), where ``clearance`` reads −1 cm for both (on 12 000 transitions it
lowered the validation loss from 0.154 to 0.145)."""
MARGIN_SCALES: dict[str, float] = {
    "clearance": 0.05, "reach_margin": 0.05, "under_depth": 0.1, "leg_clearance": 0.05, "footprint_gap": 0.01, "sweep_gap": 0.01, "support_gap": 0.02, "workspace_margin": 0.05,
    "support_margin": 0.05, "balance_margin": 0.02,
}
"""Predictions that are margins in metres, and the margin that enters a network as ±0.5
(:func:`screen_inputs`): the hook sweeps' ``clearance`` from the bystanders beyond the screen's own
clearances, ``sweep_gap`` from those at the sweep's height (negative: how deep the swept hook or
box reaches into one) and ``reach_margin`` inside the arm's reach (negative where ``in_the_way`` or
``unreachable``); Push's ``under_depth`` of the box under the rack and ``leg_clearance`` of the
swept box from the rack's legs; Place's ``clearance`` of the set-down object from the bystanders,
``footprint_gap`` from those that rise above its lowest point (negative: how deep it overlaps one),
``support_gap`` between its lowest point and the target's surface at the release,
``workspace_margin`` of the release, ``support_margin`` of its centre of mass inside the target's top
and ``balance_margin`` of it inside the part of its resting hull that the top holds up.
The others are flags."""
REFUSED_MARGIN = -np.inf
"""The margin of a call the primitive refuses (every flag raised); a state of no known world reads
``+inf`` (no prediction: nothing in the way)."""
SCREEN_SKILLS = tuple(SCREEN_FEATURES)
_NAMES = tuple(name for name, spec in OBJECTS.items() if spec.kind is not ObjectKind.TABLE)
_SHAPES = np.array([OBJECTS[name].shape_features() for name in _NAMES], dtype=np.float64)  # (objects, 6)
_SHAPE_TOLERANCE = 0.0015
"""m: a row's shape features name the object whose own lie nearest, if within this (the closest two
objects, the yellow and the cyan box, differ by 4 mm; a predicted state's rows drift a little)."""
_SHAPELESS = 1e-3
"""Raw shape features all below this: the table's row or an empty slot (whatever pose a dynamics
model predicted for it)."""


def row_objects(rows: np.ndarray) -> tuple[str | None, ...]:
    """The object of each of the 7 object rows of one raw ``(8, 12)`` state, real or predicted, by its
    shape features: the name whose shape lies nearest, ``"table"`` for the first row without shape
    features (the table's row carries none), ``None`` for the others (empty slots).

    Raises:
        ValueError: a row whose shape features match no object of the world.
    """
    shapes = np.asarray(rows, dtype=np.float64)[1:, STATIC_FEATURES]  # (7, 6)
    shapeless = np.all(np.abs(shapes) < _SHAPELESS, axis=-1)
    distance = np.abs(shapes[:, None] - _SHAPES).max(axis=-1)  # (7, objects)
    unknown = ~shapeless & (distance.min(axis=-1) > _SHAPE_TOLERANCE)
    if unknown.any():
        shape = shapes[int(np.argmax(unknown))]
        raise ValueError(f"a row's shape features {np.round(shape, 4).tolist()} match no object of the world")
    names: list[str | None] = [None if empty else _NAMES[int(nearest)] for empty, nearest in zip(shapeless, distance.argmin(axis=-1), strict=True)]
    if shapeless.any():
        names[int(np.argmax(shapeless))] = "table"  # the first row without shape features
    return tuple(names)


def screen_features(skill: str, features: tuple[str, ...] | None = None) -> tuple[str, ...]:
    """``features`` (default: :data:`SCREEN_FEATURES` of ``skill``), checked against what the skill's
    primitive predicts.

    Raises:
        ValueError: a skill without a screen, or a prediction its primitive does not make.
    """
    if skill not in SCREEN_FEATURES:
        raise ValueError(f"no geometric screen for skill {skill!r} (known: {', '.join(SCREEN_SKILLS)})")
    features = SCREEN_FEATURES[skill] if features is None else tuple(features)
    known = PRIMITIVES[skill].screen_predictions
    unknown = [name for name in features if name not in known]
    if unknown or not features:
        raise ValueError(f"{skill}'s screen predicts {', '.join(known)}; asked for {', '.join(unknown) or 'nothing'}")
    return features


def screen_values(skill: str, rows: np.ndarray, actions: np.ndarray, features: tuple[str, ...] | None = None) -> np.ndarray:
    """``(N, F)`` float64: the primitive's geometric predictions ``features`` (default
    :data:`SCREEN_FEATURES` of ``skill``) for ``(N, 8, 12)`` raw argument-first rows (row 0 the EE,
    then the skill's arguments) and ``(N, 4)`` normalised actions: flags 1 / 0 (``"in_the_way"``:
    the action drives something into another object; ``"unreachable"``: the EE leaves the arm's
    reach), margins in metres (:data:`MARGIN_SCALES`). Every flag is raised and every margin
    :data:`REFUSED_MARGIN` for a call the primitive refuses (the invalid split's ``pick(table)``:
    nothing it does can succeed); a state whose rows name no object of the world gets no prediction
    (flags 0, margins ``+inf``). States
    that repeat (a planner ranking many actions in one state) are decoded once, and every state with
    the same objects goes to the primitive's ``screen_of_states`` in one batch (a planner's samples,
    each in its own predicted state, judged at once).

    Raises:
        ValueError: a skill without a screen, or a prediction its primitive does not make.
    """
    features = screen_features(skill, features)
    primitive = PRIMITIVES[skill]
    rows = np.asarray(rows, dtype=np.float64).reshape(-1, OBSERVATION_ROWS, FEATURES)
    physical = primitive.to_physical(np.asarray(actions, dtype=np.float64).reshape(len(rows), -1))
    arity = len(primitive.argument_kinds)
    unique, inverse = np.unique(rows.reshape(len(rows), -1), axis=0, return_inverse=True)
    inverse = inverse.reshape(-1)
    # the samples of each distinct state, in order
    groups = np.split(np.argsort(inverse, kind="stable"), np.cumsum(np.bincount(inverse, minlength=len(unique)))[:-1])
    margins = np.array([name in MARGIN_SCALES for name in features])
    values = np.where(margins, np.inf, 0.0)[None].repeat(len(rows), axis=0)
    groups_by_objects: dict[tuple[str | None, ...], list[tuple[GeometricState, np.ndarray]]] = {}
    for state_rows, mine in zip(unique.reshape(-1, OBSERVATION_ROWS, FEATURES), groups, strict=True):
        try:
            names = row_objects(state_rows)
        except ValueError:
            continue  # not a state of this world (a conformance check's random rows): no prediction
        present = [row for row, name in enumerate(names, start=1) if name is not None]
        observation = np.zeros((OBSERVATION_ROWS, FEATURES))
        observation[0] = state_rows[0]
        observation[1 : 1 + len(present)] = state_rows[present]
        state = decode_observation(observation, [names[row - 1] for row in present])
        groups_by_objects.setdefault(names, []).append((state, mine))
    for names, members in groups_by_objects.items():
        arguments = names[:arity]
        if _refuses(primitive, members[0][0], arguments):
            for _, mine in members:
                values[mine] = np.where(margins, REFUSED_MARGIN, 1.0)
            continue
        samples = np.concatenate([mine for _, mine in members])
        state_of = np.repeat(np.arange(len(members)), [len(mine) for _, mine in members])
        predictions = primitive.screen_of_states([state for state, _ in members], arguments, physical[samples], state_of)
        values[samples] = np.stack([predictions[name] for name in features], axis=-1)
    return values


def screen_flags(skill: str, rows: np.ndarray, actions: np.ndarray, features: tuple[str, ...] | None = None) -> np.ndarray:
    """``(N, F)`` bool: :func:`screen_values` of flags only (``features`` without margins)."""
    features = screen_features(skill, features)
    if any(name in MARGIN_SCALES for name in features):
        raise ValueError(f"screen_flags takes flags; {', '.join(name for name in features if name in MARGIN_SCALES)} are margins (screen_values)")
    return screen_values(skill, rows, actions, features) > 0.5


def screen_inputs(values: np.ndarray, features: tuple[str, ...]) -> np.ndarray:
    """``(..., F)`` network inputs in [−0.5, 0.5] of ``(..., F)`` :func:`screen_values`: a flag
    enters as ±0.5, a margin m as clip(m / scale, −1, 1) / 2 (:data:`MARGIN_SCALES`)."""
    scales = np.array([MARGIN_SCALES.get(name, 0.0) for name in features])
    values = np.asarray(values, dtype=np.float64)
    margins = np.clip(values / np.where(scales > 0, scales, 1.0), -1.0, 1.0) / 2.0
    return np.where(scales > 0, margins, values - 0.5)


def _refuses(primitive: Primitive, state: GeometricState, arguments: tuple[str | None, ...]) -> bool:
    """Whether ``primitive`` refuses ``arguments`` (an empty row, or an object of the wrong kind)."""
    if None in arguments:
        return True
    try:
        primitive.check_arguments(state, arguments)
    except ValueError:
        return True
    return False
