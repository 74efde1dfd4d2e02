"""The three networks of a learned skill (docs/guide/skills.md#q-ensemble): MLPs with hidden sizes
(256, 256), ReLU, orthogonal weights and zero biases.

- :class:`QEnsemble`: B = 8 independent success classifiers evaluated as one batched module (one
  ``baddbmm`` per layer for all members; no Python loop over members).
- :class:`RelationalQEnsemble`: the same ensemble with a permutation-invariant reading of the
  non-argument objects (docs/guide/skills.md#relational-q-ensemble), an option of ``t2m train``.
- :class:`~t2m_skills_tableenv.geometric_q.GeometricQEnsemble` (its own module): the MLP ensemble that
  also reads the primitive's geometric screen (docs/guide/skills.md#geometric-q-ensemble), an option
  of ``t2m train``.
- :class:`GaussianPolicy`: a tanh-squashed diagonal Gaussian; the deterministic action is tanh(μ).
- :class:`Dynamics`: a residual MLP on the 96-D dynamics state.
- :class:`RelationalDynamics`: the same residual prediction with the non-argument objects read as a
  set (docs/guide/skills.md#relational-dynamics), an option of ``t2m train``.
- :class:`~t2m_skills_tableenv.prior_dynamics.PriorDynamics` (its own module): an MLP that corrects
  the primitive's geometric prediction of the next state (docs/guide/skills.md#geometric-prior), an
  option of ``t2m train``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
import torch
from torch import nn

from t2m_core.domain.observation import FEATURES as ROW_FEATURES
from t2m_core.domain.observation import OBSERVATION_ROWS, normalize

STATE_DIM = 96
ACTION_DIM = 4
HIDDEN = (256, 256)
ENSEMBLE_SIZE = 8
RELATIONAL_WIDTH = 128
"""Width of the relational Q-ensemble's layers."""
Q_NETWORKS: dict[str, str] = {"mlp": "QEnsemble", "relational": "RelationalQEnsemble", "geometric": "GeometricQEnsemble"}
"""``t2m train --q-network`` name -> the architecture ``type`` a checkpoint's config records."""
DynamicsModel = Callable[[torch.Tensor, torch.Tensor], torch.Tensor]
"""A dynamics network as the library calls it: ``(states (N, 96), actions (N, 4)) -> (N, 96)``
(:class:`Dynamics`, :class:`RelationalDynamics` or ``prior_dynamics.PriorDynamics``)."""
DYNAMICS_NETWORKS: dict[str, str] = {"mlp": "Dynamics", "relational": "RelationalDynamics", "prior": "PriorDynamics"}
"""``t2m train --dynamics-network`` name -> the architecture ``type`` a checkpoint's config records."""
LOG_STD_MIN, LOG_STD_MAX = -5.0, 2.0


class QEnsemble(nn.Module):
    """``members`` MLPs ``(96 + 4) → 256 → 256 → 1`` with stacked weights.

    ``forward(states (N, 96), actions (N, 4))`` returns the logits ``(N, B)``; :meth:`probabilities`
    their sigmoids.
    """

    def __init__(self, members: int = ENSEMBLE_SIZE, hidden: tuple[int, ...] = HIDDEN, extra_inputs: int = 0) -> None:
        super().__init__()
        sizes = (STATE_DIM + ACTION_DIM + extra_inputs, *hidden, 1)
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
        return self._logits(torch.cat((states, actions), dim=-1))

    def _logits(self, x: torch.Tensor) -> torch.Tensor:
        """Logits ``(N, B)`` of ``(N, inputs)`` or ``(B, N, inputs)`` inputs."""
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

    def flops_per_sample(self) -> int:
        """Floating-point operations (2 × multiply-adds) of all members for one (state, action)."""
        return 2 * sum(int(weight[0].numel()) for weight in self.weights) * self.members


def _stacked_linear(members: int, fan_in: int, fan_out: int, gain: float) -> tuple[nn.Parameter, nn.Parameter]:
    """``(B, fan_in, fan_out)`` orthogonal weights and ``(B, 1, fan_out)`` zero biases."""
    weight = torch.empty(members, fan_in, fan_out)
    for member in range(members):
        nn.init.orthogonal_(weight[member].T, gain=gain)
    return nn.Parameter(weight), nn.Parameter(torch.zeros(members, 1, fan_out))


