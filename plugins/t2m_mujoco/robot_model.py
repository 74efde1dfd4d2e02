"""The Franka Panda arm and hand as a MuJoCo model, loaded from the URDF that ships with pybullet_data.

The URDF (``pybullet_data/franka_panda/panda.urdf``) carries the real Panda kinematics; MuJoCo 4 reads
it once ``package://`` is stripped and the mesh directory is set. It is patched as every backend
patches it (:mod:`t2m_core.simulation.robot`: the EE point between long finger pads 0.251 m from
link 7, the hand without its −45° twist, collision filtering, cylinder inertias), in MuJoCo's terms:

* **Fingers.** Each finger gets a pad box and a body box; the stock finger meshes do not collide. The
  pads are the only finger geometry that touches a grasped object (the grasp test reads their
  contacts). The two finger joints are coupled by an equality and driven by one position actuator.
* **Arm.** Position servos on the 7 joints (the controller feeds them IK targets every 1/60 s tick),
  gravity compensation on every robot body, armature for stiffness at 2 ms steps.
* **Collision filtering** with contype/conaffinity bits: links 1–4 collide with nothing, the base
  only with objects, the robot never with itself.
"""

from __future__ import annotations

import functools
import warnings
from dataclasses import dataclass

import numpy as np

from t2m_core.simulation.robot import (
    ARM_JOINTS,
    ARM_TORQUE_LIMITS,
    BASE_LINK,
    EE_IN_HAND,
    FINGER_BODY_CENTER,
    FINGER_BODY_HALF,
    FINGER_JOINTS,
    FINGER_LINKS,
    FINGER_OPEN,
    GRIPPER_FORCE,
    GRIPPER_KP,
    GRIPPER_KV,
    HAND_LINK,
    PAD_CENTER_Z,
    PAD_FRICTION,
    PAD_HALF,
    PAD_NAMES,
    UNCOLLIDING_LINKS,
    VISUAL_FROM_COLLISION,
    panda_urdf_dir,
    placeholder_inertia,
)

EE_SITE = "ee"
HAND_BODY = HAND_LINK
BASE_BODY = BASE_LINK
PAD_GEOMS = PAD_NAMES
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
                body.inertia = placeholder_inertia(body.mass, 0.02 if "finger" in body.name else 0.06)

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
        if body_name in FINGER_LINKS:
            geom.contype = geom.conaffinity = 0  # replaced by pad + body boxes below
        elif body_name == BASE_BODY:
            geom.contype, geom.conaffinity = ROBOT_BIT, OBJECT_BIT
        elif body_name in UNCOLLIDING_LINKS:
            geom.contype = geom.conaffinity = 0
        else:
            geom.contype, geom.conaffinity = ROBOT_BIT, TABLE_BIT | OBJECT_BIT

    for finger, pad_name, side in zip(FINGER_LINKS, PAD_NAMES, (1.0, -1.0), strict=True):
        body = spec.body(finger)
        pad = body.add_geom(
            name=pad_name,
            type=mj.mjtGeom.mjGEOM_BOX,
            size=list(PAD_HALF),
            pos=[0.0, side * PAD_HALF[1], PAD_CENTER_Z],
            rgba=[0.15, 0.15, 0.15, 1],
            friction=[PAD_FRICTION, 0.005, 0.0001],
            priority=2,
            group=2,
        )
        pad.contype, pad.conaffinity = ROBOT_BIT, TABLE_BIT | OBJECT_BIT
        pad.mass = 0.0
        back = body.add_geom(
            type=mj.mjtGeom.mjGEOM_BOX,
            size=list(FINGER_BODY_HALF),
            pos=[FINGER_BODY_CENTER[0], side * FINGER_BODY_CENTER[1], FINGER_BODY_CENTER[2]],
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
        actuator.forcerange = [-ARM_TORQUE_LIMITS[index], ARM_TORQUE_LIMITS[index]]
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
