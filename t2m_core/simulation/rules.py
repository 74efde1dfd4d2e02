"""The control rules every backend applies, in 1/60 s ticks (docs/guide/world.md#time-and-motions).

A motion ends when it *converges* (pose and speed within tolerance) or *stalls* (averaged speed
below a threshold); 600 ticks without either is a control failure. An object is *moving* while any
twist component, averaged with the previous reading, is at least ε_twist. The compliant sweep of
Pull and Push uses the reference's soft gains with a capped force.
"""

from __future__ import annotations

import math

import numpy as np

from t2m_core.domain.constants import EPS_TWIST
from t2m_core.simulation.kinematics import rotation_error

TICKS_PER_SECOND = 60
MOTION_TIMEOUT_TICKS = 600
"""10 s: a motion that neither converges nor stalls by then is ``unreachable``."""
GRIPPER_TIMEOUT_TICKS = 60
"""1 s for the gripper to close or open."""
CONTACT_CHECK_PERIOD = 10
"""Ticks between collision checks during a guarded motion."""

CONVERGED_POSITION = 0.01
"""m; with speed < 0.01 m/s, orientation error < 0.01 rad and angular speed < 0.01 rad/s."""
CONVERGED_SPEED = 0.01
CONVERGED_ORIENTATION = 0.01
CONVERGED_ANGULAR_SPEED = 0.01
STALLED_SPEED = 0.001
"""m/s of the exponentially averaged (factor 0.5) EE speed below which a motion has stalled."""
STALLED_ANGULAR_SPEED = 0.02
"""rad/s, with :data:`STALLED_SPEED`."""
STALLED_SWEEP_SPEED = CONVERGED_SPEED
"""m/s: the stall threshold of a compliant sweep, the slowest speed a converged motion may have (a
documented deviation from the reference's 0.001 m/s). A blocked sweep presses with at most
:data:`SOFT_MAX_FORCE`, less than what slides the 1 kg rack (friction 1.0). In PyBullet, whose
friction is rigid, it then stands still and stalls at once; MuJoCo's friction is soft: a pressed
rack, or a box pressed against it, creeps at 1-10 mm/s for as long as the pressure lasts (measured),
so at 0.001 m/s a blocked sweep ran until the 10 s timeout, shoving the rack along. A sweep still
moving freely is much faster than this until it is within millimetres of its goal, where
convergence ends it."""

JOINT_LIMIT_MARGIN = 0.02
"""Radians kept from the joint limits: an IK target beyond them is a control failure (``unreachable``)."""
IK_POSITION_TOLERANCE = 0.002
"""Metres: an IK solution farther than this from its target means the pose is unreachable."""
IK_ORIENTATION_TOLERANCE = 0.02
"""Radians."""

SOFT_POSITION_GAINS = np.array([49.0, 49.0, 121.0])
"""1/s² (per unit operational-space mass) of the compliant sweep in x, y, z (the reference's soft gains)."""
SOFT_VELOCITY_GAINS = np.array([14.0, 14.0, 22.0])
"""1/s."""
SOFT_ORIENTATION_GAINS = (121.0, 16.0)
"""1/s² and 1/s of the sweep's orientation task."""
SOFT_MAX_FORCE = 6.0
"""N: the most the compliant sweep pushes with, below what slides the 1 kg rack (friction 1.0)."""
SOFT_MAX_TORQUE = 10.0
"""N·m: bound on the sweep's orientation moment (normal sweeps stay below ~3.5 N·m; near a singular
posture the operational-space inertia, and with it the moment, would grow without bound)."""
OPERATIONAL_INERTIA_REGULARISATION = 1e-3
"""Added to J·M⁻¹·Jᵀ (1/kg, 1/(kg·m²)) before inverting it, bounding Λ (≤ 1000) near singular postures."""


def cap_sweep_wrench(wrench: np.ndarray) -> np.ndarray:
    """Scale a ``(6,)`` (force N, moment N·m) sweep wrench in place to at most :data:`SOFT_MAX_FORCE`
    and :data:`SOFT_MAX_TORQUE`: a blocked sweep presses, it does not shove (the rack weighs 1 kg)."""
    force = math.sqrt(wrench[0] * wrench[0] + wrench[1] * wrench[1] + wrench[2] * wrench[2])
    if force > SOFT_MAX_FORCE:
        wrench[:3] *= SOFT_MAX_FORCE / force
    torque = math.sqrt(wrench[3] * wrench[3] + wrench[4] * wrench[4] + wrench[5] * wrench[5])
    if torque > SOFT_MAX_TORQUE:  # Λ grows without bound near a singular posture
        wrench[3:] *= SOFT_MAX_TORQUE / torque
    return wrench


class TwistWatch:
    """Whether objects are moving (any twist component ≥ ε_twist after averaging with the previous
    reading, docs/guide/world.md). Call :meth:`forget` to start a fresh averaging window."""

    def __init__(self) -> None:
        self._previous: np.ndarray | None = None

    def moving(self, twist: np.ndarray) -> np.ndarray:
        """``(N,) bool`` for ``(N, 6)`` twists (m/s and rad/s, any component order)."""
        averaged = twist if self._previous is None else 0.5 * (twist + self._previous)
        self._previous = twist.copy()
        return np.any(np.abs(averaged) >= EPS_TWIST, axis=1)

    def forget(self) -> None:
        self._previous = None


def sweep_acceleration(
    position_target: np.ndarray,
    position: np.ndarray,
    rotation_target: np.ndarray,
    rotation: np.ndarray,
    velocity: np.ndarray,
    out: np.ndarray,
) -> np.ndarray:
    """The compliant sweep's desired EE acceleration ``(6,)`` (linear m/s², angular rad/s²) into ``out``:
    the soft springs and dampers toward ``position_target`` (3,) m and ``rotation_target`` (3, 3) from
    the EE at ``position`` (3,), ``rotation`` (3, 3) moving with ``velocity`` (6,) (linear, angular).
    A backend multiplies it by the operational-space inertia Λ and caps it (:func:`cap_sweep_wrench`)."""
    out[:3] = SOFT_POSITION_GAINS * (position_target - position) - SOFT_VELOCITY_GAINS * velocity[:3]
    stiffness, damping = SOFT_ORIENTATION_GAINS
    out[3:] = stiffness * rotation_error(rotation_target, rotation) - damping * velocity[3:]
    return out
