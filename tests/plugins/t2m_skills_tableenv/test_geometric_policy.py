"""The policy that reads which grasp yaws the geometric screen rules out
(docs/guide/skills.md#geometric-policy): its probes from hand-placed neighbours, its start from a
published policy, checkpoints and fine-tuning."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from t2m_skills_tableenv.checkpoints import CheckpointError, save_weights, update_config
from t2m_skills_tableenv.geometric_policy import (
    GeometricGaussianPolicy,
    build_policy,
    load_policy_weights,
    policy_architecture,
    probe_actions,
)
from t2m_skills_tableenv.library import TableEnvSkill
from t2m_skills_tableenv.networks import Dynamics, GaussianPolicy, QEnsemble
from t2m_skills_tableenv.training import ARCHITECTURES, WEIGHT_FILES

from t2m_core.domain.observation import normalize
from tests.plugins.t2m_skills_tableenv.test_geometric_screen import neighbour_scene, skill_rows


def skill_states(*states) -> torch.Tensor:
    """``(N, 96)`` normalised skill states of Pick(red_box) in the given scenes."""
    return torch.from_numpy(np.concatenate([normalize(skill_rows(state, ["red_box"])) for state in states]).reshape(len(states), -1)).float()


def test_the_probes_see_a_neighbour_along_the_jaw_at_the_yaws_that_open_towards_it() -> None:
    # Pick's yaw spans [−π/4, 3π/4] over [−1, 1]: the probe at −0.5 opens the jaw along y (towards
    # the blue box, 3 mm beyond a finger's reach: struck), the probe at +0.5 along x (clear)
    probes = probe_actions()
    assert probes.shape == (9, 4) and np.all(probes[:, :3] == 0.0) and probes[2, 3] == -0.5 and probes[6, 3] == 0.5
    policy = GeometricGaussianPolicy("pick")
    screen = policy.screen(skill_states(neighbour_scene(0.003), neighbour_scene(0.05)))
    assert screen.shape == (2, 9) and set(screen.unique().tolist()) <= {-0.5, 0.5}
    assert screen[0, 2] == 0.5 and screen[0, 6] == -0.5
    assert torch.all(screen[1] == -0.5)  # 5 cm beyond: nothing in the way at any yaw


def test_a_geometric_policy_started_from_a_published_one_acts_as_it_did() -> None:
    torch.manual_seed(0)
    published = GaussianPolicy()
    geometric = GeometricGaussianPolicy.from_policy("pick", published)
    states = skill_states(neighbour_scene(0.003), neighbour_scene(0.05))
    torch.testing.assert_close(geometric(states), published(states), rtol=0, atol=1e-6)
    # (to float rounding: the first layer sums more columns.) A given screen is used as it is: the zero-weight
    # probe inputs leave the answer where it was until their weights move
    given = torch.full((2, 9), 0.5)
    torch.testing.assert_close(geometric(states, given), published(states), rtol=0, atol=1e-6)
    with torch.no_grad():
        geometric.net[0].weight[:, -9:] = 1.0
    assert not torch.allclose(geometric(states, given), published(states))


def write_checkpoint(directory, policy_network: str) -> GaussianPolicy:
    torch.manual_seed(3)
    architecture = policy_architecture("pick", policy_network)
    networks = {"q": QEnsemble(), "policy": build_policy(architecture), "dynamics": Dynamics()}
    for model, network in networks.items():
        save_weights(directory / WEIGHT_FILES[model], network)
    architectures = {**ARCHITECTURES, "policy": architecture}
    update_config(directory, skill="pick", models={m: {"file": WEIGHT_FILES[m], "architecture": architectures[m]} for m in networks})
    return networks["policy"]


def test_a_geometric_policy_checkpoint_round_trips_and_an_unknown_type_is_named(tmp_path) -> None:
    assert policy_architecture("pick", "geometric")["input"] == 105 and policy_architecture("pick", "mlp") == ARCHITECTURES["policy"]
    policy = write_checkpoint(tmp_path, "geometric")
    skill = TableEnvSkill.load(tmp_path)
    assert isinstance(skill.policy_network, GeometricGaussianPolicy)
    states = skill_states(neighbour_scene(0.003))
    torch.testing.assert_close(skill.policy(states), policy(states), rtol=0, atol=0)
    config = (tmp_path / "config.json").read_text().replace('"GeometricGaussianPolicy"', '"TransformerPolicy"')
    (tmp_path / "config.json").write_text(config)
    with pytest.raises(CheckpointError, match="unknown policy type 'TransformerPolicy'"):
        TableEnvSkill.load(tmp_path)
    with pytest.raises(ValueError, match="unknown policy network 'transformer'"):
        policy_architecture("pick", "transformer")


def test_fine_tuning_starts_a_geometric_policy_from_a_published_one_but_not_the_reverse(tmp_path) -> None:
    published = write_checkpoint(tmp_path / "mlp", "mlp")
    geometric = GeometricGaussianPolicy("pick")
    load_policy_weights(tmp_path / "mlp", geometric)
    states = skill_states(neighbour_scene(0.003), neighbour_scene(0.05))
    torch.testing.assert_close(geometric(states), published(states), rtol=0, atol=1e-6)
    write_checkpoint(tmp_path / "geometric", "geometric")
    with pytest.raises(CheckpointError, match="holds a GeometricGaussianPolicy policy, which cannot start a GaussianPolicy"):
        load_policy_weights(tmp_path / "geometric", GaussianPolicy())
