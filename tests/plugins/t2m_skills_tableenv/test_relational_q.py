"""The relational Q-ensemble: invariant to the order of the other objects, blind to empty rows,
built from the checkpoint's config (docs/guide/skills.md#relational-q-ensemble)."""

from __future__ import annotations

import pytest
import torch

from t2m_skills_tableenv.checkpoints import CheckpointError, load_q, save_weights, update_config
from t2m_skills_tableenv.dataset import SkillTensors
from t2m_skills_tableenv.library import TableEnvSkill
from t2m_skills_tableenv.networks import Dynamics, GaussianPolicy, RelationalQEnsemble, q_architecture
from t2m_skills_tableenv.training import ARCHITECTURES, WEIGHT_FILES, QStage, StageSettings, q_metrics, run_stage
from tests.plugins.t2m_skills_tableenv.rows import EMPTY, rows


def test_the_order_of_the_other_objects_does_not_change_the_values() -> None:
    q = RelationalQEnsemble(context_rows=3)
    states, actions = rows(16, 0), torch.rand(16, 4) * 2 - 1
    shuffled = states[:, [0, 1, 2, 6, 3, 7, 5, 4]]  # rows 3..7 permuted, the context kept
    torch.testing.assert_close(q(shuffled.reshape(16, 96), actions), q(states.reshape(16, 96), actions))
    swapped_arguments = states[:, [0, 2, 1, 3, 4, 5, 6, 7]]  # the argument rows are not a set
    assert not torch.allclose(q(swapped_arguments.reshape(16, 96), actions), q(states.reshape(16, 96), actions))


def test_empty_rows_count_for_nothing_and_present_objects_do() -> None:
    q = RelationalQEnsemble(context_rows=2)
    states, actions = rows(8, 1), torch.rand(8, 4) * 2 - 1
    states[:, 6:] = EMPTY
    one_more_empty = states.clone()
    one_more_empty[:, 5] = EMPTY
    moved = states.clone()
    moved[:, 5] = states[:, 5] + 0.2  # an object at another place changes the answer
    base = q(states.reshape(8, 96), actions)
    assert not torch.allclose(q(one_more_empty.reshape(8, 96), actions), base)
    assert not torch.allclose(q(moved.reshape(8, 96), actions), base)
    # every other row empty: the pooled set is empty, whatever is written nowhere else
    states[:, 2:] = EMPTY
    assert torch.isfinite(q(states.reshape(8, 96), actions)).all()


def test_members_are_independent_and_per_member_inputs_reach_their_member() -> None:
    q = RelationalQEnsemble(context_rows=3)
    states, actions = rows(5, 2).reshape(5, 96), torch.rand(5, 4)
    assert q(states, actions).std(dim=1).min() > 0
    per_member_states = torch.stack([states.roll(m, 0) for m in range(8)])
    per_member_actions = torch.stack([actions.roll(m, 0) for m in range(8)])
    logits = q(per_member_states, per_member_actions)
    torch.testing.assert_close(logits[:, 4], q(states.roll(4, 0), actions.roll(4, 0))[:, 4])


def test_it_learns_a_problem_that_depends_on_another_object_wherever_its_row_is(tmp_path) -> None:
    """Success when the action's x exceeds the x of the object in row 3, 4 or 5 that has a flag set:
    a relation an order-invariant reader must find in any row."""

    def problem(count: int, seed: int) -> SkillTensors:
        generator = torch.Generator().manual_seed(seed)
        data = torch.rand(count, 8, 12, generator=generator) - 0.5
        data[:, 3:6, 11] = -0.5
        flagged = torch.randint(3, 6, (count,), generator=generator)
        data[torch.arange(count), flagged, 11] = 0.5
        actions = torch.rand(count, 4, generator=generator) - 0.5
        rewards = (actions[:, 0] > data[torch.arange(count), flagged, 0]).float()
        return SkillTensors(data, data.clone(), torch.tensor([[3, 6]]).expand(count, 2), actions, rewards)

    train, validation = problem(4096, 0), problem(1024, 1)
    settings = StageSettings(steps=800, batch_size=128, learning_rate=3e-3, eval_every=400, q_network="relational")
    stage = QStage(train, validation, settings, RelationalQEnsemble(context_rows=3))
    result = run_stage(stage, settings, tmp_path)
    assert result["best"]["accuracy"] > 0.85, result
    assert q_metrics(stage.network, validation)["loss"] < 0.6  # the last weights learned it too (chance: 0.69)


def test_a_relational_checkpoint_loads_as_its_config_says(tmp_path) -> None:
    q = RelationalQEnsemble(context_rows=q_architecture("place", "relational")["context_rows"])
    assert q.context_rows == 3 and q_architecture("push", "relational")["context_rows"] == 4
    networks = {"q": q, "policy": GaussianPolicy(), "dynamics": Dynamics()}
    for model, network in networks.items():
        save_weights(tmp_path / WEIGHT_FILES[model], network)
    architectures = {**ARCHITECTURES, "q": q_architecture("place", "relational")}
    update_config(tmp_path, skill="place", models={m: {"file": WEIGHT_FILES[m], "architecture": architectures[m]} for m in networks})
    skill = TableEnvSkill.load(tmp_path)
    states, actions = rows(4, 3).reshape(4, 96), torch.rand(4, 4)
    torch.testing.assert_close(skill.q_values(states, actions), q.probabilities(states, actions), rtol=0, atol=0)
    # the config and the weights must agree, and an unknown type is named
    update_config(tmp_path, models={m: {"file": WEIGHT_FILES[m], "architecture": ARCHITECTURES[m]} for m in networks})
    with pytest.raises(CheckpointError, match="does not fit the QEnsemble network"):
        load_q(tmp_path)
    update_config(tmp_path, models={"q": {"file": WEIGHT_FILES["q"], "architecture": {"type": "Transformer"}}})
    with pytest.raises(CheckpointError, match="unknown Q-ensemble type 'Transformer'"):
        load_q(tmp_path)


def test_flop_counts_follow_the_layer_sizes() -> None:
    from t2m_skills_tableenv.networks import QEnsemble

    assert QEnsemble().flops_per_sample() == 2 * 8 * (100 * 256 + 256 * 256 + 256)
    assert Dynamics().flops_per_sample() == 2 * (100 * 256 + 256 * 256 + 256 * 96)
    # Place: context 3 rows + action = 40 inputs, 5 other rows of 12, width 128
    phi = 40 * 128 + 5 * (12 * 128 + 128 * 128)
    rho = 40 * 128 + 128 * 128 + 128 * 128 + 128
    assert RelationalQEnsemble(context_rows=3).flops_per_sample() == 2 * 8 * (phi + rho)
