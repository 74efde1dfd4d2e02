"""Options of the PyBullet simulator (validated from ``--set simulator.options...`` and config files)."""

from __future__ import annotations

from pydantic import Field

from t2m_core.simulation.options import SimulatorOptions


class PybulletOptions(SimulatorOptions):
    """How the PyBullet backend simulates and renders.

    One 1/60 s control tick is one ``stepSimulation`` call of ``substeps`` internal steps (PyBullet's
    ``numSubSteps``): the default 4 is PyBullet's native 240 Hz. Servo targets and the sweep's
    torques hold for the whole tick.
    """

    substeps: int = Field(4, ge=1, le=64, description="physics steps per 1/60 s tick (4 gives PyBullet's 240 Hz)")
    solver_iterations: int = Field(50, ge=1, le=1000, description="PyBullet constraint-solver iterations per step")
