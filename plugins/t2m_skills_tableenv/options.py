"""Options of the learned TableEnv skill library (``--set skills.options.<key>=...``)."""

from __future__ import annotations

from pathlib import Path

from pydantic import BaseModel, ConfigDict, Field

SHIPPED_CHECKPOINTS = Path(__file__).parent / "checkpoints"
"""The checkpoints installed with t2m: one directory per skill."""


class TableEnvSkillsOptions(BaseModel):
    """Where the library's checkpoints, and optionally its separate OOD detectors, are."""

    model_config = ConfigDict(extra="forbid")

    checkpoints: Path | None = Field(
        None,
        description="directory with one checkpoint directory per skill (pick/, place/, pull/, push/); "
        "null: the checkpoints shipped with t2m",
    )

    ood_detectors: Path | None = Field(
        None,
        description="directory with one checkpoint directory per skill whose calibrated Q-ensembles detect out-of-distribution "
        "calls instead of the library's own (for instance ensembles trained with `t2m train --ood-exposure`); the planner's "
        "values still come from `checkpoints`. null: each Q-ensemble's own variance (published)",
    )

    @property
    def checkpoint_directory(self) -> Path:
        """The directory to load: ``checkpoints`` or the shipped one."""
        return self.checkpoints if self.checkpoints is not None else SHIPPED_CHECKPOINTS
