"""Push(obj, hook, rack): sweep a box away from the robot, under the rack (docs/guide/primitives.md#waypoint-geometry)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from functools import partial

import numpy as np

from t2m_core.domain.constants import D_PUSH
from t2m_core.domain.geometry import ObjectGeometry, is_under, object_geometry, pad_polygons, penetration_depths
from t2m_core.domain.objects import ObjectKind
from t2m_core.domain.primitives.base import MotionKind, MotionStep, StepContext, lift_position, other_objects
from t2m_core.domain.primitives.hook_sweep import HookSweep, hook_clearance, planar_distance
from t2m_core.domain.primitives.pull import target_upright
from t2m_core.domain.primitives.sweep_screen import (
    CLEARANCE_RANGE,
    END_MARGIN,
    SweepPrediction,
    Verdicts,
    bystanders,
    face_meets_target,
    obstacle_footprints,
    rack_parts,
    sweep_clearance,
    sweep_disturbs,
    unit,
)
from t2m_core.domain.state import GeometricState, ObjectPose

UNDER_DEPTH = (0.02, 0.12)
"""m: the screened sampler wants the box's predicted footprint this far inside the rack's along the
push (:func:`~t2m_core.domain.geometry.penetration_depths`). Chosen on 370 measured task1
pushes: 86 % of the pushes predicted in this band succeeded; shallower ones stay short of the rack,
deeper ones drive the box or the hook into the far legs and move the rack."""


LEGS = ("leg_0", "leg_1", "leg_2", "leg_3")
"""The rack's parts a pushed box must clear (the space between them is open)."""


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

    def screen_sweep(self, state: GeometricState, arguments: Sequence[str], verdicts: Verdicts) -> None:
        """The head's face (not its corner) on the box; the swept box clear of the rack's legs and of
        bystanders, the swept hook and the hand clear of bystanders; the box pushed by d_Push + a
        margin, and its predicted footprint :data:`UNDER_DEPTH` inside the rack's."""
        verdicts.check("not_under", lambda prediction: ~face_meets_target(prediction))
        rack = arguments[2]
        others = bystanders(state, arguments)
        legs = rack_parts(state, rack, LEGS)
        bystander_footprints = obstacle_footprints(others)
        verdicts.check(
            "disturbed",
            partial(
                sweep_disturbs,
                hook_obstacles=bystander_footprints,
                target_obstacles=obstacle_footprints([*others, *legs]),
                hand_obstacles=bystander_footprints,
            ),
        )
        verdicts.check("not_pushed", self._pushed_too_little)
        rack_footprint = object_geometry(rack, state.objects[rack]).footprints[0]
        verdicts.check("not_under", lambda prediction: _depth_under(prediction, rack_footprint) < UNDER_DEPTH[0])
        verdicts.check("disturbed", lambda prediction: _depth_under(prediction, rack_footprint) > UNDER_DEPTH[1])

    screen_predictions: tuple[str, ...] = (*HookSweep.screen_predictions, "under_depth", "leg_clearance")
    """The predictions :meth:`~t2m_core.domain.primitives.hook_sweep.HookSweep.screen_of_states` makes."""

    def sweep_margins(
        self, states: Sequence[GeometricState], arguments: Sequence[str], prediction: SweepPrediction, state_of: np.ndarray,
        geometry: Callable[[str, ObjectPose], ObjectGeometry],
    ) -> dict[str, np.ndarray]:
        """Two margins of the push, metres: ``"under_depth"``, how far the box's predicted footprint
        reaches into the rack's along the push (the screen wants :data:`UNDER_DEPTH`), and
        ``"leg_clearance"``, how far the swept box clears the rack's legs beyond
        :data:`~t2m_core.domain.primitives.sweep_screen.TOOL_CLEARANCE` (up to
        :data:`~t2m_core.domain.primitives.sweep_screen.CLEARANCE_RANGE`): the rack is an argument,
        so ``clearance`` does not see it, yet driving the box into a leg moves it."""
        rack = arguments[2]
        racks = pad_polygons([geometry(rack, state.objects[rack]).footprints[0] for state in states])[state_of]  # (B, K, 2)
        legs = pad_polygons([obstacle_footprints(rack_parts(state, rack, LEGS)) for state in states])[state_of]  # (B, 4, K, 2)
        none = legs[:, :0]
        leg_clearance = sweep_clearance(prediction, hook_obstacles=none, target_obstacles=legs, hand_obstacles=none, within=CLEARANCE_RANGE)
        return {"under_depth": _depth_under(prediction, racks), "leg_clearance": leg_clearance}

    def _pushed_too_little(self, prediction: SweepPrediction) -> np.ndarray:
        """``(B,)`` whether the box's predicted end is not d_Push + :data:`END_MARGIN` farther from the base."""
        start = np.linalg.norm(prediction.target_xy)
        return np.linalg.norm(prediction.target_end_xy, axis=-1) <= start + self.min_distance + END_MARGIN


def _depth_under(prediction: SweepPrediction, rack_footprint: np.ndarray) -> np.ndarray:
    """``(B,)`` how far the box's predicted footprint reaches into the rack's (``(K, 2)``, or each
    draw's own, ``(B, K, 2)``) along its push, metres."""
    end_footprint = prediction.target_start + prediction.target_shift[:, None]
    return penetration_depths(end_footprint, rack_footprint, unit(prediction.target_shift))


def _pushed_under(context: StepContext, *, start_distance: float, min_distance: float) -> str | None:
    """After the sweep: the target moved outward by more than d_Push and is under the rack."""
    target, _, rack = context.arguments
    if planar_distance(context.state, target) <= start_distance + min_distance:
        return "not_pushed"
    state = context.state
    under = is_under(object_geometry(target, state.objects[target]), object_geometry(rack, state.objects[rack]))
    return None if under else "not_under"
