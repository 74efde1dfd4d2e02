"""Training of a skill's three models (docs/guide/skills.md#q-ensemble, #policy, #dynamics).

The stages run in order: the Q-ensemble on all valid transitions, then the policy against the
frozen ensemble, then the dynamics on the successes. Each stage:

- keeps the model with the best validation score (evaluated every ``eval_every`` steps);
- writes its metrics, one JSON line per evaluation, to ``<checkpoint>/metrics-<model>.jsonl``;
- saves a resumable training state (weights, optimiser moments, step, RNG, best score) every
  evaluation to ``<checkpoint>/.training/<model>.safetensors``: a killed run, started again with the
  same command, continues from its last evaluation.
"""

from __future__ import annotations

import copy
import json
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal, NamedTuple

import torch
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from t2m_core.errors import T2MError
from torch import nn

from t2m_skills_tableenv.checkpoints import load_q, load_training_state, save_training_state, save_weights, update_config
from t2m_skills_tableenv.dataset import SkillTensors
from t2m_skills_tableenv.geometric_policy import build_policy, load_policy_weights, policy_architecture
from t2m_skills_tableenv.networks import (
    ACTION_DIM, Dynamics, GaussianPolicy, QEnsemble, RelationalQEnsemble, build_dynamics, build_q, dynamics_architecture, q_architecture,
)

MODELS: tuple[str, ...] = ("q", "policy", "dynamics")
WEIGHT_FILES: dict[str, str] = {"q": "q_ensemble.safetensors", "policy": "policy.safetensors", "dynamics": "dynamics.safetensors"}


class StageSettings(BaseModel):
    """How one model is trained. The published schedules (millions of steps on a GPU) are shortened
    for CPU; the batch sizes are the published ones, and so are the learning rates except the
    Q-ensemble's (3e-4 instead of 1e-4: at 1e-4 a CPU-length schedule underfits; see
    docs/guide/deviations.md#cpu-scale-training-schedules)."""

    model_config = ConfigDict(extra="forbid")

    steps: int = Field(gt=0, description="optimiser steps")
    batch_size: int = Field(gt=0, description="samples per step")
    learning_rate: float = Field(gt=0, description="Adam learning rate (cosine-annealed to 0 for the Q-ensemble)")
    eval_every: int = Field(1000, gt=0, description="steps between validation evaluations and saved states")
    seed: int = Field(0, ge=0, description="torch seed of initialisation, batches and shuffles")
    patience: int | None = Field(
        None, gt=0, description="stop after this many evaluations without a better validation score (None: run every step)"
    )
    train_size: int | None = Field(
        None, gt=0, description="train on the first N training transitions only (what `t2m datagen --size N` writes); None: all"
    )
    selection_episodes: int = Field(
        0, ge=0, description="policy only: simulated evaluation episodes that select the policy at every evaluation "
        "(0: select by the frozen ensemble's min-of-8 Q on validation states)"
    )
    ensemble_batches: Literal["shared", "bootstrap"] = Field(
        "shared",
        description="Q-ensemble only: every member sees the same batches (the published setting), or each "
        "member draws its batches from its own bootstrap resample of the training set",
    )
    anchor_weight: float = Field(
        1.0, ge=0, description="Q-ensemble only, with anchor data: weight of the anchor loss against the labelled loss"
    )
    exposure_weight: float = Field(
        1.0, ge=0, description="Q-ensemble only, with OOD exposure data: weight of the exposure loss against the labelled loss"
    )
    weight_average: float = Field(
        0.0, ge=0, lt=1, description="Q-ensemble only: decay per step of an exponential moving average of the weights, which "
        "is evaluated, selected and saved instead of the trained weights (docs/guide/skills.md#averaged-weights; 0: none, "
        "the published training)"
    )
    q_network: Literal["mlp", "relational", "geometric"] = Field(
        "mlp",
        description="Q-ensemble only: the published MLP, the relational network that reads the other objects "
        "as a set (docs/guide/skills.md#relational-q-ensemble), or the MLP that also reads the primitive's "
        "geometric screen (docs/guide/skills.md#geometric-q-ensemble)",
    )
    screen: tuple[str, ...] | None = Field(
        None, min_length=1, description="Q-ensemble only, geometric network: the screen predictions it reads, flags or margins "
        "(docs/guide/skills.md#geometric-q-ensemble; None: the skill's default)",
    )
    dynamics_network: Literal["mlp", "relational", "prior"] = Field(
        "mlp",
        description="dynamics only: the published residual MLP, the relational network that reads the other "
        "objects as a set (docs/guide/skills.md#relational-dynamics), or an MLP that corrects the primitive's "
        "geometric prediction (docs/guide/skills.md#geometric-prior)",
    )
    policy_network: Literal["mlp", "geometric"] = Field(
        "mlp",
        description="policy only: the published MLP, or the MLP that also reads which gripper yaws the primitive's "
        "geometric screen rules out (docs/guide/skills.md#geometric-policy)",
    )
    policy_targets: int = Field(
        0, ge=0, description="policy only: for each training state, rank the starting policy's action and this many "
        "noisy copies of it by the ensemble's min-of-8 Q, and pull the policy's action towards the best "
        "(docs/guide/skills.md#searched-actor-targets; 0: the published actor objective alone)",
    )
    policy_target_sigma: float = Field(
        0.3, gt=0, description="policy only, with policy_targets: the copies' Gaussian noise per action dimension"
    )
    policy_target_weight: float = Field(
        1.0, ge=0, description="policy only, with policy_targets: weight of the squared distance to the target against the actor loss"
    )
    policy_target_value: Literal["min", "mean"] = Field(
        "min", description="policy only, with policy_targets: rank the copies by the members' minimum (the actor's own, "
        "pessimistic value) or by their mean"
    )
    policy_target_margin: float = Field(
        0.0, ge=0, description="policy only, with policy_targets: a copy replaces the policy's own action as a state's target only "
        "when valued at least this much higher (0: any gain; a positive margin keeps the noise of near-ties out of the targets)"
    )
    policy_target_uniform: float = Field(
        0.0, ge=0, le=1, description="policy only, with policy_targets: the share of the copies drawn uniformly over the whole "
        "action box instead of around the policy's action (0: all local; finds optima far from the policy's, e.g. a grasp turned a quarter)"
    )
    policy_target_tolerance: float = Field(
        0.0, ge=0, description="policy only, with policy_targets: copies valued within this much of the best count as best and the "
        "nearest of them to the policy's action becomes the target (0: the best alone; consistent targets between similar states)"
    )
    policy_target_focus: float = Field(
        0.0, ge=0, lt=1, description="policy only, with policy_targets: the share of each batch drawn from the states whose target "
        "moved away from the policy's own action (0: uniform batches; a few moved states among thousands are otherwise rarely seen)"
    )


