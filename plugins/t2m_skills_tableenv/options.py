"""Options of the learned TableEnv skill library (``--set skills.options.<key>=...``)."""

from __future__ import annotations

from pathlib import Path

from pydantic import BaseModel, ConfigDict, Field

SHIPPED_CHECKPOINTS = Path(__file__).parent / "checkpoints"
"""The checkpoints installed with t2m: one directory per skill."""


class TableEnvSkillsOptions(BaseModel):
    """Where the library's checkpoints are."""

    model_config = ConfigDict(extra="forbid")

    checkpoints: Path = Field(
        SHIPPED_CHECKPOINTS,
        description="directory with one checkpoint directory per skill (pick/, place/, pull/, push/); "
        "default: the checkpoints shipped with t2m",
    )
