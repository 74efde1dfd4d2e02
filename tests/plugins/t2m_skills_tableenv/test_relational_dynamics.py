"""The relational dynamics model: its prediction permutes with the other objects, leaves empty rows
alone, learns a relation to another object in any row, and is built from the checkpoint's config
(docs/guide/skills.md#relational-dynamics)."""

from __future__ import annotations

import pytest
import torch
from torch import nn

from t2m_core.errors import T2MError
from t2m_skills_tableenv.checkpoints import CheckpointError, load_dynamics, save_weights, update_config
from t2m_skills_tableenv.dataset import SkillTensors
from t2m_skills_tableenv.library import TableEnvSkill
from t2m_skills_tableenv.networks import Dynamics, GaussianPolicy, QEnsemble, RelationalDynamics, dynamics_architecture
from t2m_skills_tableenv.training import ARCHITECTURES, WEIGHT_FILES, DynamicsStage, StageSettings, run_stage, train_skill
from tests.plugins.t2m_skills_tableenv.rows import EMPTY, rows


def test_the_prediction_permutes_with_the_other_objects() -> None:
    dynamics = RelationalDynamics(context_rows=3)
    states, actions = rows(16, 0), torch.rand(16, 4) * 2 - 1
    order = [0, 1, 2, 6, 3, 7, 5, 4]  # rows 3..7 permuted, the context kept
    predicted = dynamics(states.reshape(16, 96), actions).reshape(16, 8, 12)
    permuted = dynamics(states[:, order].reshape(16, 96), actions).reshape(16, 8, 12)
    torch.testing.assert_close(permuted, predicted[:, order])
    swapped_arguments = states[:, [0, 2, 1, 3, 4, 5, 6, 7]]  # the argument rows are not a set
    assert not torch.allclose(dynamics(swapped_arguments.reshape(16, 96), actions).reshape(16, 8, 12)[:, 3:], predicted[:, 3:])


def test_empty_rows_stay_empty_and_present_objects_count() -> None:
    dynamics = RelationalDynamics(context_rows=2)
    states, actions = rows(8, 1), torch.rand(8, 4) * 2 - 1
    states[:, 5:] = EMPTY
    predicted = dynamics(states.reshape(8, 96), actions).reshape(8, 8, 12)
    torch.testing.assert_close(predicted[:, 5:], states[:, 5:], rtol=0, atol=0)
    one_more_empty = states.clone()
    one_more_empty[:, 4] = EMPTY
    assert not torch.allclose(dynamics(one_more_empty.reshape(8, 96), actions).reshape(8, 8, 12)[:, :2], predicted[:, :2])
    states[:, 2:] = EMPTY  # no other object: the pooled set is empty
    assert torch.isfinite(dynamics(states.reshape(8, 96), actions)).all()


def test_it_learns_where_an_object_lands_beside_another_in_any_row(tmp_path) -> None:
    """The moved object (row 1) lands at the action's (x, y) offset from the flagged object in row
    3, 4 or 5; nothing else moves. The MLP must learn that for each row; the relational model once."""

    def problem(count: int, seed: int) -> SkillTensors:
        generator = torch.Generator().manual_seed(seed)
        data = torch.rand(count, 8, 12, generator=generator) * 0.6 - 0.3
        data[:, 3:6, 11] = -0.5
        data[:, 6:] = EMPTY
        flagged = torch.randint(3, 6, (count,), generator=generator)
        data[torch.arange(count), flagged, 11] = 0.5
        actions = torch.rand(count, 4, generator=generator) * 2 - 1
        after = data.clone()
        after[:, 1, :2] = data[torch.arange(count), flagged, :2] + 0.1 * actions[:, :2]
        return SkillTensors(data, after, torch.tensor([[3, 6]]).expand(count, 2), actions, torch.ones(count))

    train, validation = problem(4096, 0), problem(1024, 1)
    settings = StageSettings(steps=1500, batch_size=256, learning_rate=2e-3, eval_every=500, dynamics_network="relational")
    torch.manual_seed(0)
    stage = DynamicsStage(train, validation, settings, RelationalDynamics(context_rows=3))
    with torch.no_grad():
        before = float(nn.functional.mse_loss(stage.network(validation.states(), validation.actions), validation.next_rows.reshape(1024, -1)))
    result = run_stage(stage, settings, tmp_path)
    # before training the moved row is off by ~0.04 per feature squared over 2 of 96 features
    assert result["best"]["loss"] < 0.1 * before, (before, result)
    predicted = stage.network(validation.states(), validation.actions).detach().reshape(1024, 8, 12)
    error = (predicted[:, 1, :2] - validation.next_rows[:, 1, :2]).abs().median()
    assert error < 0.02, error  # the target moves over ±0.4; guessing the mean misses by ~0.1