DEFAULT_SETTINGS: dict[str, StageSettings] = {
    "q": StageSettings(steps=40_000, batch_size=128, learning_rate=3e-4, patience=10),
    "policy": StageSettings(steps=20_000, batch_size=128, learning_rate=1e-4, selection_episodes=50),
    "dynamics": StageSettings(steps=20_000, batch_size=512, learning_rate=5e-4, patience=5),
}
"""CPU-scale defaults (docs/guide/skills.md#training-schedule)."""


@dataclass
class Evaluation:
    """One validation evaluation: ``score`` (higher is better) selects the model."""

    score: float
    metrics: dict[str, float]


class Stage:
    """One model's training: what the generic loop needs to know."""

    model: str
    network: nn.Module

    def parameters_to_save(self) -> dict[str, nn.Module | torch.optim.Optimizer]:
        raise NotImplementedError

    def step(self, index: torch.Tensor, generator: torch.Generator) -> dict[str, float]:
        raise NotImplementedError

    def batch(self, size: int, generator: torch.Generator) -> torch.Tensor:
        """``(size,)`` training sample indices of one step, uniform with replacement."""
        return torch.randint(self.train_size, (size,), generator=generator)

    def evaluate(self) -> Evaluation:
        raise NotImplementedError

    def evaluated_network(self) -> nn.Module:
        """The weights :meth:`evaluate` judges, saved when they are the best: the trained network."""
        return self.network

    @property
    def train_size(self) -> int:
        raise NotImplementedError

    def prepare(self, on_progress: Callable[[int, int], None] | None = None) -> None:
        """Work that depends on the starting weights (after ``--init-from`` loaded them, before a
        resumed state replaces them): a resumed run repeats it and gets the same result.
        ``on_progress(done, total)`` follows it."""


@dataclass
class Anchor:
    """What an anchored Q-ensemble must keep: the ``teacher`` ensemble's member probabilities on the
    states of ``data`` (docs/guide/skills.md#anchored-fine-tuning).

    Attributes:
        data: the anchor transitions (their states and actions; their rewards are not used).
        teacher: the ensemble the training starts from, frozen.
        weight: the anchor loss's weight against the labelled loss.
    """

    data: SkillTensors
    teacher: QEnsemble | RelationalQEnsemble
    weight: float

    def loss(self, network: nn.Module, index: torch.Tensor, generator: torch.Generator) -> torch.Tensor:
        """BCE of each member to its teacher member on the anchor states ``index``, each with its
        stored action and with a uniform one (where a planner's search also goes)."""
        states, stored = self.data.states(index, generator), self.data.actions[index]
        uniform = torch.rand(stored.shape, generator=generator) * 2.0 - 1.0
        states, actions = torch.cat([states, states]), torch.cat([stored, uniform])
        with torch.no_grad():
            targets = self.teacher.probabilities(states, actions)
        return nn.functional.binary_cross_entropy_with_logits(network(states, actions), targets)


EXPOSURE_MONITOR_PAIRS = 2000
"""Exposure pairs whose mean member variance every evaluation records (``exposure_variance``)."""


@dataclass
class Exposure:
    """Outlier exposure of the OOD detector (docs/guide/skills.md#ood-exposure): on symbolically
    invalid pairs, the members are taught to disagree, so that the variance detector sees them.

    Member ``b`` learns the probability ``b mod 2`` there: half the members say 0, half say 1, a
    population variance of 0.25 (the largest possible) and a pessimistic (min-of-8) value of 0.

    Attributes:
        data: invalid pairs (``t2m datagen --split invalid``), states and uniform actions.
        weight: the exposure loss's weight against the labelled loss.
    """

    data: SkillTensors
    weight: float

    def loss(self, network: nn.Module, index: torch.Tensor, generator: torch.Generator) -> torch.Tensor:
        """BCE of each member to its target (``b mod 2``) on the invalid pairs ``index``."""
        logits = network(self.data.states(index, generator), self.data.actions[index])  # (N, B)
        targets = (torch.arange(logits.shape[1]) % 2).to(logits.dtype).expand_as(logits)
        return nn.functional.binary_cross_entropy_with_logits(logits, targets)


