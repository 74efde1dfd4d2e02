"""The builtin simulator backends, for tests parametrised over every one of them."""

from __future__ import annotations

from typing import Any

import numpy as np

from t2m_core.domain.primitives import MotionKind, MotionStep
from t2m_core.tasks import load_task

BACKENDS = ("mujoco", "pybullet")


def make_simulator(backend: str, **options: Any) -> Any:
    """A simulator of ``backend`` with the given options (the rest default)."""
    if backend == "mujoco":
        from t2m_mujoco.options import MujocoOptions
        from t2m_mujoco.simulator import MujocoSimulator

        return MujocoSimulator(MujocoOptions(**options))
    if backend == "pybullet":
        from t2m_pybullet.options import PybulletOptions
        from t2m_pybullet.simulator import PybulletSimulator

        return PybulletSimulator(PybulletOptions(**options))
    raise ValueError(f"unknown backend {backend!r}; backends: {', '.join(BACKENDS)}")


def sweep_into_rack(sim: Any) -> tuple[int, str | None, float]:
    """Sweep the open fingers (soft gains) along −y into the edge of task0's rack top plate, seed 0
    (the rack near (0.44, −0.34), its long side along x, in both backends); returns (ticks, failure,
    metres the rack moved)."""
    sim.reset(load_task("task0"), seed=0)
    world, executor = sim.world, sim.executor
    executor.begin_primitive()
    assert executor.run(MotionStep(MotionKind.MOVE, "start", np.array([0.435, -0.14, 0.14]), 0.0)).failure is None
    rack_before = world.geometric_state().objects["rack"].position
    start_ticks = world.ticks
    report = executor.run(MotionStep(MotionKind.SWEEP, "into_rack", np.array([0.435, -0.34, 0.14]), 0.0, soft=True))
    moved = float(np.linalg.norm(world.geometric_state().objects["rack"].position - rack_before))
    return world.ticks - start_ticks, report.failure, moved
