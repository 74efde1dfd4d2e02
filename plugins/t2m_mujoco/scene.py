"""Builds the MuJoCo model of a TableEnv scene from the domain's object specifications.

One model per set of present objects (absent objects are simply not built, which satisfies "not in
the observation, not physical" of docs/guide/world.md#absent-objects). Every object follows
:data:`t2m_core.domain.objects.OBJECTS` exactly: the table slab, the rack as 7 boxes whose body frame
is the top surface, the hook as two capsules and a sphere, the boxes. Each movable object gets a free
joint and an inactive weld to the hand that the grasp switches on.

Contact parameters: the table has friction 1.0. Boxes and the hook have friction
0.5 and a higher contact priority, so a box sliding on the table sees 0.5, the coefficient PyBullet
produced in the original (its product of the table's 1.0 and a body's default 0.5); with MuJoCo's
default max-combination a 0.118 m box pushed at the hook's height would tip instead of sliding.
The hook's parts are capsules whose total length equals the cylinders' of docs/guide/world.md#frames-and-objects, so the bounding box
(0.40 × 0.22 × 0.04) is exact; capsules rest stably on the table where cylinders chatter.
"""

from __future__ import annotations

import functools
import warnings
from dataclasses import dataclass

import numpy as np

from t2m_core.domain.objects import OBJECTS, ObjectKind, object_spec
from t2m_core.simulation.scene import CAMERAS, FLOOR_Z, OBJECT_FRICTION, TABLE_FRICTION, camera_axes
from t2m_mujoco import robot_model
from t2m_mujoco.robot_model import OBJECT_BIT, TABLE_BIT


@dataclass(frozen=True)
class SceneModel:
    """A compiled scene and the indices the controller and the queries need.

    Attributes:
        model: the ``mujoco.MjModel``.
        object_names: present objects in task order (``table`` first when present).
        robot: robot indices.
        body: object name -> body id (the table's is its static body).
        qpos_address: free object name (all but the table) -> address of its 7 free-joint qpos.
        dof_address: free object name -> address of its 6 free-joint dofs.
        weld: movable object name -> id of its hand weld equality.
        geom_owner: ``(ngeom,) int`` owner of each geom: index into ``owners``.
        owners: owner names: the object names, then ``"robot"``, then ``"floor"``.
    """

    model: object
    object_names: tuple[str, ...]
    robot: robot_model.RobotIndices
    body: dict[str, int]
    qpos_address: dict[str, int]
    dof_address: dict[str, int]
    weld: dict[str, int]
    geom_owner: np.ndarray
    owners: tuple[str, ...]

    @property
    def free_names(self) -> tuple[str, ...]:
        return tuple(self.qpos_address)


def _add_table(spec, mj) -> None:
    table = OBJECTS["table"]
    body = spec.worldbody.add_body(name="table", pos=[0.0, 0.0, 0.0])  # pose = identity
    (slab,) = table.parts()
    geom = body.add_geom(
        name="table/slab",
        type=mj.mjtGeom.mjGEOM_BOX,
        size=[s / 2 for s in slab.size],
        pos=list(slab.center),
        rgba=list(table.rgba),
        friction=[TABLE_FRICTION, 0.005, 0.0001],
        material="table",
    )
    geom.contype, geom.conaffinity = TABLE_BIT, 0


def _add_object(spec, mj, name: str) -> None:
    obj = object_spec(name)
    body = spec.worldbody.add_body(name=name, pos=[0.0, 0.0, -0.5])
    body.add_freejoint(name=f"{name}/free")
    friction = [OBJECT_FRICTION if obj.kind is not ObjectKind.RACK else TABLE_FRICTION, 0.005, 0.0001]
    common = {"rgba": list(obj.rgba), "friction": friction, "priority": 1 if obj.kind is not ObjectKind.RACK else 0}
    if obj.kind is ObjectKind.HOOK:
        hook = obj.hook
        for part, mass in zip(hook.cylinders(), hook.mass_split(obj.mass), strict=True):
            length = part.length
            if length == 0.0:
                geom = body.add_geom(name=f"{name}/{part.name}", type=mj.mjtGeom.mjGEOM_SPHERE, size=[part.radius, 0, 0],
                                     pos=list(part.center), **common)
            else:
                axis = np.array([1.0, 0, 0]) if part.axis == "x" else np.array([0, 1.0, 0])
                half = length / 2 - part.radius  # capsule caps keep the cylinder's total length
                center = np.array(part.center)
                geom = body.add_geom(name=f"{name}/{part.name}", type=mj.mjtGeom.mjGEOM_CAPSULE, size=[part.radius, 0, 0],
                                     fromto=[*(center - half * axis), *(center + half * axis)], **common)
            geom.mass = mass
            geom.contype, geom.conaffinity = OBJECT_BIT, TABLE_BIT | OBJECT_BIT
    else:
        parts = obj.parts()
        for part in parts:
            geom = body.add_geom(name=f"{name}/{part.name}", type=mj.mjtGeom.mjGEOM_BOX, size=[s / 2 for s in part.size],
                                 pos=list(part.center), **common)
            geom.mass = obj.mass / len(parts)  # the rack's 1 kg split equally over its 7 parts
            geom.contype, geom.conaffinity = OBJECT_BIT, TABLE_BIT | OBJECT_BIT
    if not obj.movable:
        return
    weld = spec.add_equality(type=mj.mjtEq.mjEQ_WELD, name=f"grasp/{name}", name1=robot_model.HAND_BODY, name2=name,
                             objtype=mj.mjtObj.mjOBJ_BODY)
    weld.active = False


