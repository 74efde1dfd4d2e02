"""Pick(obj): grasp a box or the hook from above (docs/guide/primitives.md#waypoint-geometry)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from t2m_core.domain.constants import TABLE_Z_MAX, in_workspace
from t2m_core.domain.geometry import object_geometry_memo, quat_yaw, rotate, wrap_angle
from t2m_core.domain.objects import ObjectKind, object_spec
from t2m_core.domain.primitives.base import (
    SETTLE_TIMEOUT_S,
    MotionKind,
    MotionStep,
    Primitive,
    lift_position,
    other_objects,
)
from t2m_core.domain.primitives.fingers import FINGERTIP_BELOW_EE, finger_footprints, fingers_strike_of_states
from t2m_core.domain.state import GeometricState
from t2m_core.simulation.robot import FINGER_OPEN

MOVABLE = frozenset({ObjectKind.BOX, ObjectKind.HOOK})

TABLE_MARGIN = 0.001
"""m: a grasp whose fingertips would end lower than this above the table is predicted to strike it."""


BOX_GRASP_INSET = 0.01
"""m: how far inside a box's faces :meth:`Pick.grasp_bounds` keeps a grasp point. Of 339 grasps of
boxes proposed in the task scenes (held or closed on nothing), 88 of the 89 beside the box closed on
nothing, 14 of 42 within 1 cm inside a face, 5 of 208 farther in
(docs/guide/feasibility.md#grasps-kept-on-the-box)."""


class Pick(Primitive):
    """Grasp ``obj`` at an offset in its own frame.

    Action (physical): ``(x, y, z, θ)``: the grasp point in the object frame (metres) and the
    gripper yaw relative to the object (radians). The grasp position is ``p_obj + R_obj·(x, y, z)``,
    the gripper yaw ``yaw(obj) + θ``; the pre-pose is straight above at the lift height.
    """

    name = "pick"
    argument_kinds = (MOVABLE,)
    action_low = np.array([-0.2, -0.1, -0.05, -0.25 * np.pi])
    action_high = np.array([0.2, 0.1, 0.05, 0.75 * np.pi])

    def grasp_pose(self, state: GeometricState, obj: str, action: np.ndarray) -> tuple[np.ndarray, float]:
        """``((3,) position in metres, yaw in radians)`` of the EE at the grasp, world frame."""
        x, y, z, theta = self.to_physical(action)
        pose = state.objects[obj]
        position = pose.position + rotate(pose.quaternion, np.array([x, y, z]))
        return position, wrap_angle(quat_yaw(pose.quaternion) + theta)

    def in_the_way(self, state: GeometricState, arguments: Sequence[str], physical: np.ndarray) -> np.ndarray:
        """``(B,)`` whether each of ``(B, 4)`` physical grasps is predicted to fail before it closes:
        the object outside the workspace (the precheck refuses every grasp), fingertips at the table,
        or an open finger near a part of a bystander (an object other than the argument and the table)
        that rises above the fingertips, such as the rack's plate beside a box
        (:func:`~t2m_core.domain.primitives.fingers.fingers_strike`). A prediction from the domain's
        geometry, not a result."""
        physical = np.atleast_2d(np.asarray(physical, dtype=np.float64))
        return self.screen_of_states([state], arguments, physical, np.zeros(len(physical), dtype=np.int64))["in_the_way"]

    def screen_of_states(
        self, states: Sequence[GeometricState], arguments: Sequence[str], physical: np.ndarray, state_of: np.ndarray
    ) -> dict[str, np.ndarray]:
        """``{"in_the_way": (B,) bool}``: :meth:`in_the_way` of ``(B, 4)`` physical grasps, grasp b in
        ``states[state_of[b]]``, judged as one batch (a planner's samples, each in its own predicted
        state). The states hold the same objects; an object's geometry is computed once per distinct pose."""
        (obj,) = self.check_arguments(states[0], arguments)
        physical = np.atleast_2d(np.asarray(physical, dtype=np.float64))
        state_of = np.asarray(state_of, dtype=np.int64)
        # the precheck reads the object, not the action
        refused = np.array([self.precheck(state, arguments, physical[0]) is not None for state in states])[state_of]
        positions = np.array([state.objects[obj].position for state in states])[state_of]
        quaternions = np.array([state.objects[obj].quaternion for state in states])[state_of]
        in_the_way, live = refused.copy(), ~refused
        if live.any():
            grasps = positions[live] + rotate(quaternions[live], physical[live, :3])  # (L, 3)
            tips = grasps[:, 2] - FINGERTIP_BELOW_EE
            yaws = quat_yaw(quaternions[live]) + physical[live, 3]
            fingers = finger_footprints(grasps, yaws, FINGER_OPEN)
            struck = fingers_strike_of_states(states, state_of[live], (obj,), fingers, tips, object_geometry_memo())
            in_the_way[live] = struck | (tips < TABLE_Z_MAX + TABLE_MARGIN)
        return {"in_the_way": in_the_way}

    def grasp_bounds(self, arguments: Sequence[str]) -> tuple[np.ndarray, np.ndarray]:
        """``((4,), (4,))`` physical action bounds whose grasp point lies well on the object: for a
        box, x and y at least :data:`BOX_GRASP_INSET` inside its faces; for the hook, the action
        bounds themselves (its pads also hold a bar from beside it)."""
        (obj,) = arguments
        low, high = self.action_low.copy(), self.action_high.copy()
        spec = object_spec(obj)
        if spec.kind is ObjectKind.BOX:
            half = 0.5 * np.asarray(spec.size[:2]) - BOX_GRASP_INSET
            low[:2], high[:2] = np.maximum(low[:2], -half), np.minimum(high[:2], half)
        return low, high

    def precheck(self, state: GeometricState, arguments: Sequence[str], action: np.ndarray) -> str | None:
        (obj,) = self.check_arguments(state, arguments)
        x, y = state.objects[obj].position[:2]
        return None if in_workspace(x, y) else "not_in_workspace"

    def motion(self, state: GeometricState, arguments: Sequence[str], action: np.ndarray) -> tuple[MotionStep, ...]:
        (obj,) = self.check_arguments(state, arguments)
        grasp_position, yaw = self.grasp_pose(state, obj, action)
        pre_position = lift_position(grasp_position)
        bystanders = other_objects(state, arguments, include_table=False)
        return (
            MotionStep(MotionKind.MOVE, "pre_pose", pre_position, yaw, disturbance_objects=bystanders),
            MotionStep(
                MotionKind.DESCEND,
                "grasp_pose",
                grasp_position,
                yaw,
                contact_objects=other_objects(state, arguments, include_table=True),
            ),
            MotionStep(MotionKind.GRASP, "grasp", grasp_object=obj),
            MotionStep(MotionKind.LIFT, "lift", pre_position, yaw, disturbance_objects=bystanders),
            MotionStep(MotionKind.SETTLE, "settle", timeout_s=SETTLE_TIMEOUT_S),
        )

    def heuristic_physical(self, state: GeometricState, arguments: Sequence[str], rng: np.random.Generator) -> np.ndarray:
        """Box: a centred grasp (all zeros). Hook: with probability l/(l + h) a handle grasp at a
        uniform x along it (θ = 0), otherwise a head grasp at a uniform y (θ = π/2)."""
        spec = object_spec(arguments[0])
        if spec.kind is not ObjectKind.HOOK or spec.hook is None:
            return np.zeros(4)
        hook = spec.hook
        handle, head = hook.footprint()
        if rng.random() < hook.handle_length / (hook.handle_length + hook.head_length):
            return np.array([rng.uniform(self.action_low[0], self.action_high[0]), handle.center[1], 0.0, 0.0])
        return np.array([head.center[0], rng.uniform(self.action_low[1], self.action_high[1]), 0.0, 0.5 * np.pi])

    def screened_physical(self, state: GeometricState, arguments: Sequence[str], rng: np.random.Generator) -> np.ndarray:
        """The data-generation grasp: the heuristic's, except that a box with a square footprint is
        grasped across either pair of its faces, θ = 0 or θ = π/2 with equal probability.

        A deviation for data generation only (the reference heuristic stays :meth:`heuristic_physical`,
        θ = 0): beside the rack's plate the θ = 0 fingers hit the plate and only θ ≈ π/2 grasps succeed
        (docs/guide/deviations.md#box-grasps-across-both-face-pairs), and data drawn around θ = 0 never
        shows a model that they do."""
        action = self.heuristic_physical(state, arguments, rng)
        spec = object_spec(arguments[0])
        if spec.kind is ObjectKind.BOX and spec.size[0] == spec.size[1] and rng.random() < 0.5:
            action[3] = 0.5 * np.pi
        return action
