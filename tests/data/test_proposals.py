"""The proposal sampler (docs/guide/skills.md#proposal-data): what it draws, and the checkpoint it
is tied to."""

from __future__ import annotations

import json

import numpy as np
import pytest

from t2m_core.data import proposals
from t2m_core.data.chunks import ChunkSpec, DataGenerationError, ProposalSource
from t2m_core.data.proposals import OPTIMUM_CANDIDATES, ProposalError, ProposalSampler, checkpoint_digest, load_proposal_sampler

BEST = np.array([0.5, -0.5, 0.25, 0.0])
"""Where the toy ensemble's value peaks."""
POLICY = np.array([0.2, -0.2, 0.0, 0.3])
SCREENED = np.full(4, 0.777)


class _ToySkill:
    """Policy: always :data:`POLICY`; ensemble: 8 members that agree on exp(−|a − BEST|²)."""

    def policy(self, states):
        return np.tile(POLICY, (len(states), 1))

    def q_values(self, states, actions):
        assert len(states) == len(actions)
        value = np.exp(-((np.asarray(actions) - BEST) ** 2).sum(axis=1))
        return np.repeat(value[:, None], 8, axis=1)


class _ToyPrimitive:
    name = "place"

    def screened_exploration_action(self, state, arguments, rng):
        return SCREENED.copy()


def _draws(count: int) -> np.ndarray:
    sampler = ProposalSampler(_ToyPrimitive(), _ToySkill())
    rng = np.random.default_rng(0)
    state = np.zeros(96, dtype=np.float32)
    return np.array([sampler.draw(None, ("a", "b"), state, POLICY, rng) for _ in range(count)])


def test_a_third_of_the_draws_are_screened_and_the_rest_lie_in_the_unit_box() -> None:
    draws = _draws(900)
    screened = np.all(draws == SCREENED, axis=1)
    assert 0.28 < screened.mean() < 0.39
    assert np.all(np.abs(draws) <= 1.0)


def test_optimum_draws_go_where_the_ensemble_is_highest_and_policy_draws_stay_near_the_policy() -> None:
    draws = _draws(900)
    noisy = draws[~np.all(draws == SCREENED, axis=1)]
    to_best = np.linalg.norm(noisy - BEST, axis=1)
    # the best of 256 noisy policy actions is far closer to the peak than any one of them usually is
    close = to_best < 0.25
    assert 0.35 < close.mean() < 0.65, close.mean()  # about half: the optimum draws
    policy_like = noisy[~close]
    spread = np.std(policy_like - POLICY, axis=0)
    assert np.all(spread > 0.2) and np.all(spread < 0.4)  # σ = 0.3, clipped at the box's faces
    # the ideal best-of-256 of N(POLICY, 0.3²) lands within 0.25 of BEST: check against a direct draw
    rng = np.random.default_rng(1)
    candidates = np.clip(POLICY + rng.normal(0.0, 0.3, (OPTIMUM_CANDIDATES, 4)), -1.0, 1.0)
    assert np.linalg.norm(candidates[np.argmin(np.linalg.norm(candidates - BEST, axis=1))] - BEST) < 0.25


def _checkpoint(root, skill="place"):
    directory = root / skill
    directory.mkdir(parents=True)
    (directory / "config.json").write_text(json.dumps({"skill": skill}))
    (directory / "q_ensemble.safetensors").write_bytes(b"weights")
    (directory / "metrics-q.jsonl").write_text("{}\n")
    return root


def test_the_digest_covers_weights_and_configuration_but_not_logs(tmp_path) -> None:
    root = _checkpoint(tmp_path)
    first = checkpoint_digest(root, "place")
    (root / "place" / "metrics-q.jsonl").write_text('{"step": 2}\n')
    assert checkpoint_digest(root, "place") == first
    (root / "place" / "q_ensemble.safetensors").write_bytes(b"other weights")
    assert checkpoint_digest(root, "place") != first
    with pytest.raises(ProposalError, match="no pull checkpoint"):
        checkpoint_digest(root, "pull")


def test_a_dataset_refuses_a_proposal_checkpoint_that_changed(tmp_path, monkeypatch) -> None:
    root = _checkpoint(tmp_path)
    recorded = checkpoint_digest(root, "place")
    (root / "place" / "q_ensemble.safetensors").write_bytes(b"retrained")
    monkeypatch.setattr(proposals, "_WORKER_LIBRARIES", {})
    with pytest.raises(ProposalError, match="changed since this dataset was started"):
        load_proposal_sampler(_ToyPrimitive(), "tableenv", root, recorded)


def test_the_proposal_sampler_and_only_it_takes_a_proposal_library() -> None:
    source = ProposalSource("tableenv", "/checkpoints", "ab" * 32)
    with pytest.raises(DataGenerationError, match="proposal"):
        ChunkSpec("place", "train", 0, 5, sampler="proposal")
    with pytest.raises(DataGenerationError, match="proposal"):
        ChunkSpec("place", "train", 0, 5, sampler="screened", proposal=source)
    header = ChunkSpec("place", "train", 0, 5, sampler="proposal", proposal=source).header()
    # a shard records the checkpoint's digest, not where it lay on the machine that made it
    assert header["proposal"] == {"library": "tableenv", "digest": "ab" * 32}
    assert "/checkpoints" not in json.dumps(header)
