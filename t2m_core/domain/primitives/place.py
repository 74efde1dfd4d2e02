"""Place(obj, target): put the held object down on the table or the rack (docs/guide/primitives.md#waypoint-geometry)."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from t2m_core.domain.constants import (
    MAX_LIFT_HEIGHT,
    TABLE_PLACE_X_RANGE,
    TABLE_Y_MAX,
    TABLE_Y_MIN,
    TABLE_Z_MAX,
    in_workspace,
    workspace_margin,
)
from t2m_core.domain.geometry import (
    clip_segments,
    convex_hull_2d,
    hull_margins,
    inside_margins,
    is_above,
    is_upright,
    object_geometry,
    object_geometry_memo,
    pad_polygons,
    polygon_edges,
    quat_yaw,
    rotate,
    wrap_angle,
    yaw_to_quat,
    yawed_footprints,
    yawed_polygons,
)
from t2m_core.domain.objects import ObjectKind, object_spec
from t2m_core.domain.primitives.base import (
    SETTLE_TIMEOUT_S,
    MotionKind,
    MotionStep,
    Outcome,
    Primitive,
    StepContext,
    lift_position,
    other_objects,
)
from t2m_core.domain.primitives.fingers import (
    FINGERTIP_BELOW_EE,
    finger_footprints,
    fingers_strike_of_states,
    held_opening,
)
from t2m_core.domain.primitives.pick import MOVABLE
from t2m_core.domain.primitives.sweep_screen import (
    CLEARANCE_RANGE,
    TOOL_CLEARANCE,
    bystanders,
    clearance_and_gap,
    obstacle_footprints,
    obstacle_heights,
    pair_gaps,
)
from t2m_core.domain.state import GeometricState, pose_groups

MAX_DROP_DISTANCE = 0.05
"""Before release the held object must be within this closest distance of the target, metres."""

SUPPORTS = frozenset({ObjectKind.TABLE, ObjectKind.RACK})


def place_rectangle(target: str) -> np.ndarray:
    """``(2, 2)`` ``[[x_min, y_min], [x_max, y_max]]`` of the target's placement rectangle in its own
    frame, metres: the rack's top plate, or the table strip x ∈ [0.28, 0.70] (as in the original)."""
    spec = object_spec(target)
    if spec.kind is ObjectKind.TABLE:
        return np.array([[TABLE_PLACE_X_RANGE[0], TABLE_Y_MIN], [TABLE_PLACE_X_RANGE[1], TABLE_Y_MAX]])
    low, high = spec.local_bounds()
    return np.array([low[:2], high[:2]])


