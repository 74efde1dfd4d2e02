"""Push(obj, hook, rack): sweep a box away from the robot, under the rack (docs/guide/primitives.md#waypoint-geometry)."""

from __future__ import annotations

from collections.abc import Sequence
from functools import partial

import numpy as np

from t2m_core.domain.constants import D_PUSH
from t2m_core.domain.geometry import is_under, object_geometry
from t2m_core.domain.objects import ObjectKind
from t2m_core.domain.primitives.base import MotionKind, MotionStep, StepContext, lift_position, other_objects
from t2m_core.domain.primitives.hook_sweep import HookSweep, hook_clearance, planar_distance
from t2m_core.domain.primitives.pull import target_upright
from t2m_core.domain.primitives.sweep_screen import (
    END_MARGIN,
    SweepPrediction,
    bystanders,
    face_meets_target,
    penetration,
    rack_parts,
    sweep_failure,
)
from t2m_core.domain.state import GeometricState

UNDER_DEPTH = (0.02, 0.12)
"""m: the screened sampler wants the box's predicted footprint this far inside the rack's along the
push (:func:`~t2m_core.domain.primitives.sweep_screen.penetration`). Chosen on 370 measured task1
pushes: 86 % of the pushes predicted in this band succeeded; shallower ones stay short of the rack,
deeper ones drive the box or the hook into the far legs and move the rack."""


class Push(HookSweep):
    """Reach in front of ``obj`` with the held ``hook`` and sweep it outward, under ``rack``.

    Action (physical): ``(r_reach, r_push, y, θ)`` in the polar frame at the target: the hook starts
    ``r_reach`` (negative: on the robot's side) from the target, sweeps ``r_push`` outward, offset
    ``y`` sideways, yawed ``θ``. Every test is mid-sequence (a control failure); like the original
    there is no final settle.

    Args:
        min_distance: how much the target's planar distance from the base must grow, metres
            (d_Push; 0.05 as published, the original used 0.01:
            docs/guide/deviations.md#pull-and-push-displacement).
    """

    name = "push"
    argument_kinds = (frozenset({ObjectKind.BOX}), frozenset({ObjectKind.HOOK}), frozenset({ObjectKind.RACK}))
    action_low = np.array([-0.4, 0.1, -0.05, -0.5 * np.pi])
    action_high = np.array([-0.2, 0.4, 0.05, 0.5 * np.pi])

    def __init__(self, min_distance: float = D_PUSH) -> None:
        self.min_distance = min_distance

    def motion(self, state: GeometricState, arguments: Sequence[str], action: np.ndarray) -> tuple[MotionStep, ...]:
        target, _, rack = arguments = self.check_arguments(state, arguments)
        poses = self.sweep(state, arguments, action)
        pre_position = lift_position(poses.reach_position)
        # The rack is an argument, yet knocking it over is still a failure.
        watched = (rack, *other_objects(state, arguments, include_table=False))
        guarded = other_objects(state, arguments, include_table=True)
        pushed_under = partial(_pushed_under, start_distance=planar_distance(state, target), min_distance=self.min_distance)
        return (
            MotionStep(MotionKind.MOVE, "pre_pose", pre_position, poses.yaw, disturbance_objects=watched),
            MotionStep(
                MotionKind.DESCEND, "reach", poses.reach_position, poses.yaw, contact_objects=guarded, check=target_upright
            ),
            MotionStep(
                MotionKind.SWEEP,
                "push",
                poses.end_position,
                poses.yaw,
                disturbance_objects=watched,
                soft=True,
                check=pushed_under,
            ),
            MotionStep(
                MotionKind.DESCEND,
                "withdraw",
                poses.reach_position,
                poses.yaw,
                contact_objects=guarded,
                disturbance_objects=watched,
                check=target_upright,
            ),
            MotionStep(MotionKind.LIFT, "post_pose", pre_position, poses.yaw, disturbance_objects=watched),
        )

    deflects_target = True

    def heuristic_reach(self, arguments: Sequence[str]) -> float:
        """r_reach = −½·hook_size_x − 2r − ½‖box_size_xy‖: ≈ −0.275 m for a 0.05 m box."""
        half_hook, clearance = hook_clearance(arguments[0], arguments[1])
        return -half_hook - clearance

    def screen_sweep(self, state: GeometricState, arguments: Sequence[str], prediction: SweepPrediction) -> str | None:
        """The head's face (not its corner) on the box; the swept box clear of the rack's legs and of
        bystanders, the swept hook and the hand clear of bystanders; the box's predicted footprint
        :data:`UNDER_DEPTH` inside the rack's, and the box pushed by d_Push + a margin."""
        if not face_meets_target(prediction):
            return "not_under"
        target, _, rack = arguments
        others = bystanders(state, arguments)
        legs = rack_parts(state, rack, ("leg_0", "leg_1", "leg_2", "leg_3"))
        reason = sweep_failure(prediction, hook_obstacles=others, target_obstacles=[*others, *legs], hand_obstacles=others)
        if reason is not None:
            return reason
        start, end = prediction.target_start.position, prediction.target_end.position
        if np.linalg.norm(end[:2]) <= np.linalg.norm(start[:2]) + self.min_distance + END_MARGIN:
            return "not_pushed"
        direction = (end - start)[:2] / max(float(np.linalg.norm((end - start)[:2])), 1e-12)
        rack_footprint = object_geometry(rack, state.objects[rack]).footprints[0]
        depth = penetration(prediction.target_end.footprints[0], rack_footprint, direction)
        if depth < UNDER_DEPTH[0]:
            return "not_under"
        return "disturbed" if depth > UNDER_DEPTH[1] else None


def _pushed_under(context: StepContext, *, start_distance: float, min_distance: float) -> str | None:
    """After the sweep: the target moved outward by more than d_Push and is under the rack."""
    target, _, rack = context.arguments
    if planar_distance(context.state, target) <= start_distance + min_distance:
        return "not_pushed"
    state = context.state
    under = is_under(object_geometry(target, state.objects[target]), object_geometry(rack, state.objects[rack]))
    return None if under else "not_under"
