"""The Franka Panda arm and hand as a MuJoCo model, loaded from the URDF that ships with pybullet_data.

The URDF (``pybullet_data/franka_panda/panda.urdf``) carries the real Panda kinematics; MuJoCo 4 reads
it once ``package://`` is stripped and the mesh directory is set. This module patches it into a
controllable robot:

* **Tool mount and fingers.** TableEnv's end-effector operational point is 0.251 m from the link-7
  frame (the Robotiq 2F-85 of the original). The Franka hand sits on the flange (0.107 m) and its
  stock fingers end only 0.047 m below its palm, too short to grasp the 0.118 m red box at its centre
  without the palm striking the box top. Each finger therefore carries a 0.04 m longer pad (as
  custom Franka fingertips do); the operational point :data:`EE_SITE` lies between the pads, 0.144 m
  below the hand frame and 8 mm above the tips, i.e. exactly 0.251 m from link 7, so q_home puts it
  at (0.402, 0, 0.400) pointing down. The hand is mounted without the Franka's −45° twist so that at
  q_home the jaw closes along world y, the Robotiq's direction in the original (a yaw-0 grasp
  closes across an object's y). Stroke 0–0.04 m per finger (80 mm jaw, the class of the 2F-85's
  85 mm). The pads are the only finger geometry that touches a grasped object (the §3.3 grasp test
  reads their contacts); a body box stands in for the rest of each finger. The two finger joints
  are coupled by an equality and driven by one position actuator.
* **Arm.** Position servos on the 7 joints (the controller feeds them IK targets every 1/60 s tick),
  gravity compensation on every robot body, armature for stiffness at 2 ms steps. The URDF's
  placeholder inertias (0.1 kg·m² everywhere) are replaced by solid-cylinder estimates from each
  link's mass.
* **Collision filtering.** Links 1–4 never reach the objects at the 0.40 m lift height, so they
  collide with nothing; the base (link 0) collides only with objects (it stands on the table). The
  robot never collides with itself.
"""

from __future__ import annotations

import functools
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

Q_HOME = np.array([0.0, -0.5, 0.0, -2.28, 0.0, 1.78, 0.0])
"""(7,) home joint configuration in radians (tableenv.md §3.1)."""

EE_OFFSET_FROM_LINK7 = 0.251
"""Metres from the link-7 frame to the EE operational point along its z axis (tableenv.md §3.1)."""

FLANGE_TO_HAND = 0.107
"""Metres from link 7 to the hand frame (the Panda flange)."""

EE_IN_HAND = EE_OFFSET_FROM_LINK7 - FLANGE_TO_HAND
"""Metres from the hand frame to the EE point between the pads (0.144)."""

FINGER_EXTENSION = 0.04
"""Metres added to each stock finger by its long pad."""

FINGER_OPEN = 0.04
"""Finger joint position (m) of a fully open gripper; 0 is fully closed."""

ARM_JOINTS = tuple(f"panda_joint{i}" for i in range(1, 8))
FINGER_JOINTS = ("panda_finger_joint1", "panda_finger_joint2")
EE_SITE = "ee"
HAND_BODY = "panda_hand"
BASE_BODY = "panda_link0"
PAD_GEOMS = ("left_pad", "right_pad")
ROBOT_PREFIX = "panda_"

# contype / conaffinity bits (a pair collides when contype_a & conaffinity_b or the reverse)
TABLE_BIT = 1
OBJECT_BIT = 2
ROBOT_BIT = 4

ARM_KP = np.array([4000.0, 4000.0, 4000.0, 4000.0, 2000.0, 2000.0, 2000.0])
"""(7,) joint servo stiffness, N·m/rad: stiff enough to track IK targets within a millimetre."""
ARM_KV = np.array([200.0, 200.0, 200.0, 200.0, 80.0, 80.0, 80.0])
"""(7,) joint servo damping, N·m·s/rad (near critical with the armature below)."""
ARM_ARMATURE = 0.1
GRIPPER_KP = 400.0
"""Finger servo stiffness, N/m (tableenv.md §3.3 gripper gains (400, 40))."""
GRIPPER_KV = 40.0
GRIPPER_FORCE = 70.0
"""Newtons: the Franka hand's continuous grip force."""

