"""Checkpoints: round trip, clear errors for corrupt or mismatched files, OOD calibration rule."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch

from t2m_skills_tableenv.calibration import choose_threshold, per_bin_rates
from t2m_skills_tableenv.checkpoints import CheckpointError, load_weights, read_config, save_weights, update_config
from t2m_skills_tableenv.library import TableEnvSkill
from t2m_skills_tableenv.networks import Dynamics, GaussianPolicy, QEnsemble
from t2m_skills_tableenv.training import ARCHITECTURES, WEIGHT_FILES


def write_checkpoint(directory, threshold=0.05) -> dict:
    networks = {"q": QEnsemble(), "policy": GaussianPolicy(), "dynamics": Dynamics()}
    for model, network in networks.items():
        save_weights(directory / WEIGHT_FILES[model], network)
    update_config(directory, skill="pick", models={m: {"file": WEIGHT_FILES[m], "architecture": ARCHITECTURES[m]} for m in networks},
                  ood={"threshold": threshold})
    return networks


def test_a_checkpoint_round_trips_exactly(tmp_path) -> None:
    networks = write_checkpoint(tmp_path)
    skill = TableEnvSkill.load(tmp_path)
    states, actions = torch.rand(6, 96) - 0.5, torch.rand(6, 4) * 2 - 1
    torch.testing.assert_close(skill.q_values(states, actions), networks["q"].probabilities(states, actions), rtol=0, atol=0)
    torch.testing.assert_close(skill.policy(states), networks["policy"](states), rtol=0, atol=0)
    assert skill.ood_threshold == 0.05 and skill.name == "pick"
    assert isinstance(skill.q_values(states.numpy(), actions.numpy()), np.ndarray)  # answers in kind


def test_a_corrupt_weights_file_is_an_error_that_names_it(tmp_path) -> None:
    write_checkpoint(tmp_path)
    path = tmp_path / "policy.safetensors"
    path.write_bytes(path.read_bytes()[:1000])
    with pytest.raises(CheckpointError, match="policy.safetensors is corrupt"):
        TableEnvSkill.load(tmp_path)


def test_weights_of_another_network_are_refused_by_name(tmp_path) -> None:
    write_checkpoint(tmp_path)
    save_weights(tmp_path / "dynamics.safetensors", GaussianPolicy())
    with pytest.raises(CheckpointError, match="dynamics.safetensors does not fit the Dynamics network"):
        TableEnvSkill.load(tmp_path)


def test_a_missing_or_foreign_config_is_explained(tmp_path) -> None:
    with pytest.raises(CheckpointError, match="no config.json"):
        read_config(tmp_path)
    (tmp_path / "config.json").write_text(json.dumps({"format": "something-else"}))
    with pytest.raises(CheckpointError, match="is not a t2m-skill/1 skill checkpoint"):
        read_config(tmp_path)
    (tmp_path / "config.json").write_text("{ not json")
    with pytest.raises(CheckpointError, match="not valid JSON"):
        read_config(tmp_path)
    with pytest.raises(CheckpointError, match="is missing"):
        load_weights(tmp_path / "absent.safetensors", Dynamics())


def test_the_threshold_flags_at_most_one_percent_of_in_distribution_pairs_in_every_bin() -> None:
    rng = np.random.default_rng(0)
    mean = rng.uniform(0, 1, 20_000)
    variance = rng.exponential(1e-4, 20_000) * (1 + 10 * (mean > 0.5))  # one bin family is noisier
    threshold = choose_threshold(mean, variance)
    for row in per_bin_rates(mean, variance, threshold):
        assert row["flagged"] <= 0.01 + 1e-9
    # and it is the smallest such: just below it, the noisiest bin flags more than 1 %
    assert max(r["flagged"] for r in per_bin_rates(mean, variance, threshold * 0.97)) > 0.01


def test_a_library_refuses_a_checkpoint_of_another_skill_in_a_skills_place(tmp_path) -> None:
    from t2m_skills_tableenv.library import load_library
    from t2m_skills_tableenv.options import TableEnvSkillsOptions

    for name in ("pick", "place", "pull", "push"):
        write_checkpoint(tmp_path / name)  # every one says skill "pick"
    with pytest.raises(CheckpointError, match="holds a 'pick' skill, not 'place'"):
        load_library(TableEnvSkillsOptions(checkpoints=tmp_path))


def test_a_separate_detector_judges_ood_with_its_own_ensemble_and_threshold(tmp_path) -> None:
    from t2m_core.ood import ood_variance

    own = write_checkpoint(tmp_path / "own" / "pick", threshold=0.05)
    detector = write_checkpoint(tmp_path / "detector" / "pick", threshold=0.2)["q"]
    skill = TableEnvSkill.load(tmp_path / "own" / "pick")
    detected = skill.with_detector(tmp_path / "detector" / "pick")
    states, actions = torch.rand(6, 96) - 0.5, torch.rand(6, 4) * 2 - 1
    q = detected.q_values(states, actions)
    torch.testing.assert_close(q, own["q"].probabilities(states, actions), rtol=0, atol=0)  # values stay the library's
    expected = np.var(detector.probabilities(states, actions).detach().numpy(), axis=1)
    assert not np.allclose(expected, np.var(q.numpy(), axis=1))  # another ensemble than the values'
    np.testing.assert_allclose(ood_variance(detected, states, actions, q).numpy(), expected, rtol=1e-5, atol=1e-8)
    assert detected.ood_threshold == 0.2 and skill.ood_threshold == 0.05
    # without a detector the statistic is the members' own variance, also for NumPy callers
    members = q.numpy()
    np.testing.assert_allclose(ood_variance(skill, states.numpy(), actions.numpy(), members), np.var(members, axis=1), rtol=1e-6)


def test_a_detector_must_be_the_same_skill_and_calibrated(tmp_path) -> None:
    write_checkpoint(tmp_path / "own")
    skill = TableEnvSkill.load(tmp_path / "own")
    write_checkpoint(tmp_path / "uncalibrated")
    config = read_config(tmp_path / "uncalibrated")
    del config["ood"]
    (tmp_path / "uncalibrated" / "config.json").write_text(json.dumps(config))
    with pytest.raises(CheckpointError, match="no OOD threshold") as refused:
        skill.with_detector(tmp_path / "uncalibrated")
    assert "t2m calibrate --skill pick" in refused.value.hint
    write_checkpoint(tmp_path / "other")
    update_config(tmp_path / "other", skill="push")
    with pytest.raises(CheckpointError, match="holds a 'push' skill, not 'pick'"):
        skill.with_detector(tmp_path / "other")
    with pytest.raises(CheckpointError, match="config.json"):
        skill.with_detector(tmp_path / "missing")


def test_a_library_loads_the_detectors_it_holds_unless_told_otherwise(tmp_path) -> None:
    from pydantic import ValidationError

    from t2m_skills_tableenv.library import load_library
    from t2m_skills_tableenv.options import TableEnvSkillsOptions

    for name in ("pick", "place", "pull", "push"):
        write_checkpoint(tmp_path / "library" / name, threshold=0.05)
        update_config(tmp_path / "library" / name, skill=name)
    plain = load_library(TableEnvSkillsOptions(checkpoints=tmp_path / "library"))
    assert all(skill.detector is None and skill.ood_threshold == 0.05 for skill in plain.values())
    for name in ("pick", "place", "pull", "push"):
        write_checkpoint(tmp_path / "library" / "ood_detectors" / name, threshold=0.2)
        update_config(tmp_path / "library" / "ood_detectors" / name, skill=name)
    held = load_library(TableEnvSkillsOptions(checkpoints=tmp_path / "library"))
    assert all(skill.detector is not None and skill.ood_threshold == 0.2 for skill in held.values())
    assert held["push"].detector_directory == tmp_path / "library" / "ood_detectors" / "push"
    published = load_library(TableEnvSkillsOptions(checkpoints=tmp_path / "library", published_ood=True))
    assert all(skill.detector is None and skill.ood_threshold == 0.05 for skill in published.values())
    with pytest.raises(ValidationError, match="exclude each other"):
        TableEnvSkillsOptions(published_ood=True, ood_detectors=tmp_path)
