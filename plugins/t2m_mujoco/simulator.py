"""The MuJoCo implementation of :class:`t2m_core.protocols.Simulator`.

Reset, execution, snapshots and video are the core's (:class:`t2m_core.simulation.simulator.PhysicsSimulator`)
driving a :class:`~t2m_mujoco.world.World`; this module builds the world and its renderer.
"""

from __future__ import annotations

from t2m_mujoco.rendering import prefer_headless_gl

prefer_headless_gl()

from t2m_core.simulation.simulator import PhysicsSimulator  # noqa: E402
from t2m_mujoco.options import MujocoOptions  # noqa: E402
from t2m_mujoco.rendering import CameraRenderer  # noqa: E402
from t2m_mujoco.scene import build_scene  # noqa: E402
from t2m_mujoco.world import World  # noqa: E402


class MujocoSimulator(PhysicsSimulator):
    """TableEnv in MuJoCo (``--sim mujoco``).

    Args:
        options: validated :class:`MujocoOptions` (``None``: the defaults).

    Attributes:
        reset_stats: after each reset, ``{"sampler_rejections", "physics_rejections", "reasons"}``.
    """

    def __init__(self, options: MujocoOptions | None = None) -> None:
        super().__init__(options if options is not None else MujocoOptions())

    def _create_world(self, object_names: tuple[str, ...]) -> World:
        return World(build_scene(object_names, self.options.timestep), self.options.substeps)

    def _create_renderer(self, world: World) -> CameraRenderer:
        return CameraRenderer(world.model, world.data, self.options.render_width, self.options.render_height)
