"""A policy that also reads which gripper yaws the primitive's geometric screen rules out
(docs/guide/skills.md#geometric-policy).

A Pick policy keeps one grasp yaw for a box whatever lies around it; where the hook lies beside
the box, that grasp closes a finger on it, and the grasp turned a quarter succeeds. The Q-ensemble
values the turned grasp 0.97–1.00 there, but such scenes are about one in a hundred, too few for
the policy's MLP to learn from the 96 state numbers where to turn. :class:`GeometricGaussianPolicy`
gives it, as K more inputs, the primitive's ``in_the_way`` prediction for K probe actions: the
centre of the action box at K yaws spread over the yaw's range (the same for every state).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import torch

from t2m_core.domain.observation import FEATURES, OBSERVATION_ROWS, unnormalize
from t2m_skills_tableenv.networks import ACTION_DIM, HIDDEN, STATE_DIM, GaussianPolicy

PROBES = 9
"""Probe yaws, evenly spread over the normalised yaw's [−1, 1] (a quarter turn of Pick's grasp is 1.0)."""
POLICY_NETWORKS: dict[str, str] = {"mlp": "GaussianPolicy", "geometric": "GeometricGaussianPolicy"}
"""``t2m train --policy-network`` name -> the architecture ``type`` a checkpoint's config records."""


def probe_actions(probes: int = PROBES) -> np.ndarray:
    """``(K, 4)`` normalised probe actions: the centre of the action box, yaw from −1 to 1."""
    actions = np.zeros((probes, ACTION_DIM))
    actions[:, -1] = np.linspace(-1.0, 1.0, probes)
    return actions


class GeometricGaussianPolicy(GaussianPolicy):
    """``(96 + K) → 256 → 256 → 8``: :class:`GaussianPolicy` with the skill primitive's
    ``in_the_way`` flag at each of K :func:`probe_actions` as more inputs (±0.5).

    ``distribution``, ``forward`` and ``sample`` take ``screen`` ``(N, K)``, the inputs
    :meth:`screen` computes from the states when not given (a trainer passes those of its dataset,
    computed once). The screen is computed outside autograd.
    """

    def __init__(self, skill: str, probes: int = PROBES, hidden: tuple[int, ...] = HIDDEN) -> None:
        super().__init__(hidden, extra_inputs=probes)
        self.skill, self.probes = skill, probes

    @classmethod
    def from_policy(cls, skill: str, policy: GaussianPolicy, probes: int = PROBES) -> GeometricGaussianPolicy:
        """The geometric policy that acts exactly as ``policy`` until trained: its weights, and zero
        weights on the probe inputs."""
        network = cls(skill, probes, hidden_sizes(policy))
        state = policy.net.state_dict()
        first = next(name for name in state if name.endswith("weight"))
        state[first] = torch.cat((state[first], torch.zeros(state[first].shape[0], probes)), dim=1)
        network.net.load_state_dict(state)
        return network

    def screen(self, states: torch.Tensor) -> torch.Tensor:
        """``(N, K)`` the probe inputs of normalised ``states (N, 96)``: +0.5 where the probe is in the way."""
        from t2m_skills_tableenv.geometric_screen import screen_inputs, screen_values

        rows = unnormalize(states.detach().cpu().numpy().reshape(-1, OBSERVATION_ROWS, FEATURES))
        probes = probe_actions(self.probes)
        flags = screen_values(self.skill, np.repeat(rows, self.probes, axis=0), np.tile(probes, (len(rows), 1)), ("in_the_way",))
        inputs = screen_inputs(flags, ("in_the_way",))  # a flag enters as ±0.5, as in the geometric Q-ensemble
        return torch.from_numpy(inputs.reshape(len(rows), self.probes)).to(device=states.device, dtype=states.dtype)

    def distribution(self, states: torch.Tensor, screen: torch.Tensor | None = None) -> tuple[torch.Tensor, torch.Tensor]:
        if screen is None:
            screen = self.screen(states)
        return self._squashed(self.net(torch.cat((states, screen.to(states.dtype)), dim=-1)))

    def forward(self, states: torch.Tensor, screen: torch.Tensor | None = None) -> torch.Tensor:
        return torch.tanh(self.distribution(states, screen)[0])

    def sample(self, states: torch.Tensor, screen: torch.Tensor | None = None) -> tuple[torch.Tensor, torch.Tensor]:
        return self.sample_from(*self.distribution(states, screen))


def hidden_sizes(policy: GaussianPolicy) -> tuple[int, ...]:
    """The hidden layer widths of ``policy``'s MLP."""
    return tuple(layer.out_features for layer in policy.net if isinstance(layer, torch.nn.Linear))[:-1]


def policy_architecture(skill: str, network: str) -> dict[str, Any]:
    """The ``config.json`` architecture of ``skill``'s policy of kind ``network`` (``"mlp"`` or ``"geometric"``)."""
    published = {"type": POLICY_NETWORKS["mlp"], "input": STATE_DIM, "hidden": list(HIDDEN), "output": 2 * ACTION_DIM, "squash": "tanh", "log_std": [-5.0, 2.0]}
    if network == "mlp":
        return published
    if network == "geometric":
        return {**published, "type": POLICY_NETWORKS["geometric"], "skill": skill, "input": STATE_DIM + PROBES, "probes": PROBES, "screen": "in_the_way"}
    raise ValueError(f"unknown policy network {network!r} (known: {', '.join(POLICY_NETWORKS)})")


def build_policy(architecture: dict[str, Any]) -> GaussianPolicy:
    """A fresh policy as ``architecture`` (a checkpoint's ``models.policy.architecture``) describes it.

    Raises:
        ValueError: an architecture type this library does not know.
    """
    kind = architecture.get("type", POLICY_NETWORKS["mlp"])
    hidden = tuple(architecture.get("hidden", HIDDEN))
    if kind == POLICY_NETWORKS["mlp"]:
        return GaussianPolicy(hidden)
    if kind == POLICY_NETWORKS["geometric"]:
        return GeometricGaussianPolicy(str(architecture["skill"]), int(architecture.get("probes", PROBES)), hidden)
    raise ValueError(f"unknown policy type {kind!r} (known: {', '.join(POLICY_NETWORKS.values())})")


def load_policy_weights(directory: Path, network: GaussianPolicy) -> None:
    """Load the policy of the skill checkpoint ``directory`` into ``network`` (fine-tuning). A published
    policy starts a geometric one as :meth:`GeometricGaussianPolicy.from_policy` (it acts as before).

    Raises:
        CheckpointError: the checkpoint's policy is missing or broken, or a geometric one to start a published one.
    """
    from t2m_skills_tableenv.checkpoints import CheckpointError, architecture_of, load_weights
    from t2m_skills_tableenv.training import WEIGHT_FILES

    starting = architecture_of(directory, "policy").get("type", POLICY_NETWORKS["mlp"])
    path = Path(directory) / WEIGHT_FILES["policy"]
    if isinstance(network, GeometricGaussianPolicy) and starting == POLICY_NETWORKS["mlp"]:
        published = load_weights(path, GaussianPolicy(hidden_sizes(network)))
        network.load_state_dict(GeometricGaussianPolicy.from_policy(network.skill, published, network.probes).state_dict())
        return
    if starting != type(network).__name__:
        raise CheckpointError(f"{path} holds a {starting} policy, which cannot start a {type(network).__name__}",
                              "fine-tune it with the same --policy-network, or train without --init-from")
    load_weights(path, network)
