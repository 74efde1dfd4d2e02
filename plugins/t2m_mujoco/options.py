"""Options of the MuJoCo simulator (validated from ``--set simulator.options...`` and config files)."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field


class MujocoOptions(BaseModel):
    """How the MuJoCo backend simulates and renders.

    The physics timestep is ``1 / (60 · substeps)`` seconds: a 1/60 s control tick (the reference's
    unit of timeouts and settling) is ``substeps`` MuJoCo steps, run in one ``mj_step`` call. The
    default 5 (3.33 ms) costs 5/8 of the 2 ms-class 8 substeps; resting objects, held objects and the
    measured success rates of every primitive are the same at both (docs/guide/simulators.md).
    """

    model_config = ConfigDict(extra="forbid")

    substeps: int = Field(5, ge=2, le=64, description="physics steps per 1/60 s tick (5 gives ≈3.33 ms steps)")
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
