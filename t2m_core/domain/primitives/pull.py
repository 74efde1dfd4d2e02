"""Pull(obj, hook): drag a box towards the robot with the held hook (docs/guide/primitives.md#waypoint-geometry)."""

from __future__ import annotations

from collections.abc import Sequence
from functools import partial

import numpy as np

from t2m_core.domain.constants import D_PULL, WORKSPACE_RADIUS, WORKSPACE_X_MIN, in_workspace
from t2m_core.domain.geometry import is_upright
from t2m_core.domain.objects import ObjectKind
from t2m_core.domain.primitives.base import (
    SETTLE_TIMEOUT_S,
    MotionKind,
    MotionStep,
    Outcome,
    StepContext,
    lift_position,
    other_objects,
)
from t2m_core.domain.primitives.hook_sweep import HookSweep, hook_clearance, planar_distance
from t2m_core.domain.primitives.sweep_screen import (
    END_MARGIN,
    SweepPrediction,
    Verdicts,
    bystanders,
    face_meets_target,
    obstacle_footprints,
    sweep_disturbs,
)
from t2m_core.domain.state import GeometricState


class Pull(HookSweep):
    """Reach behind ``obj`` with the held ``hook`` and sweep it towards the base.

    Action (physical): ``(r_reach, r_pull, y, θ)`` in the polar frame at the target
    (:mod:`~t2m_core.domain.primitives.hook_sweep`): the hook's origin starts ``r_reach`` along the
    base→target direction (≤ 0: on the robot's side, so the head lies beyond the target), moves
    ``r_pull`` (< 0: towards the base), offset ``y`` sideways, yawed ``θ`` from that direction.

    Args:
        min_distance: how much the target's planar distance from the base must shrink, metres
            (d_Pull; 0.05 as published, the original used 0.01:
            docs/guide/deviations.md#pull-and-push-displacement).
    """

    name = "pull"
    argument_kinds = (frozenset({ObjectKind.BOX}), frozenset({ObjectKind.HOOK}))
    action_low = np.array([-0.2, -0.4, -0.05, -0.5 * np.pi])
    action_high = np.array([0.0, -0.1, 0.05, 0.5 * np.pi])

    def __init__(self, min_distance: float = D_PULL) -> None:
        self.min_distance = min_distance

    def motion(self, state: GeometricState, arguments: Sequence[str], action: np.ndarray) -> tuple[MotionStep, ...]:
        arguments = self.check_arguments(state, arguments)
        poses = self.sweep(state, arguments, action)
        bystanders = other_objects(state, arguments, include_table=False)
        return (
            MotionStep(
                MotionKind.MOVE, "pre_pose", lift_position(poses.reach_position), poses.yaw, disturbance_objects=bystanders
            ),
            # The hook slides over the table on the way down: table contacts are allowed here.
            MotionStep(
                MotionKind.DESCEND,
                "reach",
                poses.reach_position,
                poses.yaw,
                contact_objects=other_objects(state, arguments, include_table=False),
                check=target_upright,
            ),
            MotionStep(
                MotionKind.SWEEP, "pull", poses.end_position, poses.yaw, disturbance_objects=bystanders, soft=True
            ),
            MotionStep(
                MotionKind.LIFT, "post_pose", lift_position(poses.end_position), poses.yaw, disturbance_objects=bystanders
            ),
            MotionStep(MotionKind.SETTLE, "settle", timeout_s=SETTLE_TIMEOUT_S),
        )

    def outcome(self, start_state: GeometricState, end_state: GeometricState, arguments: Sequence[str]) -> Outcome:
        """Success: the target is upright, in the workspace, and more than d_Pull closer to the base."""
        target = arguments[0]
        pose = end_state.objects[target]
        if not is_upright(pose.quaternion):
            return Outcome.failed("not_upright")
        if not in_workspace(pose.position[0], pose.position[1]):
            return Outcome.failed("outside_workspace")
        if planar_distance(end_state, target) >= planar_distance(start_state, target) - self.min_distance:
            return Outcome.failed("not_pulled")
        return Outcome.ok()

    def heuristic_reach(self, arguments: Sequence[str]) -> float:
        """r_reach = −(½·hook_size_x − 2r − ½‖box_size_xy‖): ≈ −0.125 m for a 0.05 m box."""
        half_hook, clearance = hook_clearance(arguments[0], arguments[1])
        return -(half_hook - clearance)

    def screen_sweep(self, state: GeometricState, arguments: Sequence[str], verdicts: Verdicts) -> None:
        """The head's face square on the box; bystanders (the whole rack included) clear of the hook,
        the box (slid into the crook or not) and the hand; the box's predicted end :data:`END_MARGIN`
        inside the workspace and pulled by d_Pull + that margin."""
        verdicts.check("not_pulled", lambda prediction: ~face_meets_target(prediction))
        obstacles = obstacle_footprints(bystanders(state, arguments))
        verdicts.check(
            "disturbed",
            partial(sweep_disturbs, hook_obstacles=obstacles, target_obstacles=obstacles, hand_obstacles=obstacles),
        )
        verdicts.check("outside_workspace", _ends_outside_workspace)
        verdicts.check("not_pulled", self._pulled_too_little)

    def _pulled_too_little(self, prediction: SweepPrediction) -> np.ndarray:
        """``(B,)`` whether the box's predicted end is not d_Pull + :data:`END_MARGIN` closer to the base."""
        start = np.linalg.norm(prediction.target_xy)
        return np.linalg.norm(prediction.target_end_xy, axis=-1) >= start - self.min_distance - END_MARGIN


def _ends_outside_workspace(prediction: SweepPrediction) -> np.ndarray:
    """``(B,)`` whether the box's predicted end is not :data:`END_MARGIN` inside the workspace."""
    end = prediction.target_end_xy
    return (end[:, 0] < WORKSPACE_X_MIN + END_MARGIN) | (np.linalg.norm(end, axis=-1) >= WORKSPACE_RADIUS - END_MARGIN)


def target_upright(context: StepContext) -> str | None:
    """``"tipped_over"`` when the first argument (the swept box) is no longer upright."""
    return None if is_upright(context.state.objects[context.arguments[0]].quaternion) else "tipped_over"
