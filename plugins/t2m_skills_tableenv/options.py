"""Options of the learned TableEnv skill library (``--set skills.options.<key>=...``)."""

from __future__ import annotations

from pathlib import Path

from pydantic import BaseModel, ConfigDict, Field

SHIPPED_CHECKPOINTS = Path(__file__).parent / "checkpoints"
"""The checkpoints installed with t2m: one directory per skill."""


class TableEnvSkillsOptions(BaseModel):
    """Where the library's checkpoints are."""

    model_config = ConfigDict(extra="forbid")

    checkpoints: Path | None = Field(
        None,
        description="directory with one checkpoint directory per skill (pick/, place/, pull/, push/); "
        "null: the checkpoints shipped with t2m",
    )

    @property
    def checkpoint_directory(self) -> Path:
        """The directory to load: ``checkpoints`` or the shipped one."""
        return self.checkpoints if self.checkpoints is not None else SHIPPED_CHECKPOINTS