def release_poses(
    target: str, position: np.ndarray, quaternion: np.ndarray, physical: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """``((B, 3) positions in metres, (B,) yaws in radians)`` of the EE at the release of ``(B, 4)``
    physical Place actions on ``target`` standing at a ``(3,)`` or ``(B, 3)`` position (metres) with a
    ``(4,)`` or ``(B, 4)`` quaternion (one pose for all actions, or each action's own), world frame."""
    rectangle = place_rectangle(target)
    local_xy = rectangle[0] + (physical[:, :2] + 1.0) / 2.0 * (rectangle[1] - rectangle[0])
    positions = position + rotate(quaternion, np.column_stack((local_xy, physical[:, 2])))
    return positions, wrap_angle(quat_yaw(quaternion) + physical[:, 3])


def carried_poses(
    ee_position: np.ndarray, ee_yaw: float | np.ndarray, held_position: np.ndarray, held_yaw: float | np.ndarray,
    release: np.ndarray, release_yaw: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Where an object held rigidly by the EE is when the EE reaches ``release`` yawed ``release_yaw``:
    ``((..., 3) positions in metres, (...) yaws in radians)``, broadcast over leading axes, from the
    EE's and the object's ``(..., 3)`` positions and yaws now (the EE's relative to home)."""
    ee_yaw = np.asarray(ee_yaw, dtype=np.float64)
    in_hand = rotate(yaw_to_quat(-ee_yaw), np.asarray(held_position, dtype=np.float64) - ee_position)
    return release + rotate(yaw_to_quat(release_yaw), in_hand), release_yaw + (held_yaw - ee_yaw)


def balance_margins(obj: str, positions: np.ndarray, yaws: np.ndarray, mass_centres: np.ndarray, tops: np.ndarray) -> np.ndarray:
    """``(B,)`` how far inside the part of its resting hull that each ``(B, K, 2)`` top holds up
    ``obj``'s ``(B, 2)`` centre of mass lies, set down upright at ``(B, 3)`` positions (metres) and
    ``(B,)`` yaws (radians): :func:`~t2m_core.domain.geometry.hull_margins` of its
    :meth:`~t2m_core.domain.objects.ObjectSpec.resting_segments` clipped to the top. Where the top
    holds up all of them (most samples), the margin is the object's own, computed once."""
    spec = object_spec(obj)
    local = spec.resting_segments()
    segments = yawed_polygons(local, positions, yaws)  # (B, S, 2, 2)
    clipped, held_up = clip_segments(segments, tops)
    whole = np.all(np.abs(clipped - segments) < 1e-12, axis=(-3, -2, -1)) & np.all(held_up, axis=-1)
    own = hull_margins(local.reshape(-1, 2), np.ones(2 * len(local), dtype=bool), spec.centre_of_mass()[:2])
    margins = np.full(len(positions), float(own))
    partial = ~whole
    if partial.any():
        margins[partial] = hull_margins(clipped[partial].reshape(int(partial.sum()), -1, 2), np.repeat(held_up[partial], 2, axis=-1), mass_centres[partial])
    return margins


class Place(Primitive):
    """Release the held ``obj`` above ``target``.

    Action (physical): ``(x, y, z, θ)``: x, y ∈ [−1, 1] a location normalised over the target's
    placement rectangle (:func:`place_rectangle`), z the EE height above the support surface
    (metres; the table's and the rack's origins are their top surfaces), θ the gripper yaw relative
    to the target (radians).
    """

    name = "place"
    argument_kinds = (MOVABLE, SUPPORTS)
    action_low = np.array([-1.0, -1.0, 0.0, -0.25 * np.pi])
    action_high = np.array([1.0, 1.0, 0.1, 0.75 * np.pi])

    def release_pose(self, state: GeometricState, target: str, action: np.ndarray) -> tuple[np.ndarray, float]:
        """``((3,) position in metres, yaw in radians)`` of the EE at the release, world frame."""
        pose = state.objects[target]
        positions, yaws = release_poses(target, pose.position, pose.quaternion, self.to_physical(action)[None])
        return positions[0], float(yaws[0])

    def in_the_way(self, state: GeometricState, arguments: Sequence[str], physical: np.ndarray) -> np.ndarray:
        """``(B,)`` whether each of ``(B, 4)`` physical actions would set the held object down within
        :data:`~t2m_core.domain.primitives.sweep_screen.TOOL_CLEARANCE` of a bystander's footprint
        (an object other than the arguments and the table), the object carried rigidly from its
        pose relative to the EE now to the release pose, or bring the fingers closed on it down on
        a bystander (:func:`~t2m_core.domain.primitives.fingers.fingers_strike`). A prediction from
        the domain's geometry, not a result."""
        physical = np.atleast_2d(np.asarray(physical, dtype=np.float64))
        return self.screen_of_states([state], arguments, physical, np.zeros(len(physical), dtype=np.int64))["in_the_way"]

    screen_predictions: tuple[str, ...] = (
        "in_the_way", "too_high", "clearance", "footprint_gap", "support_gap", "workspace_margin", "support_margin", "balance_margin",
    )
    """The predictions :meth:`screen_of_states` makes."""

    def screen_of_states(
        self, states: Sequence[GeometricState], arguments: Sequence[str], physical: np.ndarray, state_of: np.ndarray
    ) -> dict[str, np.ndarray]:
        """The predictions (:attr:`screen_predictions`) for ``(B, 4)`` physical actions, action b taken
        in ``states[state_of[b]]``, judged as one batch (a planner's samples, each in its own
        predicted state; the states hold the same objects, and an object's geometry is computed
        once per distinct pose), each ``(B,)``: ``"in_the_way"`` (:meth:`in_the_way`), ``"too_high"``
        (the held object's lowest point more than :data:`MAX_DROP_DISTANCE` above the target's
        surface at the release: the descent's check fails it), and six
        margins in metres: ``"clearance"``, how far the held object's footprint at the release
        clears the bystanders beyond :data:`~t2m_core.domain.primitives.sweep_screen.TOOL_CLEARANCE`
        (up to :data:`~t2m_core.domain.primitives.sweep_screen.CLEARANCE_RANGE`; the fingers' strike
        stays a flag); ``"footprint_gap"``, how far that footprint lies from the nearest part of a
        bystander that rises above the held object's lowest point at the release, minus how deep it
        reaches into one where they overlap (within ±``CLEARANCE_RANGE``: the descent brushes a
        bystander a few millimetres deep often enough unseen by the contact checks, 10 ticks apart, and
        pushes it aside by less than a disturbance, while ``clearance`` reads the same for every
        overlap); ``"support_gap"``, how far above the target's surface the held object's lowest
        point is at the release (the object carried rigidly; the descent touching the support
        fails, and the measured placements fail mostly below −1 mm); ``"workspace_margin"``, how far
        inside the workspace the release lies (:func:`~t2m_core.domain.constants.workspace_margin`;
        outside, the precheck fails); and ``"support_margin"``, how far inside the target's top the
        held object's centre of mass lies at the release (:func:`~t2m_core.domain.geometry.inside_margins`;
        beyond the table's edge the object falls, ``below_table``; the hook's lies 8 cm from its
        origin, :meth:`~t2m_core.domain.objects.ObjectSpec.centre_of_mass`); and ``"balance_margin"``,
        how far inside the part of its resting hull that the target's top holds up the centre of mass
        lies (:meth:`~t2m_core.domain.objects.ObjectSpec.resting_segments` clipped to the top,
        :func:`~t2m_core.domain.geometry.hull_margins`; negative: it tips over the edge, as a hook
        whose head overhangs rolls about its handle; ``-inf`` with nothing on the top)."""
        obj, target = self.check_arguments(states[0], arguments)
        physical, state_of = np.asarray(physical, dtype=np.float64), np.asarray(state_of, dtype=np.int64)
        geometry = object_geometry_memo()

        def per_state(value: Callable[[GeometricState], object]) -> np.ndarray:  # one value per state, then per action
            return np.array([value(state) for state in states], dtype=np.float64)[state_of]

        release, release_yaw = release_poses(
            target, per_state(lambda s: s.objects[target].position), per_state(lambda s: s.objects[target].quaternion), physical
        )
        held_geometry = [geometry(obj, state.objects[obj]) for state in states]
        # the fingers stay closed on the held object, which the EE carries rigidly to the release
        fingers = finger_footprints(release, release_yaw, np.array([held_opening(state, obj, geometry) for state in states])[state_of])
        struck = fingers_strike_of_states(states, state_of, arguments, fingers, release[:, 2] - FINGERTIP_BELOW_EE, geometry)
        positions, yaws = carried_poses(
            per_state(lambda s: s.ee_position), per_state(lambda s: quat_yaw(s.ee_quaternion)),
            per_state(lambda s: s.objects[obj].position), per_state(lambda s: quat_yaw(s.objects[obj].quaternion)),
            release, release_yaw,
        )  # the held object's at the release
        # the target's top and the bystanders' footprints, once for each group of states where they stand alike
        first, target_group = pose_groups(states, [name for name in states[0].objects if name != target])
        tops = pad_polygons([convex_hull_2d(np.concatenate(geometry(target, states[i].objects[target]).footprints)) for i in first])
        tops = tops[target_group]
        # the EE's height above the held object's lowest point, and the target's surface
        lowest = np.array([state.ee_position[2] - shape.aabb[0][2] for state, shape in zip(states, held_geometry, strict=True)])
        surface = np.array([state.objects[target].position[2] for state in states])
        bottom = release[:, 2] - lowest[state_of]  # (B,) the held object's lowest point at the release
        first, bystander_group = pose_groups(states, arguments)
        others = [bystanders(states[i], arguments, geometry) for i in first]
        obstacles = [obstacle_footprints(shapes) for shapes in others]  # (N, K_g, 2) each
        if obstacles[0].shape[0] == 0:
            clearance = np.full(len(physical), CLEARANCE_RANGE)
            footprint_gap = np.full(len(physical), CLEARANCE_RANGE)
        else:
            footprints = yawed_footprints(object_spec(obj), positions, yaws)  # (B, P, 4, 2)
            obstacles = pad_polygons(obstacles)[bystander_group[state_of]]  # (B, N, K, 2)
            # one exact test per near pair serves both margins: the signed distance is the plain one apart
            draw, obstacle, signed = pair_gaps(footprints, polygon_edges(footprints), obstacles, TOOL_CLEARANCE + CLEARANCE_RANGE, signed=True)
            part_tops = np.array([obstacle_heights(shapes)[:, 1] for shapes in others])
            rising = part_tops[bystander_group[state_of]][draw, obstacle] > bottom[draw]  # the part rises above the set-down object
            clearance, footprint_gap = clearance_and_gap(len(physical), draw, signed, rising, CLEARANCE_RANGE)
        mass_centres = yawed_polygons(object_spec(obj).centre_of_mass()[None, None, :2], positions, yaws)[:, 0, 0]  # (B, 2)
        balance = balance_margins(obj, positions, yaws, mass_centres, tops[state_of])
        support_gap = bottom - surface[state_of]
        return {
            "in_the_way": struck | (clearance < 0.0),
            "too_high": support_gap > MAX_DROP_DISTANCE,
            "clearance": clearance,
            "footprint_gap": footprint_gap,
            "support_gap": support_gap,
            "workspace_margin": workspace_margin(release[:, 0], release[:, 1]),
            "support_margin": inside_margins(mass_centres, tops[state_of]),
            "balance_margin": balance,
        }

    def precheck(self, state: GeometricState, arguments: Sequence[str], action: np.ndarray) -> str | None:
        obj, target = self.check_arguments(state, arguments)
        if state.held != obj:
            return "not_held"
        position, _ = self.release_pose(state, target, action)
        return None if in_workspace(position[0], position[1]) else "not_in_workspace"

    def motion(self, state: GeometricState, arguments: Sequence[str], action: np.ndarray) -> tuple[MotionStep, ...]:
        obj, target = self.check_arguments(state, arguments)
        release_position, yaw = self.release_pose(state, target, action)
        pre_position = lift_position(release_position)
        bystanders = other_objects(state, arguments, include_table=False)
        # Touching the support while descending fails, so the object is released slightly above it.
        guarded = (target, *other_objects(state, arguments, include_table=True))
        return (
            MotionStep(MotionKind.MOVE, "pre_pose", pre_position, yaw, disturbance_objects=bystanders),
            MotionStep(
                MotionKind.DESCEND, "release_pose", release_position, yaw, contact_objects=guarded, check=_close_to_target
            ),
            MotionStep(MotionKind.RELEASE, "release", disturbance_objects=bystanders),
            MotionStep(MotionKind.LIFT, "retreat", pre_position, yaw, disturbance_objects=bystanders),
            MotionStep(MotionKind.SETTLE, "settle", timeout_s=SETTLE_TIMEOUT_S),
        )

    def outcome(self, start_state: GeometricState, end_state: GeometricState, arguments: Sequence[str]) -> Outcome:
        """Below the table: truncated; not upright or not above the target: failed; else success."""
        obj, target = arguments
        pose = end_state.objects[obj]
        if pose.position[2] < TABLE_Z_MAX:
            return Outcome.failed("below_table")
        if not is_upright(pose.quaternion):
            return Outcome.failed("not_upright")
        if not is_above(object_geometry(obj, pose), object_geometry(target, end_state.objects[target])):
            return Outcome.failed("not_on_target")
        return Outcome.ok()

    def heuristic_physical(self, state: GeometricState, arguments: Sequence[str], rng: np.random.Generator) -> np.ndarray:
        """Uniform, except the release height at which the held object's bottom would touch the
        surface: z = 0.40 − z_obj + size_z/2, clipped to [0, 0.1]."""
        obj = arguments[0]
        action = rng.uniform(self.action_low, self.action_high)
        release_height = MAX_LIFT_HEIGHT - state.objects[obj].position[2] + 0.5 * object_spec(obj).size[2]
        action[2] = np.clip(release_height, self.action_low[2], self.action_high[2])
        return action


def _close_to_target(context: StepContext) -> str | None:
    """Fail with ``"too_high"`` if the held object would drop more than 0.05 m onto the target."""
    obj, target = context.arguments
    return None if context.distance(obj, target) <= MAX_DROP_DISTANCE else "too_high"
