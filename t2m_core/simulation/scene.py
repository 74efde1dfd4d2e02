"""Scene facts every backend builds the same way: contact frictions, the floor, the named cameras.

Objects themselves come from :data:`t2m_core.domain.objects.OBJECTS` (docs/guide/world.md).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

OBJECT_FRICTION = 0.5
"""Lateral friction of boxes and the hook: on the 1.0 table a box slides with 0.5, the coefficient
PyBullet's product rule gave the original."""
TABLE_FRICTION = 1.0
"""Lateral friction of the table and the rack."""
FLOOR_Z = -0.75
"""Metres: a floor far below the table catches objects that fall off (they read as below the table)."""

CAMERAS: dict[str, tuple[tuple[float, float, float], tuple[float, float, float], float]] = {
    # name: (position m, look-at point m, vertical field of view in degrees)
    "front": ((1.5, 0.65, 1.25), (0.33, -0.02, 0.12), 45.0),
    "side": ((0.45, -1.45, 0.85), (0.45, 0.0, 0.08), 45.0),
    "top": ((0.45, 0.0, 1.6), (0.45, 0.0, 0.0), 45.0),
}
"""Named cameras: ``front`` shows the table, the rack and the robot from across the table."""
DEFAULT_CAMERA = "front"


def camera_axes(position: Sequence[float], target: Sequence[float]) -> tuple[np.ndarray, np.ndarray]:
    """``((3,), (3,))`` image right and up axes (world frame) of a camera at ``position`` looking at
    ``target`` with world z up; straight down, image up is world +x."""
    forward = np.asarray(target, float) - np.asarray(position, float)
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    if np.linalg.norm(right) < 1e-6:  # looking straight down: image "up" is world +x
        right = np.array([0.0, -1.0, 0.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    return right, up


def camera_intrinsics(fovy_degrees: float, width: int, height: int) -> np.ndarray:
    """``(3, 3)`` pinhole matrix of a camera with a vertical field of view, at ``width × height`` pixels."""
    focal = 0.5 * height / np.tan(0.5 * np.deg2rad(fovy_degrees))
    return np.array([[focal, 0.0, width / 2], [0.0, focal, height / 2], [0.0, 0.0, 1.0]])


def check_camera(camera: str) -> tuple[tuple[float, float, float], tuple[float, float, float], float]:
    """The ``(position, look-at, fovy)`` of a named camera; ``ValueError`` listing the cameras otherwise."""
    try:
        return CAMERAS[camera]
    except KeyError:
        raise ValueError(f"unknown camera {camera!r}; cameras: {', '.join(CAMERAS)}") from None
