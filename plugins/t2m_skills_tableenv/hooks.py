"""Registers the learned TableEnv skill library. Import-light: torch loads only when it is built."""

from __future__ import annotations

from t2m_core.hookspecs import hookimpl
from t2m_core.plugin_specs import SkillLibrarySpec
from t2m_skills_tableenv.options import TableEnvSkillsOptions

TABLEENV_SKILLS = SkillLibrarySpec(
    name="tableenv",
    factory="t2m_skills_tableenv.library:load_library",
    options=TableEnvSkillsOptions,
    summary="Learned pick, place, pull, push: Q-ensembles, policies, dynamics (shipped checkpoints, default)",
    trainer="t2m_skills_tableenv.training:train_skill",
    calibrator="t2m_skills_tableenv.calibration:calibrate_skill",
    reporter="t2m_skills_tableenv.report:report_library",
)


@hookimpl
def t2m_register_skills() -> list[SkillLibrarySpec]:
    return [TABLEENV_SKILLS]
