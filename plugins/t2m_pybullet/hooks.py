"""Registers the PyBullet simulator with t2m. Import-light: PyBullet loads only when it is created."""

from __future__ import annotations

from t2m_core.hookspecs import hookimpl
from t2m_core.plugin_specs import SimulatorSpec
from t2m_pybullet.options import PybulletOptions

PYBULLET_SIMULATOR = SimulatorSpec(
    name="pybullet",
    factory="t2m_pybullet.simulator:PybulletSimulator",
    options=PybulletOptions,
    summary="PyBullet physics (the original's engine): Franka Panda, the TableEnv scene, headless TinyRenderer",
)


@hookimpl
def t2m_register_simulators() -> list[SimulatorSpec]:
    return [PYBULLET_SIMULATOR]
