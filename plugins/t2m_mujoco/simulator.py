"""The MuJoCo implementation of :class:`t2m_core.protocols.Simulator`.

Reset and execution are the core's (:mod:`t2m_core.simulation.reset`, :mod:`t2m_core.simulation.execution`)
driving a :class:`~t2m_mujoco.world.World`: sample, drop from 5 cm, move to the sampled robot pose,
settle, verify; run the domain's motion steps with its disturbance test, checks and post-conditions.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from t2m_mujoco.rendering import prefer_headless_gl

prefer_headless_gl()

from t2m_core.domain.observation import encode_observation  # noqa: E402
from t2m_core.domain.state import GeometricState  # noqa: E402
from t2m_core.protocols import PrimitiveResult, ResetResult  # noqa: E402
from t2m_core.simulation.execution import execute_primitive  # noqa: E402
from t2m_core.simulation.motion import MotionExecutor  # noqa: E402
from t2m_core.simulation.reset import reset_to_task  # noqa: E402
from t2m_mujoco.options import MujocoOptions  # noqa: E402
from t2m_mujoco.rendering import CameraRenderer  # noqa: E402
from t2m_mujoco.scene import build_scene  # noqa: E402
from t2m_mujoco.world import Snapshot, World  # noqa: E402


class MujocoSimulator:
    """TableEnv in MuJoCo (``--sim mujoco``).

    Args:
        options: validated :class:`MujocoOptions` (``None``: the defaults).

    Attributes:
        reset_stats: after each reset, ``{"sampler_rejections", "physics_rejections", "reasons"}``.
    """

    def __init__(self, options: MujocoOptions | None = None) -> None:
        self.options = options if options is not None else MujocoOptions()
        self.world: World | None = None
        self.executor: MotionExecutor | None = None
        self.task: Any = None
        self.reset_stats: dict[str, Any] = {}
        self._renderer: CameraRenderer | None = None
        self._frames: list[np.ndarray] = []
        self._frame_sink: Callable[[np.ndarray], None] | None = None

    # --- scene ------------------------------------------------------------------------------------

    def _load(self, object_names: tuple[str, ...]) -> World:
        if self.world is None or self.world.scene.object_names != object_names:
            if self._renderer is not None:
                self._renderer.close()
                self._renderer = None
            scene = build_scene(object_names, self.options.timestep)
            self.world = World(scene, self.options.substeps)
            frame_every = max(1, round(60 / self.options.video_fps))
            self.executor = MotionExecutor(self.world, on_tick=self._on_tick, frame_every=frame_every)
        return self.world

    def _require_world(self) -> World:
        if self.world is None:
            raise RuntimeError("the simulator has no scene yet: call reset(task, seed=...) first")
        return self.world

    # --- reset ------------------------------------------------------------------------------------

    def reset(self, task: Any, *, seed: int) -> ResetResult:
        """Sample, settle and verify ``task``'s initial state from ``seed`` (docs/guide/primitives.md#initial-state-sampling).

        Raises:
            SamplingError: no candidate seed was accepted within ``max_reset_attempts``.
        """
        self._load(tuple(task.objects))
        self.task = task
        result, self.reset_stats = reset_to_task(self.world, self.executor, task, seed, self.options.max_reset_attempts)
        return result

    # --- execution --------------------------------------------------------------------------------

    def execute(self, primitive: str, arguments: Sequence[str], action: np.ndarray) -> PrimitiveResult:
        """Run one primitive with a normalised ``(4,)`` action in ``[-1, 1]`` (docs/guide/primitives.md).

        Raises:
            KeyError: unknown primitive. ValueError: bad arguments or action.
        """
        world = self._require_world()
        self._frames = []
        result = execute_primitive(world, self.executor, primitive, arguments, action)
        frames, self._frames = self._frames, []
        return dataclasses.replace(result, frames=tuple(frames))

    # --- state ------------------------------------------------------------------------------------

    def get_state(self) -> Snapshot:
        """Exact snapshot: MuJoCo integration state (incl. warm start and sleep), weld, controller."""
        return self._require_world().snapshot()

    def set_state(self, snapshot: Snapshot) -> None:
        self._require_world().restore(snapshot)

    def geometric_state(self) -> GeometricState:
        return self._require_world().geometric_state()

    def observation(self) -> np.ndarray:
        world = self._require_world()
        return encode_observation(world.geometric_state(), world.scene.object_names)

    # --- rendering --------------------------------------------------------------------------------

    def _camera_renderer(self) -> CameraRenderer:
        world = self._require_world()
        if self._renderer is None:
            self._renderer = CameraRenderer(world.model, self.options.render_width, self.options.render_height)
        return self._renderer

    def render(self, camera: str | None = None, *, depth: bool = False) -> np.ndarray:
        """``(H, W, 3) uint8`` RGB or ``(H, W) float32`` depth (metres) from a named camera
        (``front``, ``side``, ``top``; default from the options)."""
        renderer = self._camera_renderer()
        name = camera or self.options.camera
        data = self._require_world().data
        return renderer.depth(data, name) if depth else renderer.rgb(data, name)

    def camera_intrinsics(self, camera: str | None = None) -> np.ndarray:
        """``(3, 3)`` pinhole matrix of a camera at the render size."""
        return self._camera_renderer().intrinsics(camera or self.options.camera)

    def stream_frames(self, sink: Callable[[np.ndarray], None] | None) -> None:
        """Send every recorded frame to ``sink`` (e.g. :meth:`t2m_core.video.VideoWriter.add`) as it is
        rendered, instead of collecting them in the results; ``None`` stops streaming."""
        self._frame_sink = sink

    def _on_tick(self) -> None:
        if self._frame_sink is None and not self.options.record_video:
            return
        frame = self.render()
        if self._frame_sink is not None:
            self._frame_sink(frame)
        else:
            self._frames.append(frame)

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
        self.world = None
        self.executor = None
