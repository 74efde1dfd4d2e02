"""Contact queries on MuJoCo's contact list: the guarded-motion check, the grasp's pad test, and the
reset's robot-touch tests.

The grasp test itself (both pads, normals within ≈11°, contacts on the pads' inner side) is
:func:`t2m_core.simulation.grasp.pad_grips`; here it reads each pad's contacts through their contact
frames. A pad's inward normal is −y of the hand frame (left pad) or +y (right pad).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from t2m_core.protocols import Contact
from t2m_core.simulation.grasp import pad_grips
from t2m_core.simulation.robot import FINGER_LINKS

if TYPE_CHECKING:
    from t2m_mujoco.world import World


def finger_geoms(world: World) -> np.ndarray:
    """Finger geoms (pads and finger bodies): the robot parts the collision check watches."""
    model = world.model
    fingers = {model.body(name).id for name in FINGER_LINKS}
    return np.array([g for g in range(model.ngeom) if model.geom_bodyid[g] in fingers and model.geom_contype[g]])


def contact_guard(world: World, fingers: np.ndarray, forbidden: tuple[str, ...]) -> Callable[[], list[Contact]]:
    """A check returning the contacts (positive normal force) between ``fingers`` or the held object
    and the ``forbidden`` objects; the geoms are resolved once, when the motion starts."""
    owners = world.scene.owners
    forbidden_owners = [owners.index(name) for name in forbidden if name in owners]
    held_geoms = world.geoms_of(world.held) if world.held else np.empty(0, dtype=int)
    watched = np.concatenate((fingers, held_geoms)).astype(int)

    def check() -> list[Contact]:
        return _contacts(world, world.contacts_between(watched, forbidden_owners))

    return check


def _contacts(world: World, hits: list[tuple[int, int, float]]) -> list[Contact]:
    contacts = []
    pairs = world.data.contact.geom
    for index, geom, force in hits:
        other = pairs[index][1] if pairs[index][0] == geom else pairs[index][0]
        name_a = world.owner_name(geom)
        if name_a == "robot":
            name_a = world.model.geom(geom).name or world.model.body(world.model.geom_bodyid[geom]).name
        contacts.append(Contact(name_a, world.owner_name(int(other)), force))
    return contacts


def pads_hold(world: World, name: str) -> bool:
    """Whether both pads grip ``name`` validly (:func:`~t2m_core.simulation.grasp.pad_grips`)."""
    data = world.data
    owner = world.scene.owners.index(name)
    hand_y = data.xmat[world.robot.hand_body].reshape(3, 3)[:, 1]
    for pad, inward in zip(world.robot.pad_geoms, (-hand_y, hand_y), strict=True):
        contacts = []
        for index, _geom, _force in world.contacts_between(np.array([pad]), [owner]):
            contact = data.contact[index]
            normal = contact.frame[:3]  # points from geom1 to geom2
            contacts.append((normal if contact.geom[0] == pad else -normal, contact.pos))
        if not pad_grips(inward, data.geom_xpos[pad], contacts):
            return False
    return True


def held_touches_robot(world: World, held: str) -> bool:
    """Whether ``held`` touches a robot part other than the fingers."""
    model, data = world.model, world.data
    fingers = {model.body(name).id for name in FINGER_LINKS}
    owner_robot = world.scene.owners.index("robot")
    held_geoms = set(world.geoms_of(held).tolist())
    for i in range(data.ncon):
        g1, g2 = int(data.contact.geom[i][0]), int(data.contact.geom[i][1])
        other = g2 if g1 in held_geoms else g1 if g2 in held_geoms else None
        if other is None or world.scene.geom_owner[other] != owner_robot:
            continue
        if model.geom_bodyid[other] not in fingers:
            return True
    return False


def objects_touch_base(world: World) -> bool:
    """Whether any free object touches the robot's base link."""
    base_geoms = np.flatnonzero(world.model.geom_bodyid == world.scene.robot.base_body)
    object_owners = [world.scene.owners.index(name) for name in world.scene.free_names]
    return bool(world.contacts_between(base_geoms, object_owners))
