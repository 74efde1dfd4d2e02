"""Offscreen rendering of the scene's named cameras: RGB and depth, headless through EGL.

``MUJOCO_GL`` must be chosen before MuJoCo is first imported; :func:`prefer_headless_gl` picks EGL
when no display is available (OSMesa also works if set by the user).
"""

from __future__ import annotations

import os

import numpy as np

from t2m_core.simulation.scene import camera_intrinsics


def prefer_headless_gl() -> None:
    """Use EGL for offscreen rendering unless the user chose a backend or a display exists."""
    if "MUJOCO_GL" not in os.environ and not os.environ.get("DISPLAY"):
        os.environ["MUJOCO_GL"] = "egl"


class CameraRenderer:
    """Renders a model's named cameras at a fixed size; created on first use (needs a GL context).

    Args:
        model, data: the ``mujoco.MjModel`` and the ``MjData`` to render.
        width, height: image size in pixels.
    """

    def __init__(self, model, data, width: int, height: int) -> None:
        import mujoco

        self._mujoco = mujoco
        self.model, self.data = model, data
        self.cameras = tuple(model.camera(i).name for i in range(model.ncam))
        try:
            self._renderer = mujoco.Renderer(model, height=height, width=width)
        except Exception as error:  # GL context creation failures carry little context
            raise RuntimeError(
                f"cannot create a {width}x{height} MuJoCo renderer with MUJOCO_GL={os.environ.get('MUJOCO_GL')!r}: {error}",
            ) from error

    def check_camera(self, camera: str) -> None:
        if camera not in self.cameras:
            raise ValueError(f"unknown camera {camera!r}; cameras: {', '.join(self.cameras)}")

    def rgb(self, camera: str) -> np.ndarray:
        """``(H, W, 3) uint8`` colour image from ``camera``."""
        self.check_camera(camera)
        self._renderer.disable_depth_rendering()
        self._renderer.update_scene(self.data, camera=camera)
        return self._renderer.render().copy()

    def depth(self, camera: str) -> np.ndarray:
        """``(H, W) float32`` depth in metres along the camera axis."""
        self.check_camera(camera)
        self._renderer.enable_depth_rendering()
        self._renderer.update_scene(self.data, camera=camera)
        image = self._renderer.render().astype(np.float32)
        self._renderer.disable_depth_rendering()
        return image

    def intrinsics(self, camera: str) -> np.ndarray:
        """``(3, 3)`` pinhole matrix of ``camera`` at this renderer's size."""
        self.check_camera(camera)
        fovy = float(self.model.cam_fovy[self.model.camera(camera).id])
        return camera_intrinsics(fovy, self._renderer.width, self._renderer.height)

    def close(self) -> None:
        self._renderer.close()
