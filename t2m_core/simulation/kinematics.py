"""Rotation and yaw arithmetic of top-down EE targets, shared by every backend's controller.

EE orientations are top-down with a yaw relative to the home orientation (docs/guide/world.md):
``R = Rz(yaw) · R_home``. Angles in radians.
"""

from __future__ import annotations

import math

import numpy as np

from t2m_core.simulation.robot import Q_HOME


def rotation_z(yaw: float) -> np.ndarray:
    """``(3, 3)`` rotation about world z by ``yaw`` radians."""
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def rotation_error(target: np.ndarray, current: np.ndarray) -> np.ndarray:
    """``(3,)`` world-frame rotation vector (axis·angle, radians) taking ``current`` to ``target`` (both (3, 3))."""
    # scalar arithmetic on a flat list: this runs every control tick, where numpy's per-call
    # overhead on 3-vectors costs more than the arithmetic
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = (target @ current.T).ravel().tolist()
    cos_angle = max(-1.0, min(1.0, (r00 + r11 + r22 - 1.0) / 2.0))
    angle = math.acos(cos_angle)
    sin_angle = math.sin(angle)
    if sin_angle < 1e-6:
        if angle < 1e-6:
            return np.array([0.5 * (r21 - r12), 0.5 * (r02 - r20), 0.5 * (r10 - r01)])
        # near π: axis from the diagonal
        return angle * np.sqrt(np.maximum((np.array([r00, r11, r22]) + 1.0) / 2.0, 0.0))
    scale = angle / (2.0 * sin_angle)
    return np.array([scale * (r21 - r12), scale * (r02 - r20), scale * (r10 - r01)])


def relative_yaw(rotation: np.ndarray, home_rotation: np.ndarray) -> float:
    """Yaw (radians) of a top-down ``(3, 3)`` EE rotation relative to the home orientation."""
    relative = rotation @ home_rotation.T
    return math.atan2(relative[1, 0], relative[0, 0])


def smoothstep(progress):
    """``3p² − 2p³``: a ramp from 0 to 1 without velocity jumps (float or array)."""
    return progress * progress * (3.0 - 2.0 * progress)


def null_target_facing(position: np.ndarray) -> np.ndarray:
    """``(7,)`` null-space posture: q_home with joint 1 turned to face ``position`` (x, y), as the
    original's null-space task."""
    target = Q_HOME.copy()
    target[0] = math.atan2(position[1], position[0])
    return target


def wrist_seeds(null_target: np.ndarray, yaw: float, low: float, high: float) -> list[np.ndarray]:
    """``(7,)`` IK seeds: ``null_target`` with joint 7 at each angle within ``(low, high)`` rad that gives
    the EE ``yaw`` (top-down, the yaw is q1 − q7 relative to home when the other joints are at home).

    Damped least squares turns the wrist the short way round, which runs joint 7 into its limit for
    yaws near ±π although the other way round is within the limits; these seeds start it on each side."""
    base = null_target[0] - yaw + Q_HOME[6]
    seeds = []
    for turns in (-1, 0, 1):
        wrist = base + 2.0 * math.pi * turns
        if low < wrist < high:
            seed = np.array(null_target, dtype=np.float64)
            seed[6] = wrist
            seeds.append(seed)
    return seeds
