"""Options every physics backend's simulator has (rendering, video, reset); a backend's own options
model subclasses :class:`SimulatorOptions` and adds its physics settings, including ``substeps``."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field


class SimulatorOptions(BaseModel):
    """Rendering, video and reset options shared by every backend (validated from
    ``--set simulator.options...`` and config files)."""

    model_config = ConfigDict(extra="forbid")

    render_width: int = Field(480, ge=16, le=4096, description="rendered image width, pixels")
    render_height: int = Field(360, ge=16, le=4096, description="rendered image height, pixels")
    camera: str = Field("front", description="default camera: front, side or top")
    record_video: bool = Field(False, description="return rendered frames with every primitive result")
    video_fps: int = Field(15, ge=1, le=60, description="frames per simulated second when recording")
    max_reset_attempts: int = Field(100, ge=1, description="candidate seeds a reset tries before giving up")

    @property
    def timestep(self) -> float:
        """Physics timestep in seconds: a 1/60 s tick is ``substeps`` physics steps."""
        return 1.0 / (60.0 * self.substeps)
