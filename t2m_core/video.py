"""MP4 writing for execution videos: frames in, an H.264 file out, never a partial file.

Frames go to a temporary file next to the destination, which replaces the destination only when
the video is complete (``os.replace``), so an interrupted run never leaves a broken ``video.mp4``.
A run killed outright (``SIGKILL``) cannot remove its temporary file; the next writer for the same
destination does.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Iterable
from pathlib import Path
from types import TracebackType

import numpy as np


class VideoWriter:
    """Streams ``(H, W, 3) uint8`` RGB frames into an MP4 at ``path``.

    Use as a context manager; the file appears at ``path`` when the block exits without an error::

        with VideoWriter(out / "video.mp4", fps=30) as video:
            for frame in frames:
                video.add(frame)

    Args:
        path: destination ``.mp4`` file; its directory must exist.
        fps: frames per second of playback.
    """

    def __init__(self, path: str | os.PathLike[str], fps: float = 30.0) -> None:
        self.path = Path(path)
        if self.path.suffix.lower() != ".mp4":
            raise ValueError(f"video path must end in .mp4, got {self.path}")
        if not self.path.parent.is_dir():
            raise FileNotFoundError(f"directory of {self.path} does not exist; create it first")
        if fps <= 0:
            raise ValueError(f"fps must be positive, got {fps}")
        self.fps = float(fps)
        self.frames_written = 0
        self._writer = None
        self._size: tuple[int, int] | None = None
        for stale in self.path.parent.glob(f".{self.path.stem}-*.mp4"):  # left by a killed writer
            stale.unlink(missing_ok=True)
        handle, temporary = tempfile.mkstemp(prefix=f".{self.path.stem}-", suffix=".mp4", dir=self.path.parent)
        os.close(handle)
        self._temporary = Path(temporary)

    def add(self, frame: np.ndarray) -> None:
        """Append one ``(H, W, 3) uint8`` frame; every frame must have the first frame's size."""
        frame = np.asarray(frame)
        if frame.ndim != 3 or frame.shape[2] != 3 or frame.dtype != np.uint8:
            raise ValueError(f"a video frame must be (H, W, 3) uint8, got {frame.shape} {frame.dtype}")
        height, width = frame.shape[:2]
        if self._writer is None:
            import imageio_ffmpeg

            self._size = (width, height)
            self._writer = imageio_ffmpeg.write_frames(
                str(self._temporary), (width, height), fps=self.fps, codec="libx264", macro_block_size=1,
                ffmpeg_log_level="error",
            )
            self._writer.send(None)
        elif (width, height) != self._size:
            raise ValueError(f"frame size {width}x{height} differs from the video's {self._size[0]}x{self._size[1]}")
        self._writer.send(np.ascontiguousarray(frame))
        self.frames_written += 1

    def close(self) -> Path:
        """Finish the file and move it into place; returns its path. Raises if no frame was added."""
        if self._writer is None:
            self._discard()
            raise ValueError(f"no frames were written to {self.path}")
        self._writer.close()
        self._writer = None
        os.chmod(self._temporary, 0o644)  # mkstemp creates 0600; a video is for sharing
        os.replace(self._temporary, self.path)
        return self.path

    def _discard(self) -> None:
        if self._writer is not None:
            self._writer.close()
            self._writer = None
        self._temporary.unlink(missing_ok=True)

    def __enter__(self) -> VideoWriter:
        return self

    def __exit__(
        self, kind: type[BaseException] | None, error: BaseException | None, traceback: TracebackType | None
    ) -> None:
        if kind is None:
            self.close()
        else:
            self._discard()


def write_mp4(path: str | os.PathLike[str], frames: Iterable[np.ndarray], fps: float = 30.0) -> Path:
    """Write ``frames`` (each ``(H, W, 3) uint8``) to an MP4 at ``path`` atomically; returns the path."""
    with VideoWriter(path, fps) as video:
        for frame in frames:
            video.add(frame)
    return video.path
