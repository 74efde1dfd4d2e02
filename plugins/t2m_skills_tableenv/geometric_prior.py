"""The primitives' own geometry as a prior for the dynamics (docs/guide/skills.md#geometric-prior).

Each primitive commands poses that the domain computes exactly from the state and the action: the
grasp and the lift of Pick, the release pose of Place, the hook's reach and sweep of Pull and Push.
:func:`prior_next_rows` predicts the next state from those poses alone:

- **pick(obj)**: the EE ends above the grasp point at the lift height, yawed ``yaw(obj) + θ``; the
  object rises with it, a box centred between the fingers (which close along the EE's y axis).
- **place(obj, target)**: the object is carried rigidly with the EE from its pose in the hand now to
  the release pose and comes to rest upright on the support's top surface; the EE ends above the
  release point at the lift height.
- **pull(obj, hook)** / **push(obj, hook, rack)**: the hook follows the sweep and is lifted (Pull: at
  the sweep's end; Push: back at the reach); the box moves with the head once the head closes the
  gap to it (:func:`~t2m_core.domain.primitives.sweep_screen.target_shifts`), keeping its yaw.
- every other object stays where it is.

It knows no physics: what happens when a box is released, slides or turns against the hook is left
to the learned network that corrects it (:class:`~t2m_skills_tableenv.prior_dynamics.PriorDynamics`).
Rows are raw (un-normalised) and argument-first: row 0 the EE, then the skill's arguments in order.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from t2m_core.domain.constants import MAX_LIFT_HEIGHT
from t2m_core.domain.geometry import axis_angle_to_quat, quat_yaw, rotate, wrap_angle, yaw_to_quat, yawed_footprints, yawed_polygons
from t2m_core.domain.objects import object_spec
from t2m_core.domain.primitives import PRIMITIVES
from t2m_core.domain.primitives.hook_sweep import batched_sweep_poses
from t2m_core.domain.primitives.place import carried_poses, place_rectangle
from t2m_core.domain.primitives.sweep_screen import HEAD, target_shifts

HOOK = "hook"
_HOOK_FEATURE = 9
"""Index of the head length, the first hook feature: non-zero only in the hook's row."""
_ZERO = 1e-5
"""Raw features below this are zero (rows pass through normalisation and back)."""
_CORNER_SIGNS = np.array([(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)])
_TABLE_RECTANGLE = place_rectangle("table")


def prior_next_rows(skill: str, rows: np.ndarray, actions: np.ndarray) -> np.ndarray:
    """The next raw argument-first rows ``(B, 8, 12)`` the primitive's geometry predicts.

    Args:
        skill: pick, place, pull or push.
        rows: ``(B, 8, 12)`` raw rows before the skill, argument-first (EE, arguments, others).
        actions: ``(B, 4)`` normalised actions in [−1, 1].

    Raises:
        KeyError: a skill without a prior.
    """
    rows = np.asarray(rows, dtype=np.float64)
    physical = PRIMITIVES[skill].to_physical(np.asarray(actions, dtype=np.float64))
    return _PRIORS[skill](rows, physical)


def _pick(rows: np.ndarray, physical: np.ndarray) -> np.ndarray:
    following = rows.copy()
    obj = rows[:, 1]
    grasp = obj[:, :3] + rotate(axis_angle_to_quat(obj[:, 3:6]), physical[:, :3])
    yaw = _yaw(obj) + physical[:, 3]
    _set_pose(following[:, 0], _at_lift_height(grasp), yaw)
    following[:, 1, 2] += MAX_LIFT_HEIGHT - grasp[:, 2]
    # The closing fingers (either side of the EE along its y axis) centre a box between them.
    box = obj[:, _HOOK_FEATURE] <= _ZERO
    in_hand = rotate(yaw_to_quat(-yaw), obj[:, :3] - grasp)
    centred = grasp + rotate(yaw_to_quat(yaw), in_hand * np.array([1.0, 0.0, 1.0]))
    following[box, 1, :2] = centred[box, :2]
    return following