class QStage(Stage):
    """BCE of every member's sigmoid to the reward. All members see the same batch, or with
    ``ensemble_batches="bootstrap"`` member ``b`` sees the same batch positions of its own resample
    (with replacement, fixed by the seed) of the training set. With an :class:`Anchor`, each step adds
    its weighted loss on a batch of anchor states of the same size, and with an :class:`Exposure` its
    weighted loss on a batch of invalid pairs of the same size. ``labelled=False`` drops the labelled
    loss (``train`` then only sizes the steps' batches): an anchored, exposed ensemble learns what the
    starting one predicted and where the invalid pairs are, and nothing else."""

    model = "q"

    def __init__(
        self, train: SkillTensors, validation: SkillTensors, settings: StageSettings, network: QEnsemble | RelationalQEnsemble | None = None,
        anchor: Anchor | None = None, exposure: Exposure | None = None, labelled: bool = True,
    ) -> None:
        if not labelled and anchor is None:
            raise ValueError("an unlabelled Q stage needs anchor data to learn from")
        self.train, self.validation = train, validation
        self.network = network if network is not None else QEnsemble()
        self.anchor, self.exposure, self.labelled = anchor, exposure, labelled
        self.resample: torch.Tensor | None = None
        if settings.ensemble_batches == "bootstrap":
            generator = torch.Generator().manual_seed(settings.seed + 1)
            self.resample = torch.randint(len(train), (self.network.members, len(train)), generator=generator)
        self.optimizer = torch.optim.Adam(self.network.parameters(), lr=settings.learning_rate)
        self.schedule = torch.optim.lr_scheduler.CosineAnnealingLR(self.optimizer, T_max=settings.steps, eta_min=0.0)
        self.average = WeightAverage(self.network, settings.weight_average) if settings.weight_average > 0 else None
        # a geometric ensemble's screen of the stored pairs, computed once (row order does not change it)
        self.train_screen, self.validation_screen = data_screen(self.network, train), data_screen(self.network, validation)

    @property
    def train_size(self) -> int:
        return len(self.train)

    def parameters_to_save(self) -> dict[str, nn.Module | torch.optim.Optimizer]:
        saved: dict[str, nn.Module | torch.optim.Optimizer] = {
            "network": self.network, "optimizer": self.optimizer, "schedule": _SchedulerModule(self.schedule)
        }
        if self.average is not None:
            saved["average"] = self.average.network
        return saved

    def evaluated_network(self) -> nn.Module:
        return self.network if self.average is None else self.average.network

    def prepare(self, on_progress: Callable[[int, int], None] | None = None) -> None:
        """Start the weight average from the starting weights (``--init-from``'s, once loaded)."""
        if self.average is not None:
            self.average.restart()

    def step(self, index: torch.Tensor, generator: torch.Generator) -> dict[str, float]:
        loss, record = torch.zeros(()), {}
        if self.labelled:
            loss = self._labelled_loss(index, generator)
            record["loss"] = loss.item()
        for name, term in (("anchor", self.anchor), ("exposure", self.exposure)):
            if term is not None:
                term_index = torch.randint(len(term.data), (index.shape[0],), generator=generator)
                term_loss = term.loss(self.network, term_index, generator)
                loss = loss + term.weight * term_loss
                record[f"{name}_loss"] = term_loss.item()
        self.optimizer.zero_grad(set_to_none=True)
        loss.backward()
        self.optimizer.step()
        self.schedule.step()
        if self.average is not None:
            self.average.update()
        return record

    def _labelled_loss(self, index: torch.Tensor, generator: torch.Generator) -> torch.Tensor:
        if self.resample is None:
            states = self.train.states(index, generator)
            logits = self.network(states, self.train.actions[index], **screen_argument(self.train_screen, index))
            targets = self.train.rewards[index, None].expand_as(logits)
        else:
            members = self.resample[:, index]  # (B, batch)
            flat = members.reshape(-1)
            states = self.train.states(flat, generator).reshape(*members.shape, -1)
            logits = self.network(states, self.train.actions[flat].reshape(*members.shape, -1), **screen_argument(self.train_screen, members))
            targets = self.train.rewards[members].T
        return nn.functional.binary_cross_entropy_with_logits(logits, targets)

    @torch.no_grad()
    def evaluate(self) -> Evaluation:
        network = self.evaluated_network()
        metrics = q_metrics(network, self.validation, self.validation_screen)
        if self.exposure is not None:
            sample = self.exposure.data.head(EXPOSURE_MONITOR_PAIRS)
            probabilities = network.probabilities(sample.states(), sample.actions)
            metrics["exposure_variance"] = float(probabilities.var(dim=1, unbiased=False).mean())
        return Evaluation(-metrics["loss"], metrics)


class WeightAverage:
    """An exponential moving average of ``source``'s weights (Polyak averaging): after every
    optimiser step, ``network ← decay · network + (1 − decay) · source``, parameters and buffers.
    ``network`` starts as a copy of ``source`` and averages over about ``1 / (1 − decay)`` steps."""

    def __init__(self, source: nn.Module, decay: float) -> None:
        if not 0.0 < decay < 1.0:
            raise ValueError(f"a weight average's decay lies in (0, 1), not {decay}")
        self.source, self.decay = source, decay
        self.network = copy.deepcopy(source).requires_grad_(False)
        # the floating-point tensors, paired once (loading a state copies into them in place)
        pairs = zip([*self.network.parameters(), *self.network.buffers()], [*source.parameters(), *source.buffers()], strict=True)
        floating = [(a, c) for a, c in pairs if a.is_floating_point()]
        self._averaged, self._current = [a for a, _ in floating], [c for _, c in floating]

    @torch.no_grad()
    def restart(self) -> None:
        """Make the average ``source``'s current weights (new starting weights were loaded into it)."""
        self.network.load_state_dict(self.source.state_dict())

    @torch.no_grad()
    def update(self) -> None:
        """Move the average one step towards ``source``'s current weights."""
        if self._averaged:
            torch._foreach_lerp_(self._averaged, self._current, 1.0 - self.decay)  # noqa: SLF001


