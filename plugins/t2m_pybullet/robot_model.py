"""The Franka Panda as a PyBullet multibody, loaded from the URDF that ships with pybullet_data.

The URDF is patched as every backend patches it (:mod:`t2m_core.simulation.robot`: the EE point
between long finger pads 0.251 m from link 7, the hand without its −45° twist, cylinder inertias),
in PyBullet's terms:

* **Links.** Each finger's stock mesh stops colliding; a box stands in for the finger body and a pad
  box is a link of its own (fixed to the finger), so a contact names the pad it touches. The EE
  operational point is a massless link ``ee`` fixed to the hand.
* **Collision filtering** with PyBullet's group/mask pairs (a pair collides when each one's group is
  in the other's mask): links 1–4 collide with nothing, the base only with objects, the rest of the
  arm with the table and objects, the robot never with itself (no self-collision flag).

The patched URDF is written once into the t2m cache (named by its content hash, atomically), with
absolute mesh paths.
"""

from __future__ import annotations

import functools
import hashlib
import xml.etree.ElementTree as ElementTree
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from t2m_core.simulation.robot import (
    ARM_JOINTS,
    BASE_LINK,
    EE_IN_HAND,
    FINGER_BODY_CENTER,
    FINGER_BODY_HALF,
    FINGER_JOINTS,
    FINGER_LINKS,
    HAND_LINK,
    PAD_CENTER_Z,
    PAD_FRICTION,
    PAD_HALF,
    PAD_NAMES,
    UNCOLLIDING_LINKS,
    panda_urdf_dir,
    placeholder_inertia,
)

EE_LINK = "ee"
PAD_MASS = 0.01
"""kg of a pad link (a fixed link of its own; a few grams keep its inertia well defined)."""

# collision groups and masks: a pair collides when group_a & mask_b and group_b & mask_a
TABLE_GROUP = 1
OBJECT_GROUP = 2
ROBOT_GROUP = 4


@dataclass(frozen=True)
class RobotLinks:
    """Joint and link indices of the loaded Panda (a link's index is its parent joint's).

    Attributes:
        body: the multibody's unique id.
        arm: ``(7,)`` arm joint indices. fingers: the two finger joint indices.
        ee: the EE link. hand: the hand link. pads: left and right pad links.
        finger_links: the two finger links. colliding: links that collide with the table or objects.
        joint_low, joint_high: ``(7,)`` arm joint limits, radians.
    """

    body: int
    arm: tuple[int, ...]
    fingers: tuple[int, int]
    ee: int
    hand: int
    pads: tuple[int, int]
    finger_links: tuple[int, int]
    joint_low: np.ndarray
    joint_high: np.ndarray

    @property
    def dofs(self) -> tuple[int, ...]:
        """The movable joints in PyBullet's DoF order (arm, then fingers)."""
        return (*self.arm, *self.fingers)


def _box(parent: ElementTree.Element, tag: str, half: tuple[float, float, float], xyz: tuple[float, float, float], rgba: str | None = None) -> None:
    """Append a ``<visual>`` or ``<collision>`` box of half sizes ``half`` at ``xyz`` (m)."""
    element = ElementTree.SubElement(parent, tag)
    ElementTree.SubElement(element, "origin", xyz=" ".join(map(repr, xyz)), rpy="0 0 0")
    geometry = ElementTree.SubElement(element, "geometry")
    ElementTree.SubElement(geometry, "box", size=" ".join(repr(2 * h) for h in half))
    if rgba is not None:
        material = ElementTree.SubElement(element, "material", name=f"rgba_{rgba.replace(' ', '_')}")
        ElementTree.SubElement(material, "color", rgba=rgba)


def _fixed_link(robot: ElementTree.Element, name: str, parent: str, xyz: tuple[float, float, float], mass: float) -> ElementTree.Element:
    """Append a link ``name`` fixed to ``parent`` at ``xyz`` (m), of ``mass`` kg; returns the link."""
    link = ElementTree.SubElement(robot, "link", name=name)
    inertial = ElementTree.SubElement(link, "inertial")
    ElementTree.SubElement(inertial, "origin", xyz="0 0 0", rpy="0 0 0")
    ElementTree.SubElement(inertial, "mass", value=repr(mass))
    inertia = repr(1e-6 if mass else 0.0)
    ElementTree.SubElement(inertial, "inertia", ixx=inertia, ixy="0", ixz="0", iyy=inertia, iyz="0", izz=inertia)
    joint = ElementTree.SubElement(robot, "joint", name=f"{name}_joint", type="fixed")
    ElementTree.SubElement(joint, "parent", link=parent)
    ElementTree.SubElement(joint, "child", link=name)
    ElementTree.SubElement(joint, "origin", xyz=" ".join(map(repr, xyz)), rpy="0 0 0")
    return link


