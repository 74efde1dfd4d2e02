"""The gripper's fingers as footprints, and whether they come down on a bystander.

A prediction from the domain's geometry for Pick (the open fingers descending around the object) and
Place (the fingers closed on the held object, descending with it): the finger boxes of the robot
model (:mod:`t2m_core.simulation.robot`: a pad and a body box per finger, across the jaw along the
EE's y axis), projected on the table plane, against the parts of the other objects that rise above
the fingertips. A prediction only; the simulator's contacts decide.
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Sequence

import numpy as np

from t2m_core.domain.geometry import (
    ObjectGeometry,
    object_geometry,
    pad_polygons,
    polygon_edges,
    quat_yaw,
    yawed_polygons,
)
from t2m_core.domain.objects import ObjectKind, object_spec
from t2m_core.domain.primitives.sweep_screen import comes_near
from t2m_core.domain.state import GeometricState, ObjectPose, pose_groups
from t2m_core.simulation.robot import FINGER_BODY_CENTER, FINGER_BODY_HALF, PAD_HALF

FINGER_DEPTH = FINGER_BODY_CENTER[1] + FINGER_BODY_HALF[1]
"""m: from a pad's inner face to the finger body's outer face, across the jaw (26.4 mm)."""

FINGERTIP_BELOW_EE = 0.008
"""m: the fingertips lie this far below the EE point (:mod:`t2m_core.simulation.robot`)."""

FINGER_CLEARANCE = {ObjectKind.BOX: 0.005, ObjectKind.HOOK: 0.005, ObjectKind.RACK: 0.02}
"""m, by kind of bystander: the fingers are predicted to strike one when a finger's footprint comes
this close to a part of it that rises above the fingertips. Measured on 250 planner-proposed grasps
in the task scenes: no successful grasp came within 3 cm of the rack, 13 of 24 collisions within
2 cm of it (the plate's edge, which the fingers pass on their way down)."""


def finger_footprints(positions: np.ndarray, yaws: np.ndarray, opening: float | np.ndarray) -> np.ndarray:
    """``(B, 2, 4, 2)`` counter-clockwise xy footprints (m) of both fingers for ``(B, 2)`` EE positions
    (m), ``(B,)`` EE yaws (rad) and pads' inner faces ``opening`` m either side of the EE (a scalar or
    ``(B,)``; 0.04 for the open gripper)."""
    opening = np.broadcast_to(np.asarray(opening, dtype=np.float64), yaws.shape)[:, None]
    x = np.array([-PAD_HALF[0], PAD_HALF[0], PAD_HALF[0], -PAD_HALF[0]])
    inner, outer = opening, opening + FINGER_DEPTH
    left = np.stack((np.broadcast_to(x, (len(yaws), 4)), np.concatenate((inner, inner, outer, outer), axis=1)), axis=-1)
    right = left[:, ::-1] * np.array([1.0, -1.0])  # mirrored in y, reversed to stay counter-clockwise
    return yawed_polygons(np.stack((left, right), axis=1), positions, yaws)  # from (B, 2, 4, 2) in the EE frame


def fingers_strike(state: GeometricState, spared: Collection[str], footprints: np.ndarray, tips: np.ndarray) -> np.ndarray:
    """``(B,)`` whether the ``(B, 2, 4, 2)`` finger footprints, their tips at ``(B,)`` heights (m), come
    within :data:`FINGER_CLEARANCE` of a part of an object other than the table and ``spared`` that
    rises above that sample's fingertips."""
    return fingers_strike_of_states([state], np.zeros(len(tips), dtype=np.int64), spared, footprints, tips)


def fingers_strike_of_states(
    states: Sequence[GeometricState],
    state_of: np.ndarray,
    spared: Collection[str],
    footprints: np.ndarray,
    tips: np.ndarray,
    geometry: Callable[[str, ObjectPose], ObjectGeometry] = object_geometry,
) -> np.ndarray:
    """:func:`fingers_strike` of fingers b in ``states[state_of[b]]``, judged as one batch: a part
    counts for a sample where it rises above that sample's own fingertips, so that a sample's
    prediction never depends on the others in the batch."""
    edges = polygon_edges(footprints)
    tips = np.asarray(tips, dtype=np.float64)
    first, group_of = pose_groups(states, spared)  # the states whose other objects stand alike share their parts
    group_of = group_of[np.asarray(state_of, dtype=np.int64)]
    sampled = np.bincount(group_of, minlength=len(first)) > 0
    parts: dict[ObjectKind, list[list[np.ndarray]]] = {kind: [[] for _ in first] for kind in FINGER_CLEARANCE}
    tops: dict[ObjectKind, list[list[float]]] = {kind: [[] for _ in first] for kind in FINGER_CLEARANCE}
    for group, index in enumerate(first):
        if not sampled[group]:
            continue  # no fingers in these states
        for name, pose in states[index].objects.items():
            if name not in spared and object_spec(name).kind in parts:
                shape = geometry(name, pose)
                parts[shape.spec.kind][group] += list(shape.footprints)
                tops[shape.spec.kind][group] += [float(corners[:, 2].max()) for corners in shape.part_corners]
    struck = np.zeros(len(footprints), dtype=bool)
    for kind, per_state in parts.items():
        most = max(len(of_state) for of_state in per_state)
        if most == 0:
            continue
        # every state's parts, padded with polygons far beyond any clearance (never rising)
        padded = pad_polygons([pad_polygons(of_state + [_FAR] * (most - len(of_state))) for of_state in per_state])
        heights = np.array([of_state + [-np.inf] * (most - len(of_state)) for of_state in tops[kind]])  # (S, P) m
        rising = heights[group_of] > tips[:, None]  # (B, P): the parts above each sample's fingertips
        obstacles = np.where(rising[..., None, None], padded[group_of], _FAR[0])  # the others moved out of reach
        struck |= comes_near(footprints, edges, obstacles, FINGER_CLEARANCE[kind])
    return struck


_FAR = np.full((1, 2), 1.0e6)
"""m: a stand-in part, a point no finger comes near."""


def held_opening(
    state: GeometricState, held: str, geometry: Callable[[str, ObjectPose], ObjectGeometry] = object_geometry
) -> float:
    """m: how far either side of the EE the pads' inner faces stand when closed on ``held``: the larger
    half-extent across the jaw (the EE's y axis) of the held object's part nearest the EE
    (``geometry``: how to compute the object's, e.g. a memo over many states)."""
    yaw = float(quat_yaw(state.ee_quaternion))
    across = np.array([-np.sin(yaw), np.cos(yaw)])
    footprints = geometry(held, state.objects[held]).footprints
    ee = state.ee_position[:2]
    part = min(footprints, key=lambda footprint: float(np.linalg.norm(footprint.mean(axis=0) - ee)))
    projections = (part - ee) @ across
    return float(np.max(np.abs(projections)))