class PolicyStage(Stage):
    """Maximum-entropy actor against the frozen ensemble: minimise α·log π(ã|s) − min_i Q_i(s, ã),
    with α learned through log α towards the target entropy −4.

    With ``settings.policy_targets`` = K > 0 it also minimises w·‖tanh μ(s) − a*(s)‖², where a*(s) is
    the best by min-of-8 Q (or the members' mean) of the starting policy's action and K noisy copies of it
    (:func:`searched_actions`): the same objective, searched by sampling where the gradient stops at
    a worse local optimum (docs/guide/skills.md#searched-actor-targets).

    ``network`` is the policy to train (the published MLP when none is given; a
    :class:`~t2m_skills_tableenv.geometric_policy.GeometricGaussianPolicy` gets its probe inputs of
    the stored states computed once).

    The policy is selected by ``simulate(network) -> success rate`` in simulated evaluation scenes
    when given (the published selection), else by the ensemble's mean min-of-8 Q of its actions on
    validation states (a policy can climb that by exploiting the ensemble's errors)."""

    model = "policy"

    def __init__(
        self,
        train: SkillTensors,
        validation: SkillTensors,
        q_ensemble: QEnsemble | RelationalQEnsemble,
        settings: StageSettings,
        simulate: Callable[[GaussianPolicy], float] | None = None,
        network: GaussianPolicy | None = None,
    ) -> None:
        self.train, self.validation = train, validation
        self.simulate = simulate
        self.q_ensemble = q_ensemble.requires_grad_(False)
        self.network = network if network is not None else GaussianPolicy()
        # a geometric policy's probe inputs of the stored states, computed once (row order does not change them)
        self.train_screen, self.validation_screen = policy_screen(self.network, train), policy_screen(self.network, validation)
        self.log_alpha = _LogAlpha()
        self.optimizer = torch.optim.Adam(self.network.parameters(), lr=settings.learning_rate)
        self.alpha_optimizer = torch.optim.Adam(self.log_alpha.parameters(), lr=settings.learning_rate)
        self.target_entropy = -float(ACTION_DIM)
        self.settings = settings
        self.targets: torch.Tensor | None = None
        self.moved = torch.empty(0, dtype=torch.long)  # indices of the samples whose target is not the starting policy's action

    @property
    def train_size(self) -> int:
        return len(self.train)

    def prepare(self, on_progress: Callable[[int, int], None] | None = None) -> None:
        if self.settings.policy_targets:
            generator = torch.Generator().manual_seed(self.settings.seed)
            searched = searched_actions(
                self.network, self.q_ensemble, self.train.rows, self.settings.policy_targets, self.settings.policy_target_sigma, generator,
                value=self.settings.policy_target_value, margin=self.settings.policy_target_margin,
                uniform=self.settings.policy_target_uniform, tolerance=self.settings.policy_target_tolerance, on_progress=on_progress,
            )
            self.targets, self.moved = searched.actions, searched.moved.nonzero()[:, 0]

    def batch(self, size: int, generator: torch.Generator) -> torch.Tensor:
        """Uniform indices, of which a share ``policy_target_focus`` is drawn from the moved samples."""
        focused = round(self.settings.policy_target_focus * size) if len(self.moved) else 0
        index = torch.randint(self.train_size, (size - focused,), generator=generator)
        if not focused:
            return index
        return torch.cat((index, self.moved[torch.randint(len(self.moved), (focused,), generator=generator)]))

    def parameters_to_save(self) -> dict[str, nn.Module | torch.optim.Optimizer]:
        return {"network": self.network, "optimizer": self.optimizer, "log_alpha": self.log_alpha, "alpha_optimizer": self.alpha_optimizer}

    def step(self, index: torch.Tensor, generator: torch.Generator) -> dict[str, float]:
        states = self.train.states(index, generator)
        mean, log_std = self.network.distribution(states, **screen_argument(self.train_screen, index))
        actions, log_prob = self.network.sample_from(mean, log_std)
        q_min = self.q_ensemble.probabilities(states, actions).min(dim=1).values
        alpha = self.log_alpha.value.exp().detach()
        loss = (alpha * log_prob - q_min).mean()
        metrics = {"alpha": alpha.item(), "q_min": q_min.mean().item()}
        if self.targets is not None:
            distance = (torch.tanh(mean) - self.targets[index]).square().sum(-1).mean()  # the deterministic action's
            loss = loss + self.settings.policy_target_weight * distance
            metrics["target_distance"] = distance.item()
        self.optimizer.zero_grad(set_to_none=True)
        loss.backward()
        self.optimizer.step()
        alpha_loss = -(self.log_alpha.value * (log_prob.detach() + self.target_entropy)).mean()
        self.alpha_optimizer.zero_grad(set_to_none=True)
        alpha_loss.backward()
        self.alpha_optimizer.step()
        return {"loss": loss.item(), **metrics}

    @torch.no_grad()
    def evaluate(self) -> Evaluation:
        states = self.validation.states()
        q_min = self.q_ensemble.probabilities(states, self.network(states, **screen_argument(self.validation_screen, slice(None)))).min(dim=1).values
        metrics = {"q_min_mean": float(q_min.mean()), "q_min_above_half": float((q_min > 0.5).float().mean())}
        if len(self.moved):  # how far the policy still is from the targets that are not its starting action
            own = self.network(self.train.states(self.moved), **screen_argument(self.train_screen, self.moved))
            metrics["moved_target_distance"] = float((own - self.targets[self.moved]).square().sum(-1).mean())
        if self.simulate is None:
            return Evaluation(metrics["q_min_mean"], metrics)
        metrics["simulated_success"] = float(self.simulate(self.network))
        # ties in simulated success (a few dozen episodes) go to the ensemble's judgement
        return Evaluation(metrics["simulated_success"] + 1e-3 * metrics["q_min_mean"], metrics)


class SearchedTargets(NamedTuple):
    """The actor's searched targets: ``actions`` ``(N, 4)``; ``moved`` ``(N,)`` bool, where a
    copy displaced the policy's own action."""

    actions: torch.Tensor
    moved: torch.Tensor