VISUAL_FROM_COLLISION = ("panda_link5", "panda_link6")
"""Links whose visual .obj files (no texture coordinates) render as holes; their collision meshes
are drawn instead, as the URDF already does for link 7."""

PAD_HALF = (0.0105, 0.005, 0.032)
"""Half sizes (m) of a finger pad box: finger width, thickness, length along the finger."""
FINGER_ORIGIN_IN_HAND = 0.0584
"""Metres from the hand frame to the finger joints (URDF)."""
STOCK_FINGER_LENGTH = 0.0538
"""Metres: length of the stock finger mesh along the hand's z."""


@dataclass(frozen=True)
class RobotIndices:
    """Indices into a compiled model, resolved once."""

    arm_qpos: np.ndarray  # (7,) int
    arm_dof: np.ndarray  # (7,) int
    finger_qpos: np.ndarray  # (2,) int
    arm_actuators: np.ndarray  # (7,) int
    gripper_actuator: int
    ee_site: int
    hand_body: int
    base_body: int
    pad_geoms: tuple[int, int]
    robot_bodies: np.ndarray  # all panda bodies, int
    joint_low: np.ndarray  # (7,) rad
    joint_high: np.ndarray  # (7,) rad


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


@functools.cache
def _patched_urdf_text() -> str:
    directory = panda_urdf_dir()
    text = (directory / "panda.urdf").read_text().replace("package://", "")
    compiler = (
        f'<mujoco><compiler meshdir="{directory}" balanceinertia="true" discardvisual="false" '
        'fusestatic="false" autolimits="true"/></mujoco>'
    )
    head, _, rest = text.partition("<robot ")
    tag, _, body = rest.partition(">")
    return f"{head}<robot {tag}>{compiler}{body}"


def _cylinder_inertia(mass: float, radius: float = 0.06, length: float = 0.15) -> list[float]:
    """Diagonal inertia (kg·m²) of a solid cylinder, a stand-in for a link's placeholder inertia."""
    lateral = mass * (3 * radius**2 + length**2) / 12
    return [lateral, lateral, mass * radius**2 / 2]


