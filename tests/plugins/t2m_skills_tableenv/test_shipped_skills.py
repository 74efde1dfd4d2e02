"""The checkpoints shipped with t2m load without training or download and pass the skill
conformance check; STAP plans with them (docs/guide/skills.md#checkpoints)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from t2m_core.data.scenes import DATA_SKILLS
from t2m_core.testing import check_feasibility_planner, check_skill
from t2m_skills_tableenv.library import load_library
from t2m_skills_tableenv.options import SHIPPED_CHECKPOINTS, TableEnvSkillsOptions


@pytest.fixture(scope="module")
def library():
    return load_library()


@pytest.mark.parametrize("name", DATA_SKILLS)
def test_every_shipped_skill_conforms(library, name: str) -> None:
    check_skill(library[name])


@pytest.mark.parametrize("name", DATA_SKILLS)
def test_every_shipped_checkpoint_records_its_training_data_and_ood_threshold(name: str) -> None:
    config = json.loads((SHIPPED_CHECKPOINTS / name / "config.json").read_text())
    assert config["skill"] == name and set(config["models"]) == {"q", "policy", "dynamics"}
    for model in config["models"].values():
        assert len(model["data"]["train"]) == 64 and model["result"]["steps"] > 0  # sha256 of the data manifest
    ood = config["ood"]
    assert 0 < ood["threshold"] <= 0.25 and ood["false_positive_rate"] <= 0.011
    assert (SHIPPED_CHECKPOINTS / name / ood["plot"]).stat().st_size > 1000


def test_the_shipped_library_is_small() -> None:
    total = sum(p.stat().st_size for p in SHIPPED_CHECKPOINTS.rglob("*") if p.is_file())
    assert total < 40 * 2**20, f"{total / 2**20:.1f} MB of checkpoints"
    assert not list(SHIPPED_CHECKPOINTS.rglob(".training")), "resumable training states are not shipped"


def test_policy_cem_plans_a_task_skeleton_with_the_shipped_skills(library) -> None:
    from t2m_core.domain.observation import encode_observation
    from t2m_core.domain.sampling import sample_task
    from t2m_core.tasks import load_task
    from t2m_stap.options import CEMOptions
    from t2m_stap.planners import CrossEntropyMethod

    task = load_task("task3")
    observation = encode_observation(sample_task(task, 0).state, task.objects)
    check_feasibility_planner(CrossEntropyMethod(CEMOptions(population=200, iterations=3)), observation,
                              list(task.reference_skeleton[:3]), library, task.objects)
    policy_first = CrossEntropyMethod(CEMOptions(population=300, iterations=3)).plan(observation, list(task.reference_skeleton[:2]), library, task.objects)
    assert np.all(np.isfinite(policy_first.states))


SHIPPED_POLICY_FLOORS = {"pick": 0.6, "place": 0.65, "pull": 0.6, "push": 0.5}
"""Simulated success of the shipped policies in 20 evaluation scenes, well below what the report
measured on them over 100 (docs/guide/skills.md#the-shipped-checkpoints): a floor that catches a
broken or mismatched checkpoint, not a quality target."""


@pytest.mark.parametrize("name", DATA_SKILLS)
def test_every_shipped_policy_succeeds_in_simulation(library, name: str) -> None:
    from t2m_core.registry import get_registry
    from t2m_skills_tableenv.episodes import policy_success

    simulator = get_registry().create("simulator", "mujoco")
    result = policy_success(name, library[name].policy, simulator, 20, seed=7)
    assert result["episodes"] >= 18
    assert result["success_rate"] >= SHIPPED_POLICY_FLOORS[name], result["outcomes"]


@pytest.mark.slow
def test_the_report_measures_the_shipped_library_in_simulation(tmp_path) -> None:
    from typer.testing import CliRunner

    from t2m_core.cli.main import app

    result = CliRunner().invoke(app, ["skills", "report", "--episodes", "2", "--out", str(tmp_path), "--json"])
    assert result.exit_code == 0, result.output
    report = json.loads((tmp_path / "report.json").read_text())
    assert set(report) == set(DATA_SKILLS)
    for entry in report.values():
        policy = entry["policy"]
        assert policy["episodes"] == 2 and sum(policy["outcomes"].values()) >= 2 and 0 <= policy["success_rate"] <= 1
        assert entry["ood"]["threshold"] > 0
    assert "| pick |" in (tmp_path / "report.md").read_text()


@pytest.mark.parametrize("name", DATA_SKILLS)
def test_the_shipped_detectors_flag_invalid_calls_they_never_saw(library, name: str, tmp_path) -> None:
    """Invalid pairs (symbolically invalid calls, uniform actions) of a seed that neither the
    calibration (0) nor the OOD exposure (1) used: the published floor is 90 % detected."""
    from t2m_core.data.generate import DatasetJob, generate_dataset
    from t2m_core.ood import ood_variance
    from t2m_skills_tableenv.dataset import SkillTensors

    generate_dataset(DatasetJob(tmp_path, name, "invalid", 500, 500, base_seed=11))
    pairs = SkillTensors.load(tmp_path / name / "invalid")
    skill = library[name]
    states = pairs.states()
    q = skill.q_values(states, pairs.actions)
    flagged = np.asarray(ood_variance(skill, states, pairs.actions, q)) >= skill.ood_threshold
    assert len(pairs) == 500 and skill.detector is not None
    assert flagged.mean() >= 0.9
    # the published detector, each Q-ensemble's own spread and threshold, finds few of them
    published = load_library(TableEnvSkillsOptions(published_ood=True))[name]
    assert published.detector is None
    assert (np.asarray(ood_variance(published, states, pairs.actions, q)) >= published.ood_threshold).mean() < 0.5
