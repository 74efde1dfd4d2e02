"""The PyBullet implementation of :class:`t2m_core.protocols.Simulator` (``--sim pybullet``).

Reset, execution, snapshots and video are the core's (:class:`t2m_core.simulation.simulator.PhysicsSimulator`)
driving a :class:`~t2m_pybullet.world.World`; this module builds the world and its renderer. Each
simulator has its own headless (DIRECT) PyBullet clients, so several live in one process.
"""

from __future__ import annotations

from t2m_core.simulation.simulator import PhysicsSimulator
from t2m_pybullet.options import PybulletOptions
from t2m_pybullet.rendering import CameraRenderer
from t2m_pybullet.world import World


class PybulletSimulator(PhysicsSimulator):
    """TableEnv in PyBullet (``--sim pybullet``).

    Args:
        options: validated :class:`PybulletOptions` (``None``: the defaults).

    Attributes:
        reset_stats: after each reset, ``{"sampler_rejections", "physics_rejections", "reasons"}``.
    """

    def __init__(self, options: PybulletOptions | None = None) -> None:
        super().__init__(options if options is not None else PybulletOptions())

    def _create_world(self, object_names: tuple[str, ...]) -> World:
        return World(object_names, self.options.substeps, self.options.solver_iterations)

    def _create_renderer(self, world: World) -> CameraRenderer:
        return CameraRenderer(world.client, self.options.render_width, self.options.render_height)
