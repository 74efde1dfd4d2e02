"""Options of the MuJoCo simulator (validated from ``--set sim.options...`` and config files)."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field


class MujocoOptions(BaseModel):
    """How the MuJoCo backend simulates and renders.

    The physics timestep is ``1 / (60 · substeps)`` seconds: a 1/60 s control tick (the reference's
    unit of timeouts and settling) is ``substeps`` MuJoCo steps, run in one ``mj_step`` call.
    """

    model_config = ConfigDict(extra="forbid")

    substeps: int = Field(8, ge=2, le=64, description="physics steps per 1/60 s tick (8 gives ≈2.08 ms steps)")
    render_width: int = Field(480, ge=16, le=4096, description="rendered image width, pixels")
    render_height: int = Field(360, ge=16, le=4096, description="rendered image height, pixels")
    camera: str = Field("front", description="default camera: front, side or top")
    record_video: bool = Field(False, description="return rendered frames with every primitive result")
    video_fps: int = Field(15, ge=1, le=60, description="frames per simulated second when recording")
    max_reset_attempts: int = Field(100, ge=1, description="candidate seeds a reset tries before giving up")

    @property
    def timestep(self) -> float:
        """Physics timestep in seconds."""
        return 1.0 / (60.0 * self.substeps)