@torch.no_grad()
def searched_actions(
    policy: GaussianPolicy,
    q_ensemble: QEnsemble | RelationalQEnsemble,
    rows: torch.Tensor,
    samples: int,
    sigma: float,
    generator: torch.Generator,
    value: Literal["min", "mean"] = "min",
    margin: float = 0.0,
    uniform: float = 0.0,
    tolerance: float = 0.0,
    pairs_per_batch: int = 65_536,
    on_progress: Callable[[int, int], None] | None = None,
) -> SearchedTargets:
    """For each state, the best of the policy's deterministic action and ``samples`` copies of it
    with N(0, sigma²) noise per dimension, clipped to [−1, 1], by the ensemble members' minimum
    (``value="min"``) or mean (``"mean"``) success probability; a copy displaces the policy's own action
    only when valued at least ``margin`` higher. A share ``uniform`` of the copies (rounded) is drawn
    uniformly over [−1, 1]⁴ instead, to reach optima far from the policy's action. With ``tolerance``
    > 0 every copy valued within it of the best counts as best, and the nearest of them to the
    policy's action is chosen: of two equally good optima a state's target is the one its neighbours'
    targets also lie towards, not whichever the noise happened to rank first.

    Args:
        rows: ``(N, 8, 12)`` states in their stored row order; identical states share one search.

        on_progress: called with (distinct states searched, distinct states) after every batch.

    Returns:
        The targets; a state's target is never valued below the policy's own action.
    """
    unique, inverse = torch.unique(rows.reshape(rows.shape[0], -1), dim=0, return_inverse=True)
    best = torch.empty(unique.shape[0], ACTION_DIM)
    moved = torch.zeros(unique.shape[0], dtype=torch.bool)
    chunk = max(1, pairs_per_batch // (samples + 1))
    for start in range(0, unique.shape[0], chunk):
        states = unique[start:start + chunk]
        action = policy(states)
        spread = round(uniform * samples)
        noise = sigma * torch.randn(states.shape[0], samples - spread, ACTION_DIM, generator=generator)
        anywhere = 2.0 * torch.rand(states.shape[0], spread, ACTION_DIM, generator=generator) - 1.0
        candidates = torch.cat((action[:, None], (action[:, None] + noise).clamp(-1.0, 1.0), anywhere), dim=1)  # (n, samples + 1, 4)
        repeated = states[:, None].expand(-1, samples + 1, -1).reshape(-1, states.shape[1])
        members = q_ensemble.probabilities(repeated, candidates.reshape(-1, ACTION_DIM))
        ranked = (members.min(dim=1).values if value == "min" else members.mean(dim=1)).reshape(states.shape[0], -1)
        if tolerance > 0:
            near_best = ranked >= ranked.max(dim=1, keepdim=True).values - tolerance
            moves = (candidates - action[:, None]).square().sum(-1)
            chosen = moves.masked_fill(~near_best, math.inf).argmin(dim=1)
        else:
            chosen = ranked.argmax(dim=1)
        chosen[ranked.gather(1, chosen[:, None])[:, 0] < ranked[:, 0] + margin] = 0  # the own action, column 0
        best[start:start + chunk] = candidates[torch.arange(states.shape[0]), chosen]
        moved[start:start + chunk] = chosen != 0
        if on_progress:
            on_progress(start + states.shape[0], unique.shape[0])
    return SearchedTargets(best[inverse], moved[inverse])


class DynamicsStage(Stage):
    """MSE of the residual prediction to the encoded next state, on successful transitions (``network``:
    the published MLP when none is given)."""

    model = "dynamics"

    def __init__(self, train: SkillTensors, validation: SkillTensors, settings: StageSettings, network: nn.Module | None = None) -> None:
        self.train, self.validation = train.successes(), validation.successes()
        self.network = network if network is not None else Dynamics()
        self.optimizer = torch.optim.Adam(self.network.parameters(), lr=settings.learning_rate)

    @property
    def train_size(self) -> int:
        return len(self.train)

    def parameters_to_save(self) -> dict[str, nn.Module | torch.optim.Optimizer]:
        return {"network": self.network, "optimizer": self.optimizer}

    def step(self, index: torch.Tensor, generator: torch.Generator) -> dict[str, float]:
        states = self.train.states(index)
        targets = self.train.next_rows[index].reshape(len(index), -1)
        loss = self.loss(self.network(states, self.train.actions[index]), targets)
        self.optimizer.zero_grad(set_to_none=True)
        loss.backward()
        self.optimizer.step()
        return {"loss": loss.item()}

    @torch.no_grad()
    def evaluate(self) -> Evaluation:
        states = self.validation.states()
        targets = self.validation.next_rows.reshape(len(self.validation), -1)
        loss = float(self.loss(self.network(states, self.validation.actions), targets))
        return Evaluation(-loss, {"loss": loss})

    def loss(self, predicted: torch.Tensor, targets: torch.Tensor) -> torch.Tensor:
        """The network's own loss where it has one (:meth:`PriorDynamics.loss`: yaws modulo a turn),
        else the published mean squared error."""
        own = getattr(self.network, "loss", None)
        return own(predicted, targets) if own is not None else nn.functional.mse_loss(predicted, targets)


def data_screen(network: nn.Module, data: SkillTensors) -> torch.Tensor | None:
    """``(N, F)`` a geometric ensemble's screen inputs for the stored pairs of ``data``
    (:class:`~t2m_skills_tableenv.geometric_q.GeometricQEnsemble`); ``None`` for the other networks."""
    screen = getattr(network, "screen", None)
    return None if screen is None else screen(data.states(), data.actions)


def policy_screen(network: nn.Module, data: SkillTensors) -> torch.Tensor | None:
    """``(N, K)`` a geometric policy's probe inputs for the stored states of ``data`` (``None`` for
    the published policy)."""
    screen = getattr(network, "screen", None)
    return None if screen is None else screen(data.states())


def screen_argument(screen: torch.Tensor | None, index: torch.Tensor | slice) -> dict[str, torch.Tensor]:
    """The keyword a geometric ensemble or policy takes for the stored rows ``index`` (none for the others)."""
    return {} if screen is None else {"screen": screen[index]}


@torch.no_grad()
def q_metrics(network: QEnsemble | RelationalQEnsemble, data: SkillTensors, screen: torch.Tensor | None = None) -> dict[str, float]:
    """Validation BCE, and precision / recall / accuracy of the pessimistic prediction
    min_i Q_i > 0.5 (what planning uses) against the rewards. ``screen``: a geometric ensemble's
    :func:`data_screen` of ``data``, computed by the network when not given."""
    states = data.states()
    logits = network(states, data.actions, **screen_argument(screen, slice(None)))
    targets = data.rewards[:, None].expand_as(logits)
    loss = float(nn.functional.binary_cross_entropy_with_logits(logits, targets))
    predicted = torch.sigmoid(logits).min(dim=1).values > 0.5
    actual = data.rewards > 0.5
    true_positive = float((predicted & actual).sum())
    return {
        "loss": loss,
        "precision": true_positive / max(float(predicted.sum()), 1.0),
        "recall": true_positive / max(float(actual.sum()), 1.0),
        "accuracy": float((predicted == actual).float().mean()),
    }


class _LogAlpha(nn.Module):
    def __init__(self) -> None:
        super().__init__()
        self.value = nn.Parameter(torch.tensor(math.log(0.1)))


class _SchedulerModule(nn.Module):
    """Carries a scheduler's step count through :func:`save_training_state` as a buffer."""

    def __init__(self, schedule: torch.optim.lr_scheduler.LRScheduler) -> None:
        super().__init__()
        self.schedule = schedule
        self.register_buffer("last_epoch", torch.tensor(schedule.last_epoch))

    def state_dict(self, *args: Any, **kwargs: Any) -> dict[str, Any]:
        return {"last_epoch": torch.tensor(self.schedule.last_epoch)}

    def load_state_dict(self, state: dict[str, Any], strict: bool = True, assign: bool = False) -> Any:
        self.schedule.last_epoch = int(state["last_epoch"])
        self.schedule._last_lr = [group["lr"] for group in self.schedule.optimizer.param_groups]  # noqa: SLF001
        return None


# --------------------------------------------------------------------------------------------------
# The loop
# --------------------------------------------------------------------------------------------------


def run_stage(
    stage: Stage,
    settings: StageSettings,
    checkpoint: Path,
    *,
    on_progress: Callable[[int, dict[str, float]], None] | None = None,
) -> dict[str, Any]:
    """Train ``stage`` for ``settings.steps`` steps (resuming from its saved state), keep the best
    evaluated weights in ``checkpoint/<model>.safetensors`` and return the best metrics.

    Raises:
        ValueError: an empty training set.
    """
    if stage.train_size == 0:
        raise ValueError(f"no training samples for the {stage.model} model")
    checkpoint.mkdir(parents=True, exist_ok=True)
    state_path = checkpoint / ".training" / f"{stage.model}.safetensors"
    metrics_path = checkpoint / f"metrics-{stage.model}.jsonl"
    weights_path = checkpoint / WEIGHT_FILES[stage.model]
    torch.manual_seed(settings.seed)
    generator = torch.Generator().manual_seed(settings.seed)
    best = {"score": -math.inf, "step": 0, "metrics": {}}
    step = 0
    saved = stage.parameters_to_save()
    if state_path.exists():
        extra = load_training_state(state_path, {**saved, "generator": _GeneratorModule(generator)})
        if _saved_settings(extra.get("settings")) != settings.model_dump():  # never mix two schedules in one model
            raise T2MError(
                f"{state_path} is the interrupted run of a {stage.model} model with other settings ({extra.get('settings')})",
                f"rerun with those settings to resume it, or delete {state_path} to train the {stage.model} model afresh",
            )
        step, best = extra["step"], extra["best"]
    elif metrics_path.exists():
        metrics_path.unlink()  # a fresh run: the old curve is not this run's
    started, first_step = time.perf_counter(), step
    running: dict[str, float] = {}
    while step < settings.steps and not _stopped_early(settings, step, best["step"]):
        index = stage.batch(settings.batch_size, generator)
        for key, value in stage.step(index, generator).items():
            running[key] = running.get(key, 0.0) + value
        step += 1
        if step % settings.eval_every == 0 or step == settings.steps:
            evaluation = stage.evaluate()
            train_means = {f"train_{k}": v / settings.eval_every for k, v in running.items()}
            running = {}
            record = {"step": step, "seconds": round(time.perf_counter() - started, 2), **train_means, **evaluation.metrics}
            with open(metrics_path, "a", encoding="utf-8") as handle:
                handle.write(json.dumps(record) + "\n")
            if evaluation.score > best["score"]:
                best = {"score": evaluation.score, "step": step, "metrics": evaluation.metrics}
                save_weights(weights_path, stage.evaluated_network())
            save_training_state(
                state_path,
                {**saved, "generator": _GeneratorModule(generator)},
                {"step": step, "best": best, "settings": settings.model_dump()},
            )
            if on_progress:
                on_progress(step, record)
    # a rerun of a finished stage runs no step: it has no rate to report
    steps_per_second = round((step - first_step) / (time.perf_counter() - started), 1) if step > first_step else None
    return {
        "best_step": best["step"], "best": best["metrics"], "steps": step, "scheduled_steps": settings.steps, "steps_per_second": steps_per_second,
        "threads": torch.get_num_threads(),
    }


def _stopped_early(settings: StageSettings, step: int, best_step: int) -> bool:
    """Whether ``patience`` evaluations have passed since the best one (a resumed run that had
    stopped early stays stopped)."""
    return settings.patience is not None and step - best_step >= settings.patience * settings.eval_every


def _saved_settings(saved: Any) -> dict[str, Any] | None:
    """A saved state's settings with the defaults of fields added since it was saved (a run
    started by an older t2m resumes when its schedule is unchanged)."""
    try:
        return StageSettings.model_validate(saved).model_dump()
    except ValueError:
        return None


class _GeneratorModule(nn.Module):
    """Carries a torch generator's state through :func:`save_training_state`."""

    def __init__(self, generator: torch.Generator) -> None:
        super().__init__()
        self.generator = generator

    def state_dict(self, *args: Any, **kwargs: Any) -> dict[str, Any]:
        return {"state": self.generator.get_state()}

    def load_state_dict(self, state: dict[str, Any], strict: bool = True, assign: bool = False) -> Any:
        self.generator.set_state(state["state"])
        return None


def record_stage(checkpoint: Path, skill: str, model: str, settings: StageSettings, result: dict[str, Any], data: dict[str, Any]) -> None:
    """Write what trained the model and how well into the checkpoint's ``config.json``: ``data`` holds
    the splits' manifest digests and the transitions used (``train_transitions``, ``validation_transitions``)."""
    from t2m_skills_tableenv.checkpoints import read_config

    config = read_config(checkpoint) if (checkpoint / "config.json").exists() else {}
    models = dict(config.get("models", {}))
    models[model] = {
        "file": WEIGHT_FILES[model],
        "architecture": architecture(skill, model, settings),
        "training": settings.model_dump(),
        "data": data,
        "result": result,
    }
    update_config(checkpoint, skill=skill, models=models)


ARCHITECTURES: dict[str, dict[str, Any]] = {
    "q": q_architecture("pick", "mlp"),
    "policy": policy_architecture("pick", "mlp"),
    "dynamics": dynamics_architecture("pick", "mlp"),
}
"""The published (MLP) architecture of each model; the MLPs do not depend on the skill."""


def architecture(skill: str, model: str, settings: StageSettings) -> dict[str, Any]:
    """The ``config.json`` architecture of ``skill``'s ``model`` trained with ``settings``."""
    if model == "q":
        return q_architecture(skill, settings.q_network, settings.screen)
    if model == "dynamics":
        return dynamics_architecture(skill, settings.dynamics_network)
    return policy_architecture(skill, settings.policy_network)



def train_skill(
    skill: str,
    models: tuple[str, ...],
    data: Path,
    checkpoint: Path,
    overrides: dict[str, Any] | None = None,
    *,
    on_progress: Callable[[str, int, int, dict[str, float]], None] | None = None,
    simulator: str = "mujoco",
    more_train: tuple[Path, ...] = (),
    init_from: Path | None = None,
    anchor: tuple[Path, ...] = (),
    ood_exposure: tuple[Path, ...] = (),
) -> dict[str, Any]:
    """Train ``models`` (in the order q, policy, dynamics) of ``skill`` from the dataset ``data``
    (``DIR`` of ``t2m datagen``) into the checkpoint directory ``checkpoint``.

    ``more_train`` names further dataset directories whose ``<skill>/train`` splits are appended to
    ``data``'s (data made with other settings or on other machines); validation stays ``data``'s.

    ``init_from`` names a checkpoints directory (one sub-directory per skill) whose weights start
    each trained model instead of a fresh initialisation: fine-tuning on new data, such as the
    planner's own proposals (docs/guide/skills.md#proposal-data), when the data that trained those
    weights is not at hand. The checkpoint records the starting weights' digest.

    ``anchor`` names dataset directories whose ``<skill>/train`` splits the Q-ensemble learns from
    the ``init_from`` ensemble's predictions instead of their labels (a directory also given as
    ``data`` or ``more_train`` is then left out of the labelled set): fine-tuning on a new situation
    without forgetting the others (docs/guide/skills.md#anchored-fine-tuning).

    ``ood_exposure`` names dataset directories whose ``<skill>/invalid`` splits the Q-ensemble's members
    learn to disagree on (:class:`Exposure`; docs/guide/skills.md#ood-exposure). With anchors, the
    labelled set may then be empty (every training split anchored): the ensemble keeps its
    predictions and learns only the exposure.

    The policy is selected in episodes simulated by the simulator plugin ``simulator`` when its
    ``selection_episodes`` is positive (the default).

    The policy needs the Q-ensemble already in ``checkpoint`` when ``q`` is not trained with it.
    ``overrides`` replace fields of every stage's :data:`DEFAULT_SETTINGS` (e.g. ``{"steps": 2000}``);
    ``on_progress(model, step, total_steps, metrics)`` is called after every evaluation.

    Returns:
        model -> result (best step, best validation metrics, steps per second).
    """
    from t2m_core.data.generate import manifest_digest
    from t2m_skills_tableenv.checkpoints import load_weights

    settings = {model: _with_overrides(stage, overrides or {}) for model, stage in DEFAULT_SETTINGS.items()}
    _check_screen(skill, settings["q"])
    anchor_dirs = tuple(Path(d) / skill / "train" for d in anchor)
    if anchor_dirs and (init_from is None or tuple(models) != ("q",)):
        # the policy and dynamics would otherwise train on the labelled splits alone
        raise T2MError("anchor data keep what a starting Q-ensemble predicts there: they need --init-from and the Q-ensemble "
                       "trained alone", "add --init-from CHECKPOINTS and --model q")
    train_dir, validation_dir = Path(data) / skill / "train", Path(data) / skill / "validation"
    more_dirs = tuple(Path(d) / skill / "train" for d in more_train)
    anchored = {d.resolve() for d in anchor_dirs}
    labelled = [d for d in (train_dir, *more_dirs) if d.resolve() not in anchored]
    exposure_dirs = tuple(Path(d) / skill / "invalid" for d in ood_exposure)
    if exposure_dirs and "q" not in models:
        raise T2MError("OOD exposure data train the Q-ensemble only", "add --model q (or all)")
    if not labelled and not exposure_dirs:
        raise T2MError("every training split is anchor data: nothing is left to learn from labels", "add --more-train with the new situation's data")
    anchor_states = SkillTensors.load(*anchor_dirs) if anchor_dirs else None
    # without labels, the anchor states only size the steps' batches
    train, validation = SkillTensors.load(*labelled) if labelled else anchor_states, SkillTensors.load(validation_dir)
    digests: dict[str, Any] = {"train": manifest_digest(train_dir), "validation": manifest_digest(validation_dir)}
    if more_dirs:
        digests["more_train"] = [manifest_digest(d) for d in more_dirs]
    if anchor_dirs:
        digests["anchor"] = [manifest_digest(d) for d in anchor_dirs]
    if exposure_dirs:
        digests["ood_exposure"] = [manifest_digest(d) for d in exposure_dirs]
    if init_from is not None:
        from t2m_core.data.proposals import checkpoint_digest

        digests["init_from"] = checkpoint_digest(init_from, skill)
    checkpoint.mkdir(parents=True, exist_ok=True)
    results = {}
    for model in MODELS:
        if model not in models:
            continue
        stage_settings = settings[model]
        torch.manual_seed(stage_settings.seed)
        stage_train = train.head(stage_settings.train_size)
        if model == "q":
            anchor_data = None
            if anchor_states is not None:
                anchor_data = Anchor(anchor_states, load_q(Path(init_from) / skill).eval(), stage_settings.anchor_weight)
            exposure = Exposure(SkillTensors.load(*exposure_dirs), stage_settings.exposure_weight) if exposure_dirs else None
            network = build_q(architecture(skill, "q", stage_settings))
            stage: Stage = QStage(stage_train, validation, stage_settings, network, anchor_data, exposure, labelled=bool(labelled))
        elif model == "policy":
            q_ensemble = load_q(checkpoint)
            simulate = _simulated_selection(skill, simulator, stage_settings.selection_episodes) if stage_settings.selection_episodes else None
            stage = PolicyStage(stage_train, validation, q_ensemble, stage_settings, simulate, build_policy(architecture(skill, "policy", stage_settings)))
        else:
            if init_from is not None:
                _require_same_dynamics(Path(init_from) / skill, stage_settings.dynamics_network)
            stage = DynamicsStage(stage_train, validation, stage_settings, build_dynamics(architecture(skill, "dynamics", stage_settings)))
        distilled = model == "q" and init_from is not None and _distills(Path(init_from) / skill, stage_settings.q_network, bool(anchor_dirs))
        if init_from is not None and model == "policy":
            load_policy_weights(Path(init_from) / skill, stage.network)
        elif init_from is not None and not distilled:
            load_weights(Path(init_from) / skill / WEIGHT_FILES[model], stage.network)
        started = time.perf_counter()
        # the bar counts the distinct states searched, then the steps
        stage.prepare((lambda done, total, model=model: on_progress(model, done, total, {"targets_searched": done})) if on_progress else None)
        prepare_seconds = round(time.perf_counter() - started, 1)
        total = stage_settings.steps
        report = (lambda step, record, model=model, total=total: on_progress(model, step, total, record)) if on_progress else None
        results[model] = run_stage(stage, stage_settings, checkpoint, on_progress=report)
        if model == "policy" and stage_settings.policy_targets:
            results[model]["target_search_seconds"] = prepare_seconds
        stage_data = {**digests, "train_transitions": len(stage_train), "validation_transitions": len(validation)}
        if distilled:
            stage_data["distilled"] = True  # init_from taught the anchors; its weights did not start this network
        record_stage(checkpoint, skill, model, stage_settings, results[model], stage_data)
    return results


def _distills(directory: Path, q_network: str, anchored: bool) -> bool:
    """Whether the Q-ensemble of ``directory`` is distilled into a fresh network of another kind
    (``q_network``) instead of fine-tuned: the new network then learns the starting ensemble's
    predictions on the anchor states (:class:`Anchor`), member for member, from a fresh
    initialisation (docs/guide/skills.md#distilling-into-another-network).

    Raises:
        T2MError: the networks differ and there are no anchors to distil on.
    """
    from t2m_skills_tableenv.checkpoints import architecture_of
    from t2m_skills_tableenv.networks import q_network_name

    starting = q_network_name(architecture_of(directory, "q"))
    if starting == q_network:
        return False
    if not anchored:
        raise T2MError(
            f"{directory} holds a {starting} Q-ensemble and the settings train a {q_network} one",
            f"fine-tune it with --q-network {starting}, distil it into a {q_network} one with --anchor DATA, "
            f"or train a {q_network} ensemble without --init-from",
        )
    return True


def _require_same_dynamics(directory: Path, network: str) -> None:
    """Refuse to fine-tune the dynamics of ``directory`` into a network of another kind.

    Raises:
        T2MError: the starting model is not a ``network`` one.
    """
    from t2m_skills_tableenv.checkpoints import architecture_of
    from t2m_skills_tableenv.networks import dynamics_network_name

    starting = dynamics_network_name(architecture_of(directory, "dynamics"))
    if starting != network:
        raise T2MError(
            f"{directory} holds a {starting} dynamics model and the settings train a {network} one",
            f"fine-tune it with --dynamics-network {starting}, or train a {network} one without --init-from",
        )


def _check_screen(skill: str, settings: StageSettings) -> None:
    """Refuse screen predictions the network does not read or the skill's primitive does not make.

    Raises:
        T2MError: naming the problem and the choice.
    """
    from t2m_skills_tableenv.geometric_screen import screen_features

    if settings.screen is None:
        return
    if settings.q_network != "geometric":
        raise T2MError(f"--screen is read by the geometric Q-ensemble, not the {settings.q_network} one", "add --q-network geometric, or drop --screen")
    try:
        screen_features(skill, settings.screen)
    except ValueError as error:
        raise T2MError(str(error), "choose --screen among the predictions named") from None


def _with_overrides(settings: StageSettings, overrides: dict[str, Any]) -> StageSettings:
    """``settings`` with ``overrides`` applied and validated like the defaults.

    Raises:
        T2MError: an unknown field or a value out of its range, named with the valid ones.
    """
    try:
        return StageSettings.model_validate({**settings.model_dump(), **overrides})
    except ValidationError as error:
        problems = "; ".join(f"{'.'.join(str(part) for part in e['loc'])}: {e['msg']}" for e in error.errors())
        raise T2MError(f"invalid training settings: {problems}", f"settings are {', '.join(StageSettings.model_fields)}") from None


def _simulated_selection(skill: str, simulator_name: str, episodes: int) -> Callable[[GaussianPolicy], float]:
    """``policy network -> success rate`` over the same ``episodes`` evaluation scenes every time."""
    from t2m_core.registry import get_registry
    from t2m_skills_tableenv.episodes import SELECTION_SEED, policy_success

    simulator = get_registry().create("simulator", simulator_name)

    def simulate(network: GaussianPolicy) -> float:
        with torch.no_grad():
            act = lambda states: network(torch.as_tensor(states, dtype=torch.float32)).numpy()  # noqa: E731
            return policy_success(skill, act, simulator, episodes, seed=SELECTION_SEED)["success_rate"]

    return simulate