def test_a_relational_dynamics_checkpoint_loads_as_its_config_says(tmp_path) -> None:
    architecture = dynamics_architecture("push", "relational")
    assert architecture["context_rows"] == 4 and dynamics_architecture("pick", "relational")["context_rows"] == 2
    dynamics = RelationalDynamics(context_rows=architecture["context_rows"])
    networks = {"q": QEnsemble(), "policy": GaussianPolicy(), "dynamics": dynamics}
    for model, network in networks.items():
        save_weights(tmp_path / WEIGHT_FILES[model], network)
    architectures = {**ARCHITECTURES, "dynamics": architecture}
    update_config(tmp_path, skill="push", models={m: {"file": WEIGHT_FILES[m], "architecture": architectures[m]} for m in networks})
    skill = TableEnvSkill.load(tmp_path)
    states, actions = rows(4, 3).reshape(4, 96), torch.rand(4, 4)
    torch.testing.assert_close(skill.predict(states, actions), dynamics(states, actions), rtol=0, atol=0)
    # the config and the weights must agree, and an unknown type is named
    update_config(tmp_path, models={m: {"file": WEIGHT_FILES[m], "architecture": ARCHITECTURES[m]} for m in networks})
    with pytest.raises(CheckpointError, match="does not fit the Dynamics network"):
        load_dynamics(tmp_path)
    update_config(tmp_path, models={"dynamics": {"file": WEIGHT_FILES["dynamics"], "architecture": {"type": "Transformer"}}})
    with pytest.raises(CheckpointError, match="unknown dynamics type 'Transformer'"):
        load_dynamics(tmp_path)


def test_fine_tuning_into_another_dynamics_network_is_refused(tmp_path, monkeypatch) -> None:
    start = tmp_path / "start" / "place"
    start.mkdir(parents=True)
    save_weights(start / WEIGHT_FILES["dynamics"], Dynamics())
    update_config(start, skill="place", models={"dynamics": {"file": WEIGHT_FILES["dynamics"], "architecture": ARCHITECTURES["dynamics"]}})
    monkeypatch.setattr("t2m_skills_tableenv.training.SkillTensors.load", lambda *directories: SkillTensors(
        rows(8, 4), rows(8, 5), torch.tensor([[3, 8]]).expand(8, 2), torch.zeros(8, 4), torch.ones(8)))
    monkeypatch.setattr("t2m_core.data.generate.manifest_digest", lambda directory: "digest")
    monkeypatch.setattr("t2m_core.data.proposals.checkpoint_digest", lambda directory, skill: "digest")
    with pytest.raises(T2MError, match="holds a mlp dynamics model and the settings train a relational one") as raised:
        train_skill("place", ("dynamics",), tmp_path / "data", tmp_path / "out", {"dynamics_network": "relational"}, init_from=tmp_path / "start")
    assert "--dynamics-network mlp" in raised.value.hint


def test_flop_count_follows_the_layer_sizes() -> None:
    # Place: context 3 rows + action = 40 inputs, 5 other rows of 12, width 128, ρ of 256
    per_object = (40 + 12) * 128 + 128 * 128 + (40 + 12 + 128) * 128 + 128 * 128 + 128 * 12
    rho = (40 + 128) * 256 + 256 * 256 + 256 * 36
    assert RelationalDynamics(context_rows=3).flops_per_sample() == 2 * (5 * per_object + rho)