@functools.cache
def patched_urdf_text() -> str:
    """The patched Panda URDF (see the module docstring), with absolute mesh paths."""
    directory = panda_urdf_dir()
    robot = ElementTree.fromstring((directory / "panda.urdf").read_text())
    for mesh in robot.iter("mesh"):
        mesh.set("filename", str(directory / mesh.get("filename").replace("package://", "")))
    for joint in robot.iter("joint"):
        if joint.get("name") == "panda_hand_joint":
            joint.find("origin").set("rpy", "0 0 0")  # no −45° twist: the jaw closes along world y at q_home
    for link in robot.iter("link"):
        name = link.get("name")
        inertial = link.find("inertial")
        mass = float(inertial.find("mass").get("value"))
        if mass > 0:
            ixx, iyy, izz = placeholder_inertia(mass, 0.02 if "finger" in name else 0.06)
            inertial.find("inertia").attrib.update(ixx=repr(ixx), iyy=repr(iyy), izz=repr(izz))
        if name == BASE_LINK:
            # PyBullet's IK works in the base's inertial frame: put it at the base frame (the base is fixed)
            inertial.find("origin").set("xyz", "0 0 0")
        if name in FINGER_LINKS:
            for collision in link.findall("collision"):
                link.remove(collision)  # replaced by the body box here and the pad link below
            side = 1.0 if name == FINGER_LINKS[0] else -1.0
            center = (FINGER_BODY_CENTER[0], side * FINGER_BODY_CENTER[1], FINGER_BODY_CENTER[2])
            _box(link, "collision", FINGER_BODY_HALF, center)
    for finger, pad, side in zip(FINGER_LINKS, PAD_NAMES, (1.0, -1.0), strict=True):
        link = _fixed_link(robot, pad, finger, (0.0, side * PAD_HALF[1], PAD_CENTER_Z), PAD_MASS)
        _box(link, "visual", PAD_HALF, (0.0, 0.0, 0.0), rgba="0.15 0.15 0.15 1")
        _box(link, "collision", PAD_HALF, (0.0, 0.0, 0.0))
        contact = ElementTree.SubElement(link, "contact")
        ElementTree.SubElement(contact, "lateral_friction", value=repr(PAD_FRICTION))
    _fixed_link(robot, EE_LINK, HAND_LINK, (0.0, 0.0, EE_IN_HAND), 0.0)
    return ElementTree.tostring(robot, encoding="unicode")


def patched_urdf_path() -> Path:
    """The patched URDF in the t2m cache, written once (named by its content hash)."""
    from t2m_core.atomic_files import write_bytes_atomic
    from t2m_core.settings import cache_dir

    text = patched_urdf_text().encode()
    path = cache_dir() / "pybullet" / f"panda-{hashlib.sha256(text).hexdigest()[:16]}.urdf"
    if not path.is_file():
        path.parent.mkdir(parents=True, exist_ok=True)
        write_bytes_atomic(path, text)
    return path


def load_panda(client) -> RobotLinks:
    """Load the patched Panda into a PyBullet ``client`` at the origin, filter its collisions, and
    return its indices."""
    import pybullet

    body = client.loadURDF(str(patched_urdf_path()), [0, 0, 0], [0, 0, 0, 1], useFixedBase=True,
                           flags=pybullet.URDF_USE_INERTIA_FROM_FILE)
    index = {client.getJointInfo(body, j)[12].decode(): j for j in range(client.getNumJoints(body))}
    joints = {client.getJointInfo(body, j)[1].decode(): j for j in range(client.getNumJoints(body))}
    arm = tuple(joints[name] for name in ARM_JOINTS)
    links = RobotLinks(
        body=body,
        arm=arm,
        fingers=(joints[FINGER_JOINTS[0]], joints[FINGER_JOINTS[1]]),
        ee=index[EE_LINK],
        hand=index[HAND_LINK],
        pads=(index[PAD_NAMES[0]], index[PAD_NAMES[1]]),
        finger_links=(index[FINGER_LINKS[0]], index[FINGER_LINKS[1]]),
        joint_low=np.array([client.getJointInfo(body, j)[8] for j in arm]),
        joint_high=np.array([client.getJointInfo(body, j)[9] for j in arm]),
    )
    client.setCollisionFilterGroupMask(body, -1, ROBOT_GROUP, OBJECT_GROUP)  # the base stands on the table
    for name, link in index.items():
        if name in UNCOLLIDING_LINKS:
            client.setCollisionFilterGroupMask(body, link, 0, 0)
        else:
            client.setCollisionFilterGroupMask(body, link, ROBOT_GROUP, TABLE_GROUP | OBJECT_GROUP)
    return links
