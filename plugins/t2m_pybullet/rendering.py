"""Offscreen rendering of the named cameras with PyBullet's software TinyRenderer: RGB and depth.

The cameras are those of every backend (:data:`t2m_core.simulation.scene.CAMERAS`); no display or GL
context is needed.
"""

from __future__ import annotations

import numpy as np

from t2m_core.simulation.scene import camera_axes, camera_intrinsics, check_camera

NEAR, FAR = 0.05, 10.0
"""Metres: the clipping planes of the projection."""
LIGHT_DIRECTION = (0.8, 0.6, 2.0)
"""Towards the key light, as MuJoCo's scene lights it (no shadows: they triple the rendering time)."""


class CameraRenderer:
    """Renders a client's scene from the named cameras at a fixed size.

    Args:
        client: the PyBullet client.
        width, height: image size in pixels.
    """

    def __init__(self, client, width: int, height: int) -> None:
        import pybullet

        self._pybullet = pybullet
        self.client, self.width, self.height = client, int(width), int(height)
        self._matrices: dict[str, tuple[list[float], list[float]]] = {}

    def _camera(self, camera: str) -> tuple[list[float], list[float]]:
        if camera not in self._matrices:
            position, target, fovy = check_camera(camera)
            _right, up = camera_axes(position, target)
            view = self.client.computeViewMatrix(list(position), list(target), up.tolist())
            projection = self.client.computeProjectionMatrixFOV(fovy, self.width / self.height, NEAR, FAR)
            self._matrices[camera] = (view, projection)
        return self._matrices[camera]

    def _render(self, camera: str):
        view, projection = self._camera(camera)
        return self.client.getCameraImage(
            self.width, self.height, view, projection, renderer=self._pybullet.ER_TINY_RENDERER, shadow=0,
            lightDirection=list(LIGHT_DIRECTION), flags=self._pybullet.ER_NO_SEGMENTATION_MASK,
        )

    def rgb(self, camera: str) -> np.ndarray:
        """``(H, W, 3) uint8`` colour image from ``camera``."""
        rgba = np.asarray(self._render(camera)[2], dtype=np.uint8).reshape(self.height, self.width, 4)
        return np.ascontiguousarray(rgba[..., :3])

    def depth(self, camera: str) -> np.ndarray:
        """``(H, W) float32`` depth in metres along the camera axis."""
        buffer = np.asarray(self._render(camera)[3], dtype=np.float64).reshape(self.height, self.width)
        # the depth buffer is non-linear in [0, 1]; this is its inverse for a perspective projection
        return (FAR * NEAR / (FAR - (FAR - NEAR) * buffer)).astype(np.float32)

    def intrinsics(self, camera: str) -> np.ndarray:
        """``(3, 3)`` pinhole matrix of ``camera`` at this renderer's size."""
        return camera_intrinsics(check_camera(camera)[2], self.width, self.height)