def _place(rows: np.ndarray, physical: np.ndarray) -> np.ndarray:
    following = rows.copy()
    ee, obj, target = rows[:, 0], rows[:, 1], rows[:, 2]
    is_table = np.all(np.abs(target) < _ZERO, axis=-1)
    half_size = 0.5 * target[:, 6:8]
    low = np.where(is_table[:, None], _TABLE_RECTANGLE[0], -half_size)
    high = np.where(is_table[:, None], _TABLE_RECTANGLE[1], half_size)
    local_xy = low + (physical[:, :2] + 1.0) / 2.0 * (high - low)
    target_yaw = _yaw(target)
    release = target[:, :3] + rotate(yaw_to_quat(target_yaw), np.column_stack((local_xy, physical[:, 2])))
    release_yaw = target_yaw + physical[:, 3]
    carried, carried_yaw = carried_poses(ee[:, :3], _yaw(ee), obj[:, :3], _yaw(obj), release, release_yaw)
    carried[:, 2] = target[:, 2] + _half_height(obj)
    _set_pose(following[:, 1], carried, carried_yaw)
    _set_pose(following[:, 0], _at_lift_height(release), release_yaw)
    return following


def _sweep(rows: np.ndarray, physical: np.ndarray, *, push: bool) -> np.ndarray:
    following = rows.copy()
    ee, obj, hook = rows[:, 0], rows[:, 1], rows[:, 2]
    poses = batched_sweep_poses(
        obj[:, :2], hook[:, :3], axis_angle_to_quat(hook[:, 3:6]), ee[:, :3], axis_angle_to_quat(ee[:, 3:6]), *physical.T
    )
    head = yawed_footprints(object_spec(HOOK), poses.hook_reach, poses.hook_yaw)[:, HEAD]
    box = _box_footprints(obj)
    shift = target_shifts(head, box, (poses.hook_end - poses.hook_reach)[:, :2], poses.hook_yaw, along_head_normal=push)
    following[:, 1, :2] += shift
    ee_end, hook_end = (poses.reach_position, poses.hook_reach) if push else (poses.end_position, poses.hook_end)
    lift = MAX_LIFT_HEIGHT - ee_end[:, 2]
    _set_pose(following[:, 0], _at_lift_height(ee_end), poses.yaw)
    _set_pose(following[:, 2], hook_end + np.column_stack((np.zeros((len(lift), 2)), lift)), poses.hook_yaw)
    return following


def _box_footprints(rows: np.ndarray) -> np.ndarray:
    """``(B, 4, 2)`` counter-clockwise xy corners of upright boxes given by their raw rows."""
    corners = 0.5 * _CORNER_SIGNS[None] * rows[:, None, 6:8]
    return yawed_polygons(corners[:, None], rows[:, :2], _yaw(rows))[:, 0]


def _half_height(rows: np.ndarray) -> np.ndarray:
    """``(B,)`` half the height of the objects in raw ``rows`` (the hook's from its spec), metres."""
    return np.where(rows[:, _HOOK_FEATURE] > _ZERO, 0.5 * object_spec(HOOK).size[2], 0.5 * rows[:, 8])


def _yaw(rows: np.ndarray) -> np.ndarray:
    return np.asarray(quat_yaw(axis_angle_to_quat(rows[:, 3:6])))


def _at_lift_height(positions: np.ndarray) -> np.ndarray:
    return np.column_stack((positions[:, :2], np.full(len(positions), MAX_LIFT_HEIGHT)))


def _set_pose(rows: np.ndarray, positions: np.ndarray, yaws: np.ndarray) -> None:
    """Write upright poses (position, axis-angle ``(0, 0, yaw)``) into ``(B, 12)`` raw rows in place."""
    rows[:, :3] = positions
    rows[:, 3:5] = 0.0
    rows[:, 5] = wrap_angle(yaws)


_PRIORS: dict[str, Callable[[np.ndarray, np.ndarray], np.ndarray]] = {
    "pick": _pick,
    "place": _place,
    "pull": lambda rows, physical: _sweep(rows, physical, push=False),
    "push": lambda rows, physical: _sweep(rows, physical, push=True),
}
PRIOR_SKILLS: tuple[str, ...] = tuple(_PRIORS)
"""The skills :func:`prior_next_rows` knows."""
