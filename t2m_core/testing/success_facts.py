"""What a successful primitive must have done to the world, measured independently of the domain.

A backend usually decides success with the domain's own post-conditions
(:meth:`t2m_core.domain.primitives.Primitive.outcome`), so comparing its answer with those again
proves nothing. These checks read only the poses the backend reports and the objects' sizes, and
apply their own plain geometry (written here, deliberately not the domain's tests), with tolerances
loose enough for any physics engine and tight enough to catch a success that did not happen:

- pick: the object is held and lifted off its support;
- place: the object is released, upright, resting on the target (bottom at the target's top) with
  its centre over the target;
- pull: the hook is still held; the box is upright on the table and closer to the robot base;
- push: the hook is still held; the box is farther from the base and overlaps the rack's footprint
  below its top.

The pose helpers (:func:`bottom_z`, :func:`top_z`, :func:`centre_in_support_frame`...) also serve
tests that must not judge a sampler with the predicates it accepted its samples with.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from t2m_core.domain.objects import object_spec

MAX_TILT_COS = 0.98
"""An upright object's z-axis has a world-z component above this (tilt below ≈ 11.5°)."""
REST_TOLERANCE = 0.02
"""Metres between an object's bottom and its support's top for the object to rest on it."""
LIFT_CLEARANCE = 0.10
"""Metres above the table a picked object's bottom must be."""
MIN_SWEEP_DISPLACEMENT = 0.01
"""Metres a pulled or pushed box must move towards or away from the base (the smaller threshold
any source uses; the domain's default is 0.05)."""


def _rotation(quaternion: np.ndarray) -> np.ndarray:
    """``(3, 3)`` rotation matrix of an ``(x, y, z, w)`` quaternion."""
    x, y, z, w = np.asarray(quaternion, dtype=np.float64) / np.linalg.norm(quaternion)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def _corners(name: str, pose: Any) -> np.ndarray:
    """``(8, 3)`` world corners of the object's bounding box."""
    low, high = object_spec(name).local_bounds()
    local = np.array([[(low, high)[i][0], (low, high)[j][1], (low, high)[k][2]] for i in (0, 1) for j in (0, 1) for k in (0, 1)])
    return local @ _rotation(pose.quaternion).T + np.asarray(pose.position)


def world_bounds(name: str, pose: Any) -> tuple[np.ndarray, np.ndarray]:
    """``((3,), (3,))`` world-axis-aligned bounds of the object's rotated bounding box, metres."""
    corners = _corners(name, pose)
    return corners.min(axis=0), corners.max(axis=0)


def bottom_z(name: str, pose: Any) -> float:
    """Lowest world z of the object's bounding box, metres."""
    return float(world_bounds(name, pose)[0][2])


def top_z(name: str, pose: Any) -> float:
    """Highest world z of the object's bounding box, metres."""
    return float(world_bounds(name, pose)[1][2])


def is_upright_pose(pose: Any) -> bool:
    """The object's z-axis points up within ≈ 11.5° (:data:`MAX_TILT_COS`)."""
    return float(_rotation(pose.quaternion)[2, 2]) > MAX_TILT_COS


def planar_distance(pose: Any) -> float:
    """Metres from the robot base (the world z-axis) to the object's origin in the xy plane."""
    return float(np.hypot(pose.position[0], pose.position[1]))


def centre_in_support_frame(name: str, pose: Any, support: str, support_pose: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The object's centre in the support's frame, ``(2,)``, and the support's xy bounds there."""
    local = _rotation(support_pose.quaternion).T @ (np.asarray(pose.position) - np.asarray(support_pose.position))
    low, high = object_spec(support).local_bounds()
    return local[:2], low[:2], high[:2]


def _held(state: Any, name: str) -> list[str]:
    return [] if state.held == name else [f"{name} is not held (held: {state.held!r})"]


def pick_problems(start: Any, end: Any, arguments: Sequence[str]) -> list[str]:
    """Pick(obj): held and lifted."""
    (obj,) = arguments
    problems = _held(end, obj)
    if bottom_z(obj, end.objects[obj]) < LIFT_CLEARANCE:
        problems.append(f"{obj}'s bottom is {bottom_z(obj, end.objects[obj]):.3f} m high, not lifted")
    return problems


def place_problems(start: Any, end: Any, arguments: Sequence[str]) -> list[str]:
    """Place(obj, target): released, upright, resting on the target with its centre over it."""
    obj, target = arguments
    pose, target_pose = end.objects[obj], end.objects[target]
    problems = [] if end.held != obj else [f"{obj} is still held"]
    if not is_upright_pose(pose):
        problems.append(f"{obj} is not upright")
    gap = bottom_z(obj, pose) - top_z(target, target_pose)
    if abs(gap) > REST_TOLERANCE:
        problems.append(f"{obj}'s bottom is {gap:+.3f} m from {target}'s top, not resting on it")
    centre, low, high = centre_in_support_frame(obj, pose, target, target_pose)
    if np.any(centre < low) or np.any(centre > high):
        problems.append(f"{obj}'s centre {np.round(centre, 3)} is not over {target} ({np.round(low, 3)}..{np.round(high, 3)})")
    return problems


def pull_problems(start: Any, end: Any, arguments: Sequence[str]) -> list[str]:
    """Pull(box, hook): hook held; box upright on the table and closer to the base."""
    box, hook = arguments
    pose = end.objects[box]
    problems = _held(end, hook)
    if not is_upright_pose(pose):
        problems.append(f"{box} is not upright")
    if abs(bottom_z(box, pose)) > REST_TOLERANCE:
        problems.append(f"{box}'s bottom is {bottom_z(box, pose):+.3f} m from the table top, not resting on it")
    moved = planar_distance(start.objects[box]) - planar_distance(pose)
    if moved < MIN_SWEEP_DISPLACEMENT:
        problems.append(f"{box} came {moved:.3f} m closer to the base, not pulled")
    return problems


def push_problems(start: Any, end: Any, arguments: Sequence[str]) -> list[str]:
    """Push(box, hook, rack): hook held; box farther from the base, under the rack's top, overlapping it."""
    box, hook, rack = arguments
    pose, rack_pose = end.objects[box], end.objects[rack]
    problems = _held(end, hook)
    moved = planar_distance(pose) - planar_distance(start.objects[box])
    if moved < MIN_SWEEP_DISPLACEMENT:
        problems.append(f"{box} moved {moved:.3f} m away from the base, not pushed")
    if top_z(box, pose) >= top_z(rack, rack_pose):
        problems.append(f"{box}'s top is not below {rack}'s top")
    reach = 0.5 * float(np.hypot(*object_spec(box).size[:2]))  # the box's footprint may overlap the edge
    centre, low, high = centre_in_support_frame(box, pose, rack, rack_pose)
    if np.any(centre < low - reach) or np.any(centre > high + reach):
        problems.append(f"{box}'s footprint does not overlap {rack}'s")
    return problems


SUCCESS_FACTS = {"pick": pick_problems, "place": place_problems, "pull": pull_problems, "push": push_problems}
"""Primitive name -> ``problems(start_state, end_state, arguments)``; empty when the success is real."""


def success_problems(primitive: str, start: Any, end: Any, arguments: Sequence[str]) -> list[str]:
    """Why the poses of ``end`` contradict a reported success of ``primitive`` (empty: they agree)."""
    check = SUCCESS_FACTS.get(primitive)
    return [] if check is None else check(start, end, tuple(arguments))