_EMPTY_ROW = torch.from_numpy(normalize(np.zeros(ROW_FEATURES, dtype=np.float32)))
"""A raw all-zero row after normalisation: an empty slot (the table's row is all zero too, and
carries nothing: the table never moves)."""


class RelationalQEnsemble(nn.Module):
    """B success classifiers that read the other objects as a set.

    The context ``c`` is the end-effector row, the skill's argument rows (``context_rows`` rows in
    all: 1 + the skill's arity) and the action. Each other present object ``o_k`` is encoded
    together with the context, ``h_k = φ(c, o_k)`` (two ReLU layers), the encodings are max-pooled
    over the objects, and ``ρ(c, max_k h_k)`` (two ReLU layers, one logit) scores the pair. The
    output does not depend on the order of the non-argument rows, which an MLP has to learn from
    shuffled rows. Rows that are all zero in raw units (empty slots, the table) are left out.

    ``forward(states (N, 96), actions (N, 4))`` returns the logits ``(N, B)``, like
    :class:`QEnsemble`; so does ``((B, N, 96), (B, N, 4))``.
    """

    def __init__(self, context_rows: int, members: int = ENSEMBLE_SIZE, width: int = RELATIONAL_WIDTH) -> None:
        super().__init__()
        if not 1 <= context_rows < OBSERVATION_ROWS:
            raise ValueError(f"context_rows must be in [1, {OBSERVATION_ROWS - 1}], got {context_rows}")
        self.members, self.context_rows, self.width = members, context_rows, width
        context = context_rows * ROW_FEATURES + ACTION_DIM
        gain = math.sqrt(2.0)
        # the first layers are split by input block: the context's share is computed once per sample
        self.phi_context_w, self.phi_b1 = _stacked_linear(members, context, width, gain)
        self.phi_object_w, _ = _stacked_linear(members, ROW_FEATURES, width, gain)
        self.phi_w2, self.phi_b2 = _stacked_linear(members, width, width, gain)
        self.rho_context_w, self.rho_b1 = _stacked_linear(members, context, width, gain)
        self.rho_pooled_w, _ = _stacked_linear(members, width, width, gain)
        self.rho_w2, self.rho_b2 = _stacked_linear(members, width, width, gain)
        self.out_w, self.out_b = _stacked_linear(members, width, 1, 1.0)
        self.register_buffer("empty_row", _EMPTY_ROW.clone(), persistent=False)

    def forward(self, states: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        """Logits ``(N, B)``."""
        # (N, K, 1) when every member reads the same states, (B, N, K, 1) otherwise: computed once per sample
        absent = self._absent(states)
        if states.dim() == 2:
            states = states.unsqueeze(0).expand(self.members, -1, -1)
            actions = actions.unsqueeze(0).expand(self.members, -1, -1)
        members, count = states.shape[0], states.shape[1]
        rows = states.reshape(members, count, OBSERVATION_ROWS, ROW_FEATURES)
        context = torch.cat((rows[:, :, : self.context_rows].reshape(members, count, -1), actions), dim=-1)
        others = rows[:, :, self.context_rows :]  # (B, N, K, 12)
        objects = others.shape[2]
        shared = torch.baddbmm(self.phi_b1, context, self.phi_context_w)  # (B, N, W)
        hidden = torch.bmm(others.reshape(members, count * objects, ROW_FEATURES), self.phi_object_w)
        hidden = hidden.view(members, count, objects, -1).add_(shared.unsqueeze(2)).relu_()
        hidden = torch.baddbmm(self.phi_b2, hidden.view(members, count * objects, -1), self.phi_w2).relu_()
        # ReLU outputs are ≥ 0, so an absent object's zeros never win the max
        pooled = hidden.view(members, count, objects, -1).masked_fill(absent, 0.0).amax(dim=2)  # (B, N, W)
        x = torch.baddbmm(self.rho_b1, context, self.rho_context_w).baddbmm_(pooled, self.rho_pooled_w).relu_()
        x = torch.baddbmm(self.rho_b2, x, self.rho_w2).relu_()
        return torch.baddbmm(self.out_b, x, self.out_w).squeeze(-1).T

    def _absent(self, states: torch.Tensor) -> torch.Tensor:
        """``(..., K, 1)`` whether each non-argument row of ``(..., 96)`` states is all zero in raw units."""
        others = states.reshape(*states.shape[:-1], OBSERVATION_ROWS, ROW_FEATURES)[..., self.context_rows :, :]
        return torch.isclose(others, self.empty_row, atol=1e-6).all(dim=-1, keepdim=True)

    def flops_per_sample(self) -> int:
        """Floating-point operations (2 × multiply-adds) of all members for one (state, action),
        every non-argument row encoded (absent ones are computed, then masked)."""
        objects = OBSERVATION_ROWS - self.context_rows
        context = self.phi_context_w.shape[1]
        phi = context * self.width + objects * (ROW_FEATURES * self.width + self.width * self.width)
        rho = context * self.width + 2 * self.width * self.width + self.width
        return 2 * (phi + rho) * self.members

    def probabilities(self, states: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        """``(N, B)`` success probabilities of every member."""
        return torch.sigmoid(self.forward(states, actions))


def q_architecture(skill: str, network: str, screen: tuple[str, ...] | None = None) -> dict[str, Any]:
    """The ``config.json`` architecture of ``skill``'s Q-ensemble of kind ``network`` (``"mlp"``,
    ``"relational"`` or ``"geometric"``; the relational network's context is the end effector and the
    skill's arguments, the geometric network's extra inputs the skill's geometric ``screen``
    predictions, by default :data:`~t2m_skills_tableenv.geometric_screen.SCREEN_FEATURES`)."""
    if network == "mlp":
        return {"type": Q_NETWORKS["mlp"], "members": ENSEMBLE_SIZE, "input": 100, "hidden": list(HIDDEN), "output": "sigmoid", "loss": "bce"}
    if network == "geometric":
        from t2m_skills_tableenv.geometric_screen import screen_features

        features = screen_features(skill, screen)
        return {"type": Q_NETWORKS["geometric"], "skill": skill, "members": ENSEMBLE_SIZE, "input": 100 + len(features),
                "hidden": list(HIDDEN), "screen": list(features), "output": "sigmoid", "loss": "bce"}
    from t2m_core.domain.primitives import get_primitive

    context_rows = 1 + len(get_primitive(skill).argument_kinds)
    return {"type": Q_NETWORKS["relational"], "members": ENSEMBLE_SIZE, "input": 100, "context_rows": context_rows,
            "width": RELATIONAL_WIDTH, "pooling": "max", "output": "sigmoid", "loss": "bce"}


def build_q(architecture: dict[str, Any]) -> QEnsemble | RelationalQEnsemble:
    """A fresh Q-ensemble as ``architecture`` (a checkpoint's ``models.q.architecture``) describes it.

    Raises:
        ValueError: an architecture type this library does not know.
    """
    kind = architecture.get("type", Q_NETWORKS["mlp"])
    members = int(architecture.get("members", ENSEMBLE_SIZE))
    if kind == Q_NETWORKS["mlp"]:
        return QEnsemble(members=members, hidden=tuple(architecture.get("hidden", HIDDEN)))
    if kind == Q_NETWORKS["relational"]:
        return RelationalQEnsemble(int(architecture["context_rows"]), members=members, width=int(architecture.get("width", RELATIONAL_WIDTH)))
    if kind == Q_NETWORKS["geometric"]:
        from t2m_skills_tableenv.geometric_q import GeometricQEnsemble

        features = architecture.get("screen", "in_the_way")  # one name: the first (Pick) checkpoints
        features = (features,) if isinstance(features, str) else tuple(features)
        return GeometricQEnsemble(str(architecture["skill"]), members=members, hidden=tuple(architecture.get("hidden", HIDDEN)), features=features)
    raise ValueError(f"unknown Q-ensemble type {kind!r} (known: {', '.join(Q_NETWORKS.values())})")


def q_network_name(architecture: dict[str, Any]) -> str:
    """The ``--q-network`` name of a checkpoint's Q architecture (``"mlp"`` when it names none)."""
    return _network_name(architecture, Q_NETWORKS)


def dynamics_network_name(architecture: dict[str, Any]) -> str:
    """The ``--dynamics-network`` name of a checkpoint's dynamics architecture (``"mlp"`` when it names none)."""
    return _network_name(architecture, DYNAMICS_NETWORKS)


def _network_name(architecture: dict[str, Any], names: dict[str, str]) -> str:
    kind = architecture.get("type", names["mlp"])
    return next((name for name, recorded in names.items() if recorded == kind), kind)


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
    squashed to [−5, 2]. ``extra_inputs`` widens the input for a subclass that reads more than the state."""

    def __init__(self, hidden: tuple[int, ...] = HIDDEN, extra_inputs: int = 0) -> None:
        super().__init__()
        self.net = mlp((STATE_DIM + extra_inputs, *hidden, 2 * ACTION_DIM))

    def distribution(self, states: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """``(mean, log_std)``, each ``(N, 4)``."""
        return self._squashed(self.net(states))

    @staticmethod
    def _squashed(outputs: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """``(mean, log_std)`` of the network's ``(N, 8)`` outputs, log σ squashed to [−5, 2]."""
        mean, raw = outputs.chunk(2, dim=-1)
        return mean, LOG_STD_MIN + 0.5 * (LOG_STD_MAX - LOG_STD_MIN) * (torch.tanh(raw) + 1.0)

    def forward(self, states: torch.Tensor) -> torch.Tensor:
        """Deterministic action ``(N, 4)`` = tanh(μ) in [−1, 1]."""
        return torch.tanh(self.distribution(states)[0])

    def sample(self, states: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Reparameterised ``(actions (N, 4), log π(a|s) (N,))``."""
        return self.sample_from(*self.distribution(states))

    @staticmethod
    def sample_from(mean: torch.Tensor, log_std: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """:meth:`sample` of a :meth:`distribution` already computed (whose mean also gives the
        deterministic action, tanh(μ))."""
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

    def flops_per_sample(self) -> int:
        """Floating-point operations (2 × multiply-adds) for one (state, action)."""
        return 2 * sum(int(module.weight.numel()) for module in self.net if isinstance(module, nn.Linear))


class RelationalDynamics(nn.Module):
    """Residual dynamics that read the other objects as a set: ŝ′ = s + Δ(s, a/2).

    The context ``c`` is the end-effector row, the skill's argument rows (``context_rows`` rows in
    all) and the action rescaled to [−0.5, 0.5]. Each other present object ``o_k`` is encoded with
    the context, ``h_k = φ(c, o_k)`` (two ReLU layers), and the encodings are max-pooled. The context
    rows' change is ``ρ(c, max_k h_k)`` (two ReLU layers of 256), each other object's change
    ``ψ(c, o_k, max_k h_k)`` (two ReLU layers): the same function for every object, so the
    prediction permutes with the non-argument rows, and an absent row (all zero in raw units)
    predicts no change. ``forward(states (N, 96), actions (N, 4)) -> (N, 96)``, like
    :class:`Dynamics`.
    """

    def __init__(self, context_rows: int, width: int = RELATIONAL_WIDTH, hidden: tuple[int, ...] = HIDDEN) -> None:
        super().__init__()
        if not 1 <= context_rows < OBSERVATION_ROWS:
            raise ValueError(f"context_rows must be in [1, {OBSERVATION_ROWS - 1}], got {context_rows}")
        self.context_rows, self.width = context_rows, width
        context = context_rows * ROW_FEATURES + ACTION_DIM
        self.phi = nn.Sequential(mlp((context + ROW_FEATURES, width, width)), nn.ReLU())
        self.rho = mlp((context + width, *hidden, context_rows * ROW_FEATURES))
        self.psi = mlp((context + ROW_FEATURES + width, width, width, ROW_FEATURES))
        self.register_buffer("empty_row", _EMPTY_ROW.clone(), persistent=False)

    def forward(self, states: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        count = states.shape[0]
        rows = states.reshape(count, OBSERVATION_ROWS, ROW_FEATURES)
        context = torch.cat((rows[:, : self.context_rows].reshape(count, -1), 0.5 * actions), dim=-1)
        others = rows[:, self.context_rows :]  # (N, K, 12)
        objects = others.shape[1]
        absent = torch.isclose(others, self.empty_row, atol=1e-6).all(dim=-1, keepdim=True)  # (N, K, 1)
        shared = context.unsqueeze(1).expand(-1, objects, -1)
        # ReLU outputs are ≥ 0, so an absent object's zeros never win the max
        pooled = self.phi(torch.cat((shared, others), dim=-1)).masked_fill(absent, 0.0).amax(dim=1)  # (N, W)
        context_change = self.rho(torch.cat((context, pooled), dim=-1))
        other_change = self.psi(torch.cat((shared, others, pooled.unsqueeze(1).expand(-1, objects, -1)), dim=-1))
        return states + torch.cat((context_change, other_change.masked_fill(absent, 0.0).reshape(count, -1)), dim=-1)

    def flops_per_sample(self) -> int:
        """Floating-point operations (2 × multiply-adds) for one (state, action), every non-argument
        row computed (absent ones are masked afterwards)."""
        objects = OBSERVATION_ROWS - self.context_rows
        per_object = sum(_weights(self.phi[0])) + sum(_weights(self.psi))
        return 2 * (objects * per_object + sum(_weights(self.rho)))


def _weights(network: nn.Sequential) -> list[int]:
    return [int(module.weight.numel()) for module in network if isinstance(module, nn.Linear)]


def dynamics_architecture(skill: str, network: str) -> dict[str, Any]:
    """The ``config.json`` architecture of ``skill``'s dynamics model of kind ``network`` (``"mlp"``,
    ``"relational"`` or ``"prior"``; the relational and prior models' context is the end effector and
    the skill's arguments, the prior model's frame the box's polar frame for Pull and Push)."""
    if network == "mlp":
        return {"type": DYNAMICS_NETWORKS["mlp"], "input": 100, "hidden": list(HIDDEN), "output": 96, "residual": True}
    from t2m_core.domain.primitives import get_primitive

    context_rows = 1 + len(get_primitive(skill).argument_kinds)
    if network == "prior":
        # a sweep's physics is the same wherever on the table it happens: read it in the action's frame
        frame = "target" if skill in ("pull", "push") else "world"
        return {"type": DYNAMICS_NETWORKS["prior"], "skill": skill, "context_rows": context_rows, "frame": frame, "input": 100,
                "hidden": list(HIDDEN), "output": 96, "residual": "geometric prior"}
    return {"type": DYNAMICS_NETWORKS["relational"], "input": 100, "context_rows": context_rows, "width": RELATIONAL_WIDTH,
            "hidden": list(HIDDEN), "pooling": "max", "output": 96, "residual": True}


def build_dynamics(architecture: dict[str, Any]) -> nn.Module:
    """A fresh dynamics model as ``architecture`` (a checkpoint's ``models.dynamics.architecture``)
    describes it.

    Raises:
        ValueError: an architecture type this library does not know.
    """
    kind = architecture.get("type", DYNAMICS_NETWORKS["mlp"])
    hidden = tuple(architecture.get("hidden", HIDDEN))
    if kind == DYNAMICS_NETWORKS["mlp"]:
        return Dynamics(hidden=hidden)
    if kind == DYNAMICS_NETWORKS["relational"]:
        return RelationalDynamics(int(architecture["context_rows"]), width=int(architecture.get("width", RELATIONAL_WIDTH)), hidden=hidden)
    if kind == DYNAMICS_NETWORKS["prior"]:
        from t2m_skills_tableenv.prior_dynamics import PriorDynamics

        return PriorDynamics(str(architecture["skill"]), int(architecture["context_rows"]), frame=str(architecture.get("frame", "world")), hidden=hidden)
    raise ValueError(f"unknown dynamics type {kind!r} (known: {', '.join(DYNAMICS_NETWORKS.values())})")
