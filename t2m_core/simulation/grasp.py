"""The grasp validity test (docs/guide/world.md#grasping), on contacts a backend reports.

A grasp holds when *both* finger pads touch the object, every pad contact's normal is within about
11° of the pad's inward normal (dot product ≥ 0.98), and every contact lies on the pad's inner side.
A pad's inward normal is −y of the hand frame for the left pad and +y for the right one.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from t2m_core.simulation.robot import PAD_HALF

NORMAL_ALIGNMENT = 0.98
"""Minimum dot product between a contact normal and the pad's inward normal."""
CLOSED_FINGER = 0.001
"""Finger position (m) below which the gripper closed on nothing."""
INNER_SIDE_TOLERANCE = 0.003
"""Metres: a contact counts as on the inner side when it lies at most this far behind the pad's inner face."""


def pad_grips(inward: np.ndarray, pad_center: np.ndarray, contacts: Iterable[tuple[np.ndarray, np.ndarray]]) -> bool:
    """Whether one pad grips validly: it touches, and every contact ``(normal (3,) pointing from the
    pad into the object, point (3,) m)`` is aligned with the pad's ``inward`` (3,) unit normal and lies
    on its inner side (the pad's centre at ``pad_center`` (3,) m)."""
    touched = False
    for normal, point in contacts:
        if float(np.dot(normal, inward)) < NORMAL_ALIGNMENT:
            return False
        # inner side: the contact point is no deeper than the pad's inner face, measured inward
        depth = float(np.dot(point - pad_center, inward))
        if depth < PAD_HALF[1] - INNER_SIDE_TOLERANCE:
            return False
        touched = True
    return touched
