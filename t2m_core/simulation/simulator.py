"""The :class:`t2m_core.protocols.Simulator` of any physics backend: scenes, reset, execution,
snapshots, rendering and video, over one :class:`~t2m_core.simulation.backend.PhysicsBackend` per scene.

A backend's simulator subclasses :class:`PhysicsSimulator` and says how to build a world for a set
of objects and how to render it; everything else is the same for every engine.
"""

from __future__ import annotations

import dataclasses
from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from typing import Any, Protocol

import numpy as np

from t2m_core.domain.observation import encode_observation
from t2m_core.domain.state import GeometricState
from t2m_core.protocols import PrimitiveResult, ResetResult
from t2m_core.simulation.backend import PhysicsBackend
from t2m_core.simulation.execution import execute_primitive
from t2m_core.simulation.motion import MotionExecutor
from t2m_core.simulation.reset import reset_to_task


class CameraRenderer(Protocol):
    """Renders one world from the named cameras (:data:`t2m_core.simulation.scene.CAMERAS`) at a fixed size."""

    def rgb(self, camera: str) -> np.ndarray:
        """``(H, W, 3) uint8``; ``ValueError`` for an unknown camera."""
        ...

    def depth(self, camera: str) -> np.ndarray:
        """``(H, W) float32`` metres along the camera axis."""
        ...

    def intrinsics(self, camera: str) -> np.ndarray:
        """``(3, 3)`` pinhole matrix at the render size."""
        ...


class PhysicsSimulator(ABC):
    """A simulator over a physics backend.

    Args:
        options: the backend's validated options; they need ``video_fps``, ``record_video``,
            ``camera`` and ``max_reset_attempts``.

    Attributes:
        world: the backend of the current scene (``None`` before the first reset).
        executor: the motion executor driving it.
        reset_stats: after each reset, ``{"sampler_rejections", "physics_rejections", "reasons"}``.
    """

    def __init__(self, options: Any) -> None:
        self.options = options
        self.world: Any = None
        self.executor: MotionExecutor | None = None
        self.task: Any = None
        self.reset_stats: dict[str, Any] = {}
        self._renderer: CameraRenderer | None = None
        self._frames: list[np.ndarray] = []
        self._frame_sink: Callable[[np.ndarray], None] | None = None

    # --- what a backend provides ------------------------------------------------------------------

    @abstractmethod
    def _create_world(self, object_names: tuple[str, ...]) -> PhysicsBackend:
        """A world holding the robot and ``object_names`` (table first)."""

    @abstractmethod
    def _create_renderer(self, world: Any) -> CameraRenderer:
        """A renderer of ``world`` at the options' render size."""

    # --- scene ------------------------------------------------------------------------------------

    def _load(self, object_names: tuple[str, ...]) -> PhysicsBackend:
        if self.world is None or self.world.object_names != object_names:
            self._close_world()
            self.world = self._create_world(object_names)
            frame_every = max(1, round(60 / self.options.video_fps))
            self.executor = MotionExecutor(self.world, on_tick=self._on_tick, frame_every=frame_every)
        return self.world

    def _require_world(self) -> Any:
        if self.world is None:
            raise RuntimeError("the simulator has no scene yet: call reset(task, seed=...) first")
        return self.world

    # --- reset and execution ----------------------------------------------------------------------

    def reset(self, task: Any, *, seed: int) -> ResetResult:
        """Sample, settle and verify ``task``'s initial state from ``seed``
        (docs/guide/primitives.md#initial-state-sampling).

        Raises:
            SamplingError: no candidate seed was accepted within ``max_reset_attempts``.
        """
        self._load(tuple(task.objects))
        self.task = task
        result, self.reset_stats = reset_to_task(self.world, self.executor, task, seed, self.options.max_reset_attempts)
        return result

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

    def get_state(self) -> Any:
        """An exact snapshot of the physics and the controller (opaque)."""
        return self._require_world().snapshot()

    def set_state(self, snapshot: Any) -> None:
        self._require_world().restore(snapshot)

    def geometric_state(self) -> GeometricState:
        return self._require_world().geometric_state()

    def observation(self) -> np.ndarray:
        world = self._require_world()
        return encode_observation(world.geometric_state(), world.object_names)

    # --- rendering --------------------------------------------------------------------------------

    def _camera_renderer(self) -> CameraRenderer:
        world = self._require_world()
        if self._renderer is None:
            self._renderer = self._create_renderer(world)
        return self._renderer

    def render(self, camera: str | None = None, *, depth: bool = False) -> np.ndarray:
        """``(H, W, 3) uint8`` RGB or ``(H, W) float32`` depth (metres) from a named camera
        (``front``, ``side``, ``top``; default from the options)."""
        renderer = self._camera_renderer()
        name = camera or self.options.camera
        return renderer.depth(name) if depth else renderer.rgb(name)

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

    def _close_world(self) -> None:
        if self._renderer is not None and hasattr(self._renderer, "close"):
            self._renderer.close()
        self._renderer = None
        if self.world is not None:
            self.world.close()
        self.world = None
        self.executor = None

    def close(self) -> None:
        """Release the world and the renderer."""
        self._close_world()
