"""Options of the learned TableEnv skill library (``--set skills.options.<key>=...``)."""

from __future__ import annotations

from pathlib import Path

from pydantic import BaseModel, ConfigDict, Field, model_validator

SHIPPED_CHECKPOINTS = Path(__file__).parent / "checkpoints"
"""The checkpoints installed with t2m: one directory per skill."""

DETECTORS_FOLDER = "ood_detectors"
"""The folder of a checkpoints directory that holds its separate OOD detectors, one per skill."""


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
        "values still come from `checkpoints`. null: the checkpoints directory's ood_detectors/ when it has one",
    )
    published_ood: bool = Field(
        False, description="true: each skill's own Q-ensemble detects out-of-distribution calls, as published, whatever detectors exist"
    )

    @model_validator(mode="after")
    def _one_detector_choice(self) -> TableEnvSkillsOptions:
        if self.published_ood and self.ood_detectors is not None:
            raise ValueError("published_ood and ood_detectors exclude each other: the Q-ensembles detect, or the detectors do")
        return self

    @property
    def checkpoint_directory(self) -> Path:
        """The directory to load: ``checkpoints`` or the shipped one."""
        return self.checkpoints if self.checkpoints is not None else SHIPPED_CHECKPOINTS

    @property
    def detector_directory(self) -> Path | None:
        """The separate detectors to load (``ood_detectors``, else the checkpoints directory's
        ``ood_detectors/`` when it exists), or ``None``: the Q-ensembles detect."""
        if self.published_ood:
            return None
        if self.ood_detectors is not None:
            return self.ood_detectors
        folder = self.checkpoint_directory / DETECTORS_FOLDER
        return folder if folder.is_dir() else None
