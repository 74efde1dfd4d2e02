"""Registers the MuJoCo simulator with t2m. Import-light: MuJoCo loads only when it is created."""

from __future__ import annotations

from t2m_core.hookspecs import hookimpl
from t2m_core.plugin_specs import SimulatorSpec
from t2m_mujoco.options import MujocoOptions

MUJOCO_SIMULATOR = SimulatorSpec(
    name="mujoco",
    factory="t2m_mujoco.simulator:MujocoSimulator",
    options=MujocoOptions,
    summary="MuJoCo physics: Franka Panda, the TableEnv scene, headless rendering (default)",
)


@hookimpl
def t2m_register_simulators() -> list[SimulatorSpec]:
    return [MUJOCO_SIMULATOR]
