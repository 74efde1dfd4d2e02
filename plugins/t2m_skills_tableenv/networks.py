"""The three networks of a learned skill (docs/guide/skills.md#q-ensemble): MLPs with hidden sizes
(256, 256), ReLU, orthogonal weights and zero biases.

- :class:`QEnsemble`: B = 8 independent success classifiers evaluated as one batched module (one
  ``baddbmm`` per layer for all members; no Python loop over members).
- :class:`GaussianPolicy`: a tanh-squashed diagonal Gaussian; the deterministic action is tanh(μ).
- :class:`Dynamics`: a residual MLP on the 96-D dynamics state.
"""

from __future__ import annotations

import math

import torch
from torch import nn

STATE_DIM = 96
ACTION_DIM = 4
HIDDEN = (256, 256)
ENSEMBLE_SIZE = 8
LOG_STD_MIN, LOG_STD_MAX = -5.0, 2.0


class QEnsemble(nn.Module):
    """``members`` MLPs ``(96 + 4) → 256 → 256 → 1`` with stacked weights.

    ``forward(states (N, 96), actions (N, 4))`` returns the logits ``(N, B)``; :meth:`probabilities`
    their sigmoids.
    """

    def __init__(self, members: int = ENSEMBLE_SIZE, hidden: tuple[int, ...] = HIDDEN) -> None:
        super().__init__()
        sizes = (STATE_DIM + ACTION_DIM, *hidden, 1)
        self.members = members
        self.weights = nn.ParameterList()
        self.biases = nn.ParameterList()
        for fan_in, fan_out in zip(sizes[:-1], sizes[1:]):
            weight = torch.empty(members, fan_in, fan_out)
            for member in range(members):
                nn.init.orthogonal_(weight[member].T, gain=math.sqrt(2.0) if fan_out != 1 else 1.0)
            self.weights.append(nn.Parameter(weight))
            self.biases.append(nn.Parameter(torch.zeros(members, 1, fan_out)))

    def forward(self, states: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        """Logits ``(N, B)``. ``states (N, 96)`` and ``actions (N, 4)`` go to every member;
        ``(B, N, 96)`` and ``(B, N, 4)`` give each member its own inputs (bootstrapped training)."""
        x = torch.cat((states, actions), dim=-1)
        if x.dim() == 2:
            x = x.unsqueeze(0).expand(self.members, -1, -1)
        last = len(self.weights) - 1
        for layer, (weight, bias) in enumerate(zip(self.weights, self.biases)):
            x = torch.baddbmm(bias, x, weight)
            if layer != last:
                x = torch.relu(x)
        return x.squeeze(-1).T

    def probabilities(self, states: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        """``(N, B)`` success probabilities of every member."""
        return torch.sigmoid(self.forward(states, actions))


def mlp(sizes: tuple[int, ...]) -> nn.Sequential:
    """ReLU MLP with orthogonal weights (gain √2, 1 on the output layer) and zero biases."""
    layers: list[nn.Module] = []
    for index, (fan_in, fan_out) in enumerate(zip(sizes[:-1], sizes[1:])):
        linear = nn.Linear(fan_in, fan_out)
        last = index == len(sizes) - 2
        nn.init.orthogonal_(linear.weight, gain=1.0 if last else math.sqrt(2.0))
        nn.init.zeros_(linear.bias)
        layers.append(linear)
        if not last:
            layers.append(nn.ReLU())
    return nn.Sequential(*layers)


class GaussianPolicy(nn.Module):
    """``96 → 256 → 256 → 8``: mean μ and raw log σ of a tanh-squashed diagonal Gaussian; log σ is
    squashed to [−5, 2]."""

    def __init__(self, hidden: tuple[int, ...] = HIDDEN) -> None:
        super().__init__()
        self.net = mlp((STATE_DIM, *hidden, 2 * ACTION_DIM))

    def distribution(self, states: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """``(mean, log_std)``, each ``(N, 4)``."""
        mean, raw = self.net(states).chunk(2, dim=-1)
        log_std = LOG_STD_MIN + 0.5 * (LOG_STD_MAX - LOG_STD_MIN) * (torch.tanh(raw) + 1.0)
        return mean, log_std

    def forward(self, states: torch.Tensor) -> torch.Tensor:
        """Deterministic action ``(N, 4)`` = tanh(μ) in [−1, 1]."""
        return torch.tanh(self.distribution(states)[0])

    def sample(self, states: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Reparameterised ``(actions (N, 4), log π(a|s) (N,))``."""
        mean, log_std = self.distribution(states)
        std = log_std.exp()
        pre_tanh = mean + std * torch.randn_like(mean)
        action = torch.tanh(pre_tanh)
        gaussian = -0.5 * (((pre_tanh - mean) / std) ** 2 + 2 * log_std + math.log(2 * math.pi))
        # log|d tanh(u)/du| = 2 (log 2 − u − softplus(−2u)), the numerically stable form
        correction = 2.0 * (math.log(2.0) - pre_tanh - nn.functional.softplus(-2.0 * pre_tanh))
        return action, (gaussian - correction).sum(-1)


class Dynamics(nn.Module):
    """``(96 + 4) → 256 → 256 → 96``, residual: ŝ′ = s + f(s, a/2) (actions rescaled to [−0.5, 0.5])."""

    def __init__(self, hidden: tuple[int, ...] = HIDDEN) -> None:
        super().__init__()
        self.net = mlp((STATE_DIM + ACTION_DIM, *hidden, STATE_DIM))

    def forward(self, states: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        return states + self.net(torch.cat((states, 0.5 * actions), dim=-1))
