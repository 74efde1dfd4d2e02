"""The Pull and Push screen as it was judged one draw at a time, in scalar geometry: the reference the
batched screen (``HookSweep.screen_draws``) must agree with. Test-only; do not extend it."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from t2m_core.domain.constants import D_PULL, D_PUSH, WORKSPACE_RADIUS, WORKSPACE_X_MIN
from t2m_core.domain.geometry import (
    convex_hull_2d,
    object_geometry,
    polygon_distance,
    polygons_overlap,
    quat_to_matrix,
    yaw_to_quat,
)
from t2m_core.domain.primitives.hook_sweep import sweep_poses
from t2m_core.domain.primitives.push import UNDER_DEPTH
from t2m_core.domain.primitives.sweep_screen import (
    EE_MAX_RADIUS,
    EE_MIN_RADIUS,
    END_MARGIN,
    HAND_CLEARANCE,
    HEAD_LANDING_DEPTH,
    LANDING_CLEARANCE,
    MAX_FACE_ANGLE,
    TOOL_CLEARANCE,
    bystanders,
    rack_parts,
)
from t2m_core.domain.state import GeometricState, ObjectPose


def reference_screen(name: str, state: GeometricState, arguments: Sequence[str], physical: np.ndarray) -> str | None:
    """The predicted failure reason of one physical Pull (``name="pull"``) or Push action, or ``None``
    (the hook held and the target in front of the base are assumed)."""
    target, hook = arguments[0], arguments[1]
    if state.held != hook:
        return "not_held"
    if state.objects[target].position[0] < 0.0:
        return "target_behind_robot"
    poses = sweep_poses(state, target, hook, *physical)
    quaternion = yaw_to_quat(poses.hook_yaw)
    reach = object_geometry(hook, ObjectPose(poses.hook_reach, quaternion))
    end = object_geometry(hook, ObjectPose(poses.hook_end, quaternion))
    start_pose = state.objects[target]
    start = object_geometry(target, start_pose)
    box = start.footprints[0]
    sweep = (poses.hook_end - poses.hook_reach)[:2]
    direction = sweep / max(float(np.linalg.norm(sweep)), 1e-12)
    displacement = max(0.0, float(np.linalg.norm(sweep)) - polygon_distance(reach.footprints[1], box)) * direction
    pushing = name == "push"
    if pushing:
        normal = quat_to_matrix(quaternion)[:2, 0]
        normal = normal if normal @ direction >= 0.0 else -normal
        displacement = float(displacement @ normal) * normal
    end_position = start_pose.position + np.array([*displacement, 0.0])
    box_end = object_geometry(target, ObjectPose(end_position, start_pose.quaternion))
    box_drift = box_end
    if not pushing:
        across = np.array([-direction[1], direction[0]])
        if (reach.footprints[0].mean(axis=0) - start_pose.position[:2]) @ across < 0.0:
            across = -across
        slide = polygon_distance(reach.footprints[0], box) * across
        box_drift = object_geometry(target, ObjectPose(end_position + np.array([*slide, 0.0]), start_pose.quaternion))
    ee_path = np.stack((poses.reach_position[:2], poses.end_position[:2]))

    radii = np.linalg.norm(ee_path, axis=1)
    if not np.all((radii >= EE_MIN_RADIUS) & (radii < EE_MAX_RADIUS)):
        return "unreachable"
    if polygon_distance(reach.footprints[0], box) < LANDING_CLEARANCE:
        return "tipped_over"
    if _penetration(reach.footprints[1], box, direction) > HEAD_LANDING_DEPTH:
        return "tipped_over"
    face_normal = quat_to_matrix(quaternion)[:2, 0]
    across = np.array([-direction[1], direction[0]])
    head, target_across = reach.footprints[1] @ across, box @ across
    square = abs(float(face_normal @ direction)) >= np.cos(MAX_FACE_ANGLE)
    if not (square and target_across.min() >= head.min() and target_across.max() <= head.max()):
        return "not_under" if pushing else "not_pulled"
    others = bystanders(state, arguments)
    legs = rack_parts(state, arguments[2], ("leg_0", "leg_1", "leg_2", "leg_3")) if pushing else []
    hook_regions = [convex_hull_2d(np.concatenate(pair)) for pair in zip(reach.footprints, end.footprints, strict=True)]
    box_region = convex_hull_2d(np.concatenate([g.footprints[0] for g in (start, box_end, box_drift)]))
    for regions, obstacles, clearance in (
        (hook_regions, others, TOOL_CLEARANCE),
        ([box_region], [*others, *legs], TOOL_CLEARANCE),
        ([ee_path], others, HAND_CLEARANCE),
    ):
        for obstacle in obstacles:
            for footprint in obstacle.footprints:
                if any(polygon_distance(region, footprint) < clearance for region in regions):
                    return "disturbed"
    start_xy, end_xy = start_pose.position[:2], end_position[:2]
    if not pushing:
        if end_xy[0] < WORKSPACE_X_MIN + END_MARGIN or np.linalg.norm(end_xy) >= WORKSPACE_RADIUS - END_MARGIN:
            return "outside_workspace"
        if np.linalg.norm(end_xy) >= np.linalg.norm(start_xy) - D_PULL - END_MARGIN:
            return "not_pulled"
        return None
    if np.linalg.norm(end_xy) <= np.linalg.norm(start_xy) + D_PUSH + END_MARGIN:
        return "not_pushed"
    push_direction = displacement / max(float(np.linalg.norm(displacement)), 1e-12)
    rack = arguments[2]
    rack_footprint = object_geometry(rack, state.objects[rack]).footprints[0]
    depth = _penetration(box_end.footprints[0], rack_footprint, push_direction)
    if depth < UNDER_DEPTH[0]:
        return "not_under"
    return "disturbed" if depth > UNDER_DEPTH[1] else None


def _penetration(footprint: np.ndarray, region: np.ndarray, direction: np.ndarray) -> float:
    """How far ``footprint`` reaches into ``region`` along ``direction``, by bisection to 0.5 µm."""
    if not polygons_overlap(footprint, region):
        return 0.0
    low, high = 0.0, 0.5
    for _ in range(20):
        middle = 0.5 * (low + high)
        low, high = (middle, high) if polygons_overlap(footprint - middle * direction, region) else (low, middle)
    return high
