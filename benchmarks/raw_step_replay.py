"""Record the physics inputs of one primitive execution and replay them with the bare engine step:
the reference that sim_throughput.py divides a primitive's CPU time by.

A recorder wraps a world for the duration of a ``with`` block, starting after the canonicalising
restore every execution begins with; :meth:`replay` then steps the recorded inputs from the world's
current state (the caller restores the same snapshot first) and returns ``(CPU s, wall s, final state)``.
The final state must equal the execution's bit for bit (``final_state``), so the reference simulates
exactly the contacts and solver work of the primitive.

* MuJoCo: per tick, the actuator targets (``ctrl``), the applied joint forces (``qfrc_applied``, the
  sweep impedance), the weld activations, and the model parameters the controller changes (servo
  gains during a sweep, the held object's gravity compensation, the weld pose); replayed with
  assignments and ``mj_step(model, data, nstep=substeps)``.
* PyBullet: the client calls that change the simulation (motor commands, the weld constraint) and
  ``stepSimulation``; replayed as those calls alone, without the queries (poses, contacts, Jacobians,
  IK) the controller makes between them.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np


def recorder_for(world: Any) -> Any:
    """The recorder of ``world``'s backend."""
    module = type(world).__module__
    if module.startswith("t2m_mujoco"):
        return MujocoRecorder(world)
    if module.startswith("t2m_pybullet"):
        return PybulletRecorder(world)
    raise ValueError(f"no raw-step replay for {type(world).__module__}.{type(world).__name__}")


def final_state(world: Any) -> np.ndarray:
    """Every position of the simulation as one array (MuJoCo ``qpos``; PyBullet joints and base poses)."""
    if hasattr(world, "data"):
        return world.data.qpos.copy()
    client, bodies = world.client, (world.robot.body, *world.scene.body.values())
    values = [state[0] for state in client.getJointStates(world.robot.body, list(world.robot.dofs))]
    for body in bodies:
        position, orientation = client.getBasePositionAndOrientation(body)
        values.extend((*position, *orientation))
    return np.array(values)


class _AfterCanonicalize:
    """Records only once the execution's canonicalising restore is done (the replay starts from a restore)."""

    def __init__(self, world: Any) -> None:
        self.world = world
        self.recording = False

    def __enter__(self):
        world, original = self.world, self.world.canonicalize

        def canonicalize() -> None:
            original()
            self.recording = True
            self._started()

        world.canonicalize = canonicalize
        self._start()
        return self

    def __exit__(self, *exc) -> None:
        del self.world.canonicalize  # back to the class's method
        self._stop()

    def _start(self) -> None: ...

    def _started(self) -> None: ...

    def _stop(self) -> None: ...


class MujocoRecorder(_AfterCanonicalize):
    """Per-tick inputs of a :class:`t2m_mujoco.world.World` (module docstring)."""

    MODEL_FIELDS = ("actuator_gainprm", "actuator_biasprm", "body_gravcomp", "eq_data")
    """Model parameters the controller changes at run time (servo gains, held load, weld pose)."""

    def _start(self) -> None:
        world = self.world
        self.ticks: list[tuple] = []
        original = world.tick

        def recording_tick(count: int = 1) -> None:
            if self.recording:
                data, model = world.data, world.model
                inputs = (data.ctrl.copy(), data.qfrc_applied.copy(), data.eq_active.copy(),
                          tuple(getattr(model, name).copy() for name in self.MODEL_FIELDS))
                self.ticks.extend([inputs] * count)
            original(count)

        world.tick = recording_tick

    def _stop(self) -> None:
        del self.world.tick

    def replay(self) -> tuple[float, float, np.ndarray]:
        """Step the recorded inputs with bare ``mj_step``; model parameters are assigned only when
        they change, so the loop is the physics and little else."""
        import mujoco

        world = self.world
        model, data, substeps = world.model, world.data, world.substeps
        saved = tuple(getattr(model, name).copy() for name in self.MODEL_FIELDS)
        plan, previous = [], None
        for ctrl, force, active, parameters in self.ticks:
            changed = None if previous is not None and all(np.array_equal(a, b) for a, b in zip(parameters, previous, strict=True)) else parameters
            plan.append((ctrl, force, active, changed))
            previous = parameters
        cpu, wall = time.process_time(), time.perf_counter()
        for ctrl, force, active, changed in plan:
            data.ctrl[:] = ctrl
            data.qfrc_applied[:] = force
            data.eq_active[:] = active
            if changed is not None:
                for name, value in zip(self.MODEL_FIELDS, changed, strict=True):
                    getattr(model, name)[:] = value
            mujoco.mj_step(model, data, nstep=substeps)
        cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
        for name, value in zip(self.MODEL_FIELDS, saved, strict=True):
            getattr(model, name)[:] = value
        return cpu, wall, final_state(world)


class _RecordingClient:
    """Forwards every call to a PyBullet client and logs the ones that change the simulation."""

    MUTATING = frozenset({
        "setJointMotorControlArray", "setJointMotorControl2", "createConstraint", "changeConstraint",
        "removeConstraint", "stepSimulation",
    })

    def __init__(self, client: Any, recorder: PybulletRecorder) -> None:
        self._client, self._recorder = client, recorder

    def __getattr__(self, name: str) -> Any:
        method = getattr(self._client, name)
        if name not in self.MUTATING:
            return method

        def logged(*args, **kwargs):
            result = method(*args, **kwargs)
            if self._recorder.recording:
                self._recorder.calls.append((name, args, kwargs, result))
            return result

        return logged


class PybulletRecorder(_AfterCanonicalize):
    """The simulation-changing client calls of a :class:`t2m_pybullet.world.World` (module docstring)."""

    def _start(self) -> None:
        self.calls: list[tuple] = []
        self._client = self.world.client
        self.world.client = _RecordingClient(self._client, self)

    def _started(self) -> None:
        self._start_weld = self.world._weld  # the weld the canonicalising restore created, if any

    def _stop(self) -> None:
        self.world.client = self._client
        self._end_weld = self.world._weld

    def replay(self) -> tuple[float, float, np.ndarray]:
        """Issue the recorded calls in order from a restore of the same snapshot; constraint ids are
        mapped to the ones the restore and the replay create, and the world is left owning the weld
        that is live at the end, as after the recorded run."""
        client, world = self._client, self.world
        bound = [(getattr(client, name), name, args, kwargs, result) for name, args, kwargs, result in self.calls]
        constraint_ids = {self._start_weld: world._weld} if self._start_weld is not None else {}
        cpu, wall = time.process_time(), time.perf_counter()
        for method, name, args, kwargs, result in bound:
            if name == "createConstraint":
                constraint_ids[result] = method(*args, **kwargs)
            elif name in ("changeConstraint", "removeConstraint"):
                method(constraint_ids.get(args[0], args[0]), *args[1:], **kwargs)
            else:
                method(*args, **kwargs)
        cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
        world._weld = constraint_ids.get(self._end_weld) if self._end_weld is not None else None
        return cpu, wall, final_state(world)
