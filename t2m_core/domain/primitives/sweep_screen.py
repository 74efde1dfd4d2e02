"""Analytic screen of Pull and Push actions for data generation (no simulation).

The reference heuristic (docs/guide/primitives.md#action-samplers) fixes r_reach and θ = π/8 and draws the sweep
length and the sideways offset y uniformly. Many such draws are doomed before any physics runs: the
handle lands on the box's top (the box tips), the sweep ends with the box outside the workspace or
short of the rack, the tool or the hand sweeps through a bystander, or the EE leaves the arm's reach.
This module predicts those outcomes from the domain's own geometry, so the *screened* sampler
(:meth:`~t2m_core.domain.primitives.hook_sweep.HookSweep.screened_physical`) can redraw them.

The prediction is deliberately simple: once the head has closed the initial gap, the swept box moves
with it and keeps its yaw. Pulled, it follows the sweep, possibly sliding sideways into the hook's
crook against the handle; pushed, it slides along the angled head's normal, as a frictionless
contact would (measured on task1 scenes: a box pushed with θ = π/8 drifts sideways by about 0.4 of
its forward travel). Margins absorb the errors of that model. A screen reason is a prediction
only; the primitive's own tests decide success.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from t2m_core.domain.constants import TABLE_X_MIN
from t2m_core.domain.geometry import (
    ObjectGeometry,
    convex_hull_2d,
    object_geometry,
    polygon_distance,
    polygons_overlap,
    quat_to_matrix,
    yaw_to_quat,
)
from t2m_core.domain.objects import BoxPart, ObjectKind, object_spec
from t2m_core.domain.state import GeometricState, ObjectPose

EE_MAX_RADIUS = 0.72
"""m: the EE's planar distance from the base must stay below this at the reach and the sweep end.
The Panda's top-down reach at the 0.40 m lift height ends between 0.73 and 0.74 m (measured in
MuJoCo on 1 200 pulls: every pre-pose up to 0.73 m was reached, none from 0.74 m)."""

EE_MIN_RADIUS = TABLE_X_MIN
"""m: the EE must stay at least this far from the base at table height (closer, the arm folds onto
itself; the table's near placement limit)."""

TOOL_CLEARANCE = 0.01
"""m: the swept hook and the swept box must stay this far from bystanders and the rack's legs."""

HAND_CLEARANCE = 0.10
"""m: the EE's straight path must stay this far from the footprint of a bystander (the gripper body
reaches about this far from the EE across its fingers; measured: with 0.06 m it still struck the rack)."""

MAX_FACE_ANGLE = np.pi / 6
"""rad: the largest angle between the head's face normal and the sweep at which the box follows the
head; at steeper angles it slides off the face (the heuristic's θ = π/8 is below it)."""

LANDING_CLEARANCE = 0.005
"""m: at the reach pose the hook must be this far from the target's footprint, or it lands on it."""

HEAD_LANDING_DEPTH = 0.01
"""m: how deep the head's footprint may reach into the target's along the sweep at the reach pose."""

END_MARGIN = 0.03
"""m: how far inside its success region the predicted end of the target must lie."""


@dataclass(frozen=True)
class SweepPrediction:
    """The geometry of one hook sweep, predicted from the start state.

    Attributes:
        hook_reach: the hook's geometry at the reach pose.
        hook_end: the hook's geometry at the sweep end.
        target_start: the target's geometry now.
        target_end: the target's predicted geometry after the sweep.
        target_drift: where it ends if it also slides sideways along the head (Pull: into the crook
            against the handle); ``target_end`` when no drift is predicted.
        ee_path: ``(2, 2)`` xy of the EE at the reach and at the sweep end, metres.
    """

    hook_reach: ObjectGeometry
    hook_end: ObjectGeometry
    target_start: ObjectGeometry
    target_end: ObjectGeometry
    target_drift: ObjectGeometry
    ee_path: np.ndarray


def predict_sweep(
    state: GeometricState,
    target: str,
    hook: str,
    hook_reach: np.ndarray,
    hook_end: np.ndarray,
    hook_yaw: float,
    ee_path: np.ndarray,
    *,
    along_head_normal: bool = False,
    into_crook: bool = False,
) -> SweepPrediction:
    """Predict the target's end pose: it moves with the hook once the head closes the gap to it.

    Args:
        hook_reach, hook_end: ``(3,)`` the hook's origin at the reach and the sweep end, metres.
        hook_yaw: the hook's yaw during the sweep, radians.
        ee_path: ``(2, 2)`` EE xy at the reach and the sweep end.
        along_head_normal: the box slides along the head's normal (Push) instead of following the
            sweep (Pull).
        into_crook: the box may also slide sideways into the crook, up to the handle (Pull).
    """
    quaternion = yaw_to_quat(hook_yaw)
    reach = object_geometry(hook, ObjectPose(hook_reach, quaternion))
    end = object_geometry(hook, ObjectPose(hook_end, quaternion))
    start_pose = state.objects[target]
    target_start = object_geometry(target, start_pose)
    sweep = (hook_end - hook_reach)[:2]
    length = float(np.linalg.norm(sweep))
    direction = sweep / max(length, 1e-12)
    gap = polygon_distance(_head(reach), target_start.footprints[0])
    displacement = max(0.0, length - gap) * direction
    if along_head_normal:
        normal = quat_to_matrix(quaternion)[:2, 0]  # the head's face looks along the hook's x axis
        normal = normal if normal @ direction >= 0.0 else -normal
        displacement = float(displacement @ normal) * normal
    end_position = start_pose.position + np.array([displacement[0], displacement[1], 0.0])
    target_end = object_geometry(target, ObjectPose(end_position, start_pose.quaternion))
    target_drift = target_end
    if into_crook:
        handle = reach.footprints[0]
        across = np.array([-direction[1], direction[0]])
        if (handle.mean(axis=0) - start_pose.position[:2]) @ across < 0.0:
            across = -across
        slide = polygon_distance(handle, target_start.footprints[0]) * across
        target_drift = object_geometry(target, ObjectPose(end_position + np.array([*slide, 0.0]), start_pose.quaternion))
    return SweepPrediction(reach, end, target_start, target_end, target_drift, np.asarray(ee_path, dtype=np.float64))


def penetration(footprint: np.ndarray, region: np.ndarray, direction: np.ndarray, longest: float = 0.5) -> float:
    """How far ``footprint`` reaches into the convex ``region`` along the unit ``direction``: the
    shortest move back against it that separates them (0 when they do not overlap), metres."""
    if not polygons_overlap(footprint, region):
        return 0.0
    low, high = 0.0, longest
    for _ in range(20):  # bisection to 0.5 µm
        middle = 0.5 * (low + high)
        low, high = (middle, high) if polygons_overlap(footprint - middle * direction, region) else (low, middle)
    return high


def reach_failure(prediction: SweepPrediction) -> str | None:
    """``"unreachable"`` when the EE leaves the annulus the arm reaches at table height."""
    radii = np.linalg.norm(prediction.ee_path, axis=1)
    return None if np.all((radii >= EE_MIN_RADIUS) & (radii < EE_MAX_RADIUS)) else "unreachable"


def landing_failure(prediction: SweepPrediction) -> str | None:
    """``"tipped_over"`` when the hook at the reach pose would come down on the target: its handle
    within :data:`LANDING_CLEARANCE` of the target's footprint, or its head more than
    :data:`HEAD_LANDING_DEPTH` into it along the sweep. (The heuristic's r_reach leaves the head
    about 0.01 m from a square-on box; a turned box's corner may reach under it by a few mm, which
    the measured sweeps survive.)"""
    target = prediction.target_start.footprints[0]
    if polygon_distance(prediction.hook_reach.footprints[0], target) < LANDING_CLEARANCE:
        return "tipped_over"
    sweep = (prediction.hook_end.position - prediction.hook_reach.position)[:2]
    direction = sweep / max(float(np.linalg.norm(sweep)), 1e-12)
    if penetration(_head(prediction.hook_reach), target, direction) > HEAD_LANDING_DEPTH:
        return "tipped_over"
    return None


def face_meets_target(prediction: SweepPrediction) -> bool:
    """Whether the head's face, not its corner at the joint, meets the target square enough to carry
    it: the target's extent across the sweep lies within the head's (a corner turns the box and sends
    it sideways) and the face is within :data:`MAX_FACE_ANGLE` of the sweep."""
    sweep = (prediction.hook_end.position - prediction.hook_reach.position)[:2]
    direction = sweep / max(float(np.linalg.norm(sweep)), 1e-12)
    face_normal = quat_to_matrix(prediction.hook_reach.quaternion)[:2, 0]
    if abs(float(face_normal @ direction)) < np.cos(MAX_FACE_ANGLE):
        return False
    across = np.array([-direction[1], direction[0]])
    head = _head(prediction.hook_reach) @ across
    target = prediction.target_start.footprints[0] @ across
    return bool(target.min() >= head.min() and target.max() <= head.max())


def sweep_failure(
    prediction: SweepPrediction,
    *,
    hook_obstacles: Sequence[ObjectGeometry],
    target_obstacles: Sequence[ObjectGeometry],
    hand_obstacles: Sequence[ObjectGeometry],
) -> str | None:
    """``"disturbed"`` when the swept hook or the swept target comes within :data:`TOOL_CLEARANCE` of
    one of its obstacles, or the EE's path within :data:`HAND_CLEARANCE` of a hand obstacle."""
    hook = [_swept(a, b) for a, b in zip(prediction.hook_reach.footprints, prediction.hook_end.footprints, strict=True)]
    target_footprints = (prediction.target_start, prediction.target_end, prediction.target_drift)
    target = [convex_hull_2d(np.concatenate([geometry.footprints[0] for geometry in target_footprints]))]
    for regions, obstacles, clearance in (
        (hook, hook_obstacles, TOOL_CLEARANCE),
        (target, target_obstacles, TOOL_CLEARANCE),
        ([prediction.ee_path], hand_obstacles, HAND_CLEARANCE),
    ):
        for obstacle in obstacles:
            for footprint in obstacle.footprints:
                if any(polygon_distance(region, footprint) < clearance for region in regions):
                    return "disturbed"
    return None


def bystanders(state: GeometricState, arguments: Sequence[str]) -> list[ObjectGeometry]:
    """Geometry of the present objects other than the arguments and the table."""
    return [
        object_geometry(name, pose)
        for name, pose in state.objects.items()
        if name not in arguments and object_spec(name).kind is not ObjectKind.TABLE
    ]


def rack_parts(state: GeometricState, rack: str, names: Sequence[str]) -> list[ObjectGeometry]:
    """The named parts of the rack (``"leg_0"``..., ``"bar_0"``...) as one-part
    :class:`ObjectGeometry` s: the space between the legs is open, so Push needs them separately."""
    pose = state.objects[rack]
    spec = object_spec(rack)
    return [_part_geometry(rack, spec, part, pose) for part in spec.parts() if part.name in names]


def _part_geometry(name: str, spec, part: BoxPart, pose: ObjectPose) -> ObjectGeometry:
    rotation = quat_to_matrix(pose.quaternion)
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=np.float64)
    corners = (np.asarray(part.center) + 0.5 * signs * np.asarray(part.size)) @ rotation.T + pose.position
    aabb = np.stack((corners.min(axis=0), corners.max(axis=0)))
    return ObjectGeometry(name, spec, pose.position, pose.quaternion, corners[None], aabb, (convex_hull_2d(corners[:, :2]),))


def _head(hook: ObjectGeometry) -> np.ndarray:
    """The head's footprint (the hook's second convex part)."""
    return hook.footprints[1]


def _swept(start: np.ndarray, end: np.ndarray) -> np.ndarray:
    """Footprint swept by a convex polygon translated from ``start`` to ``end``: their hull."""
    return convex_hull_2d(np.concatenate((start, end)))