def load_panda_spec():
    """A fresh ``mujoco.MjSpec`` of the patched Panda (see the module docstring)."""
    import mujoco as mj

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # visual .obj files lack texture coordinates: harmless
        spec = mj.MjSpec.from_string(_patched_urdf_text())

    for body in spec.bodies:
        if body.name.startswith(ROBOT_PREFIX):
            body.gravcomp = 1.0
            if body.mass > 0:
                body.explicitinertial = True
                body.fullinertia = [np.nan] * 6
                body.inertia = _cylinder_inertia(body.mass, 0.02 if "finger" in body.name else 0.06)

    hand = spec.body(HAND_BODY)
    hand.quat = [1.0, 0.0, 0.0, 0.0]  # no −45° twist: the jaw closes along world y at q_home
    hand.add_site(name=EE_SITE, pos=[0, 0, EE_IN_HAND], size=[0.005, 0, 0], rgba=[1, 0, 1, 0])

    collision_mesh = {
        geom.parent.name: geom.meshname for geom in spec.geoms if geom.parent and (geom.contype or geom.conaffinity)
    }
    for geom in spec.geoms:
        body_name = geom.parent.name if geom.parent else ""
        is_visual = geom.contype == 0 and geom.conaffinity == 0
        if is_visual:
            geom.group = 1
            if body_name in VISUAL_FROM_COLLISION:
                geom.meshname = collision_mesh[body_name]
            continue
        geom.group = 3
        if body_name in ("panda_leftfinger", "panda_rightfinger"):
            geom.contype = geom.conaffinity = 0  # replaced by pad + body boxes below
        elif body_name == BASE_BODY:
            geom.contype, geom.conaffinity = ROBOT_BIT, OBJECT_BIT
        elif body_name in ("panda_link1", "panda_link2", "panda_link3", "panda_link4"):
            geom.contype = geom.conaffinity = 0
        else:
            geom.contype, geom.conaffinity = ROBOT_BIT, TABLE_BIT | OBJECT_BIT

    for finger, side in (("panda_leftfinger", 1.0), ("panda_rightfinger", -1.0)):
        body = spec.body(finger)
        pad = body.add_geom(
            name=f"{'left' if side > 0 else 'right'}_pad",
            type=mj.mjtGeom.mjGEOM_BOX,
            size=list(PAD_HALF),
            pos=[0.0, side * PAD_HALF[1], STOCK_FINGER_LENGTH + FINGER_EXTENSION - PAD_HALF[2]],
            rgba=[0.15, 0.15, 0.15, 1],
            friction=[1.0, 0.005, 0.0001],
            priority=2,
            group=2,
        )
        pad.contype, pad.conaffinity = ROBOT_BIT, TABLE_BIT | OBJECT_BIT
        pad.mass = 0.0
        back = body.add_geom(
            type=mj.mjtGeom.mjGEOM_BOX,
            size=[0.0105, 0.0092, 0.027],
            pos=[0.0, side * 0.0172, 0.027],
            rgba=[0.9, 0.9, 0.9, 1],
            group=3,
        )
        back.contype, back.conaffinity = ROBOT_BIT, TABLE_BIT | OBJECT_BIT
        back.mass = 0.0

    for joint in spec.joints:
        if joint.name in ARM_JOINTS:
            joint.armature = ARM_ARMATURE
        elif joint.name in FINGER_JOINTS:
            joint.armature = 0.01
    for index, name in enumerate(ARM_JOINTS):
        actuator = spec.add_actuator(name=f"{name}_servo", target=name, trntype=mj.mjtTrn.mjTRN_JOINT)
        actuator.set_to_position(kp=float(ARM_KP[index]), kv=float(ARM_KV[index]))
        actuator.forcerange = [-300.0, 300.0] if index < 4 else [-60.0, 60.0]
        actuator.forcelimited = mj.mjtLimited.mjLIMITED_TRUE
    gripper = spec.add_actuator(name="gripper", target=FINGER_JOINTS[0], trntype=mj.mjtTrn.mjTRN_JOINT)
    gripper.set_to_position(kp=GRIPPER_KP, kv=GRIPPER_KV)
    gripper.ctrlrange = [0.0, FINGER_OPEN]
    gripper.ctrllimited = mj.mjtLimited.mjLIMITED_TRUE
    gripper.forcerange = [-GRIPPER_FORCE, GRIPPER_FORCE]
    gripper.forcelimited = mj.mjtLimited.mjLIMITED_TRUE
    spec.add_equality(
        type=mj.mjtEq.mjEQ_JOINT, name1=FINGER_JOINTS[1], name2=FINGER_JOINTS[0], objtype=mj.mjtObj.mjOBJ_JOINT
    )
    return spec


def resolve_indices(model) -> RobotIndices:
    """Look up the robot's joints, actuators, site and pads in a compiled model."""
    import mujoco

    joint_ids = [model.joint(name).id for name in ARM_JOINTS]
    finger_ids = [model.joint(name).id for name in FINGER_JOINTS]
    robot_bodies = [i for i in range(model.nbody) if model.body(i).name.startswith(ROBOT_PREFIX)]
    return RobotIndices(
        arm_qpos=np.array([model.jnt_qposadr[j] for j in joint_ids]),
        arm_dof=np.array([model.jnt_dofadr[j] for j in joint_ids]),
        finger_qpos=np.array([model.jnt_qposadr[j] for j in finger_ids]),
        arm_actuators=np.array([model.actuator(f"{name}_servo").id for name in ARM_JOINTS]),
        gripper_actuator=model.actuator("gripper").id,
        ee_site=mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, EE_SITE),
        hand_body=model.body(HAND_BODY).id,
        base_body=model.body(BASE_BODY).id,
        pad_geoms=(model.geom(PAD_GEOMS[0]).id, model.geom(PAD_GEOMS[1]).id),
        robot_bodies=np.array(robot_bodies),
        joint_low=np.array([model.jnt_range[j][0] for j in joint_ids]),
        joint_high=np.array([model.jnt_range[j][1] for j in joint_ids]),
    )
