"""The Franka Panda as the TableEnv world mounts it, the same in every backend (docs/guide/simulators.md).

Both backends load the Panda URDF that ships with ``pybullet_data`` and patch it the same way:

* the EE operational point 0.251 m from the link-7 frame (the original's Robotiq 2F-85), between the
  finger pads, 8 mm above the tips;
* each stock finger carries a 0.04 m longer pad (the stock fingers cannot grasp the 0.118 m box at
  its centre without the palm striking its top) and a box standing in for the rest of the finger;
* the hand mounted without the Franka's −45° twist, so that at q_home the jaw closes along world y;
* links 1–4 collide with nothing (they never reach the objects at the 0.40 m lift height), the base
  only with objects, the robot never with itself;
* the URDF's placeholder inertias (0.1 kg·m² everywhere) replaced by solid-cylinder estimates.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

Q_HOME = np.array([0.0, -0.5, 0.0, -2.28, 0.0, 1.78, 0.0])
"""(7,) home joint configuration in radians (docs/guide/world.md#the-robot)."""

EE_OFFSET_FROM_LINK7 = 0.251
"""Metres from the link-7 frame to the EE operational point along its z axis."""
FLANGE_TO_HAND = 0.107
"""Metres from link 7 to the hand frame (the Panda flange)."""
EE_IN_HAND = EE_OFFSET_FROM_LINK7 - FLANGE_TO_HAND
"""Metres from the hand frame to the EE point between the pads (0.144)."""

FINGER_EXTENSION = 0.04
"""Metres added to each stock finger by its long pad."""
FINGER_OPEN = 0.04
"""Finger joint position (m) of a fully open gripper (80 mm jaw); 0 is fully closed."""
FINGER_ORIGIN_IN_HAND = 0.0584
"""Metres from the hand frame to the finger joints (URDF)."""
STOCK_FINGER_LENGTH = 0.0538
"""Metres: length of the stock finger mesh along the hand's z."""
PAD_HALF = (0.0105, 0.005, 0.032)
"""Half sizes (m) of a finger pad box: finger width, thickness, length along the finger."""
PAD_CENTER_Z = STOCK_FINGER_LENGTH + FINGER_EXTENSION - PAD_HALF[2]
"""Metres from the finger joint to a pad's centre along the hand's z."""
FINGER_BODY_HALF = (0.0105, 0.0092, 0.027)
"""Half sizes (m) of the box that stands in for the rest of a finger (its stock mesh does not collide)."""
FINGER_BODY_CENTER = (0.0, 0.0172, 0.027)
"""Centre (m) of that box in the left finger's frame (the right finger's is mirrored in y)."""
PAD_FRICTION = 1.0

ARM_TORQUE_LIMITS = (300.0, 300.0, 300.0, 300.0, 60.0, 60.0, 60.0)
"""(7,) N·m the joint servos may apply."""
GRIPPER_KP, GRIPPER_KV = 400.0, 40.0
"""Finger servo gains, N/m and N·s/m (the reference's gripper gains)."""
GRIPPER_FORCE = 70.0
"""Newtons: the Franka hand's continuous grip force."""

ARM_JOINTS = tuple(f"panda_joint{i}" for i in range(1, 8))
FINGER_JOINTS = ("panda_finger_joint1", "panda_finger_joint2")
BASE_LINK = "panda_link0"
HAND_LINK = "panda_hand"
FINGER_LINKS = ("panda_leftfinger", "panda_rightfinger")
PAD_NAMES = ("left_pad", "right_pad")
UNCOLLIDING_LINKS = ("panda_link1", "panda_link2", "panda_link3", "panda_link4")
"""Links that never reach the objects at the lift height: they collide with nothing."""
VISUAL_FROM_COLLISION = ("panda_link5", "panda_link6")
"""Links whose visual .obj files lack texture coordinates; their collision meshes are drawn instead."""


def placeholder_inertia(mass: float, radius: float = 0.06, length: float = 0.15) -> list[float]:
    """Diagonal inertia (kg·m²) of a solid cylinder of ``mass`` kg, ``radius`` and ``length`` m: the
    stand-in for a link's placeholder inertia (fingers use ``radius=0.02``)."""
    lateral = mass * (3 * radius**2 + length**2) / 12
    return [lateral, lateral, mass * radius**2 / 2]


def panda_urdf_dir() -> Path:
    """Directory of pybullet_data's Franka Panda (URDF and meshes); raises with the fix if missing."""
    try:
        import pybullet_data
    except ImportError as error:  # pragma: no cover - pybullet is a pinned dependency
        raise RuntimeError("pybullet_data is needed for the Panda model: pip install pybullet==3.2.7") from error
    directory = Path(pybullet_data.getDataPath()) / "franka_panda"
    if not (directory / "panda.urdf").is_file():
        raise RuntimeError(f"{directory / 'panda.urdf'} is missing; reinstall pybullet==3.2.7")
    return directory
