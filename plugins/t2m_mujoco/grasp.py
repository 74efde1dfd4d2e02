"""The grasp validity test of tableenv.md §3.3, on MuJoCo contacts.

A grasp holds when *both* finger pads touch the object, every pad contact's normal is within about
11° of the pad's inward normal (dot product ≥ 0.98), and every contact lies on the pad's inner side.
The pads are the boxes :mod:`t2m_mujoco.robot_model` puts on the fingers' inner faces; a pad's inward
normal is −y of the left finger and +y of the right finger, in the hand frame.
"""

from __future__ import annotations

import numpy as np

from t2m_mujoco.robot_model import PAD_HALF
from t2m_mujoco.world import World

NORMAL_ALIGNMENT = 0.98
"""Minimum dot product between a contact normal and the pad's inward normal."""
CLOSED_FINGER = 0.001
"""Finger position (m) below which the gripper closed on nothing."""


def pads_hold(world: World, name: str) -> bool:
    """Whether both pads grip ``name`` with valid contacts (§3.3 step 3)."""
    data = world.data
    owner = world.scene.owners.index(name)
    hand_y = data.xmat[world.robot.hand_body].reshape(3, 3)[:, 1]
    touched = set()
    for pad, inward in zip(world.robot.pad_geoms, (-hand_y, hand_y), strict=True):
        hits = world.contacts_between(np.array([pad]), [owner])
        if not hits:
            return False
        for index, _geom, _force in hits:
            contact = data.contact[index]
            normal = contact.frame[:3]  # points from geom1 to geom2
            from_pad = normal if contact.geom[0] == pad else -normal
            if float(np.dot(from_pad, inward)) < NORMAL_ALIGNMENT:
                return False
            # inner side: the contact point is no deeper than the pad's inner face, measured inward
            depth = float(np.dot(contact.pos - data.geom_xpos[pad], inward))
            if depth < PAD_HALF[1] - 0.003:
                return False
        touched.add(pad)
    return len(touched) == 2