def _add_world_dressing(spec, mj) -> None:
    spec.add_texture(name="grid", type=mj.mjtTexture.mjTEXTURE_2D, builtin=mj.mjtBuiltin.mjBUILTIN_CHECKER,
                     rgb1=[0.32, 0.36, 0.40], rgb2=[0.27, 0.30, 0.34], width=256, height=256)
    spec.add_material(name="floor", texrepeat=[6, 6], reflectance=0.05).textures[mj.mjtTextureRole.mjTEXROLE_RGB] = "grid"
    spec.add_material(name="table", reflectance=0.0)
    floor = spec.worldbody.add_geom(name="floor", type=mj.mjtGeom.mjGEOM_PLANE, size=[3, 3, 0.1], pos=[0, 0, FLOOR_Z],
                                    material="floor")
    floor.contype, floor.conaffinity = TABLE_BIT, 0
    spec.worldbody.add_light(name="key", pos=[0.8, 0.6, 2.0], dir=[-0.3, -0.3, -1.0], diffuse=[0.6, 0.6, 0.6],
                             castshadow=False)  # shadows triple the software-rendering time
    spec.worldbody.add_light(name="fill", pos=[-0.5, -0.8, 1.8], dir=[0.4, 0.4, -1.0], diffuse=[0.3, 0.3, 0.3],
                             castshadow=False)
    for name, (position, target, fovy) in CAMERAS.items():
        right, up = camera_axes(position, target)
        spec.worldbody.add_camera(name=name, pos=list(position), xyaxes=[*right, *up], fovy=fovy)
    spec.visual.headlight.ambient = [0.35, 0.35, 0.35]
    spec.visual.headlight.diffuse = [0.3, 0.3, 0.3]


@functools.cache
def build_scene(object_names: tuple[str, ...], timestep: float = 0.002) -> SceneModel:
    """Compile the scene with ``object_names`` (the task's objects, table first) plus the robot.

    Cached per object set and timestep: compiling loads the Panda meshes (about 0.4 s).

    Raises:
        KeyError: an unknown object name (the message lists the known ones).
        ValueError: duplicated names.
    """
    import mujoco as mj

    if len(set(object_names)) != len(object_names):
        raise ValueError(f"object names repeat: {object_names}")
    for name in object_names:
        object_spec(name)
    spec = robot_model.load_panda_spec()
    spec.option.timestep = timestep
    spec.option.gravity = [0.0, 0.0, -9.8]
    spec.option.integrator = mj.mjtIntegrator.mjINT_IMPLICITFAST
    spec.option.cone = mj.mjtCone.mjCONE_PYRAMIDAL
    # Resting objects sleep until something touches them (PyBullet deactivates resting bodies the
    # same way); this makes a scene of still objects about 5x cheaper to step.
    spec.option.enableflags |= int(mj.mjtEnableBit.mjENBL_SLEEP)
    _add_world_dressing(spec, mj)
    if "table" in object_names:
        _add_table(spec, mj)
    for name in object_names:
        if object_spec(name).kind is not ObjectKind.TABLE:
            _add_object(spec, mj, name)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # visual .obj files lack texture coordinates: harmless
        model = spec.compile()

    owners = (*object_names, "robot", "floor")
    body_owner = np.full(model.nbody, -1)
    body = {}
    for index, name in enumerate(object_names):
        body[name] = model.body(name).id
        body_owner[body[name]] = index
    body_owner[robot_model.resolve_indices(model).robot_bodies] = len(object_names)
    geom_owner = body_owner[model.geom_bodyid].copy()
    geom_owner[model.geom("floor").id] = len(object_names) + 1
    free_bodies = [n for n in object_names if object_spec(n).kind is not ObjectKind.TABLE]
    joints = {n: model.joint(f"{n}/free").id for n in free_bodies}
    return SceneModel(
        model=model,
        object_names=tuple(object_names),
        robot=robot_model.resolve_indices(model),
        body=body,
        qpos_address={n: int(model.jnt_qposadr[j]) for n, j in joints.items()},
        dof_address={n: int(model.jnt_dofadr[j]) for n, j in joints.items()},
        weld={n: model.equality(f"grasp/{n}").id for n in free_bodies if object_spec(n).movable},
        geom_owner=geom_owner,
        owners=owners,
    )
