"""The learned TableEnv skills as :class:`t2m_core.protocols.Skill` objects
(docs/guide/skills.md#the-skill-library).

Each method takes NumPy arrays or torch tensors and answers in the same kind, batched over the
first axis, without gradients. Models are loaded once, when the library is built.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import nn

from t2m_core.data.scenes import DATA_SKILLS
from t2m_core.ood import members_variance
from t2m_core.protocols import Batch
from t2m_skills_tableenv.checkpoints import CheckpointError, load_dynamics, load_q, load_weights, read_config
from t2m_skills_tableenv.geometric_policy import build_policy
from t2m_skills_tableenv.networks import GaussianPolicy, QEnsemble, RelationalQEnsemble
from t2m_skills_tableenv.options import TableEnvSkillsOptions
from t2m_skills_tableenv.training import WEIGHT_FILES


class TableEnvSkill:
    """One learned skill: policy, Q-ensemble, dynamics and OOD detector.

    Attributes:
        name: the primitive (``"pick"``).
        action_dim: 4.
        ensemble_size: B, the Q-ensemble's members (8).
        ood_threshold: ε; a (state, action) whose detector variance is ≥ ε is out of distribution.
        config: the checkpoint's ``config.json``.
        detector: a separate OOD detector ensemble, or ``None``: the Q-ensemble detects (published).
        detector_config: the ``config.json`` of the detector's checkpoint, or ``None``.
        detector_directory: where the detector was loaded from, or ``None``.
    """

    action_dim = 4

    def __init__(
        self, name: str, q_ensemble: QEnsemble | RelationalQEnsemble, policy: GaussianPolicy, dynamics: nn.Module, config: dict[str, Any],
        detector: QEnsemble | RelationalQEnsemble | None = None, detector_config: dict[str, Any] | None = None,
        detector_directory: Path | None = None,
    ) -> None:
        self.name = name
        self.q_ensemble = q_ensemble.eval().requires_grad_(False)
        self.policy_network = policy.eval().requires_grad_(False)
        self.dynamics = dynamics.eval().requires_grad_(False)
        self.ensemble_size = q_ensemble.members
        self.config = config
        self.detector = None if detector is None else detector.eval().requires_grad_(False)
        self.detector_config = detector_config
        self.detector_directory = detector_directory
        self.ood_threshold = float(self.ood_calibration.get("threshold", np.inf))

    @property
    def ood_calibration(self) -> dict[str, Any]:
        """The ``ood`` section (threshold, rates) of whichever checkpoint detects: the detector's, else this skill's."""
        return (self.detector_config if self.detector is not None else self.config).get("ood", {})

    @property
    def ood_ensemble(self) -> QEnsemble | RelationalQEnsemble:
        """The ensemble whose member variance is thresholded: the detector, else the Q-ensemble."""
        return self.detector if self.detector is not None else self.q_ensemble

    @classmethod
    def load(cls, directory: Path) -> TableEnvSkill:
        """Load a skill checkpoint directory.

        Raises:
            CheckpointError: a missing, corrupt or mismatched file, named.
        """
        directory = Path(directory)
        config = read_config(directory)
        name = config.get("skill", directory.name)
        missing = [m for m in WEIGHT_FILES if m not in config.get("models", {})]
        if missing:
            raise CheckpointError(f"{directory / 'config.json'} has no {', '.join(missing)} model", f"train it: t2m train --skill {name} --model all")
        return cls(
            name,
            load_q(directory),
            load_weights(directory / WEIGHT_FILES["policy"], _policy_network(directory, config)),
            load_dynamics(directory),
            config,
        )

    @torch.no_grad()
    def policy(self, states: Batch) -> Batch:
        """Deterministic actions ``(N, 4)`` in [−1, 1] for skill states ``(N, 96)``."""
        return _same_kind(states, self.policy_network(_tensor(states)))

    @torch.no_grad()
    def q_values(self, states: Batch, actions: Batch) -> Batch:
        """Success probability of every member, ``(N, B)``, for ``(N, 96)`` states and ``(N, 4)`` actions."""
        return _same_kind(states, self.q_ensemble.probabilities(_tensor(states), _tensor(actions)))

    @torch.no_grad()
    def predict(self, states: Batch, actions: Batch) -> Batch:
        """Predicted next dynamics state ``(N, 96)`` (normalised, argument-first; not yet clamped)."""
        return _same_kind(states, self.dynamics(_tensor(states), _tensor(actions)))

    @torch.no_grad()
    def ood_variance(self, states: Batch, actions: Batch, q_members: Batch) -> Batch:
        """``(N,)`` what ``ood_threshold`` thresholds: the population variance of the detector's
        member probabilities, or of ``q_members`` (``(N, B)``, this skill's ``q_values``) without one."""
        if self.detector is None:
            return members_variance(q_members)
        return _same_kind(states, members_variance(self.detector.probabilities(_tensor(states), _tensor(actions))))

    def with_detector(self, directory: Path) -> TableEnvSkill:
        """This skill with the Q-ensemble and calibrated threshold of the checkpoint ``directory`` as
        its OOD detector (docs/guide/skills.md#a-separate-detector).

        Raises:
            CheckpointError: the directory's checkpoint is missing, broken, of another skill or not calibrated.
        """
        directory = Path(directory)
        config = read_config(directory)
        if config.get("skill", directory.name) != self.name:
            raise CheckpointError(f"{directory / 'config.json'} holds a {config.get('skill')!r} skill, not {self.name!r}", f"put the {self.name} detector in {directory}")
        if "threshold" not in config.get("ood", {}):
            raise CheckpointError(f"{directory / 'config.json'} has no OOD threshold", f"calibrate it: t2m calibrate --skill {self.name} --data DATA --out {directory.parent}")
        return TableEnvSkill(self.name, self.q_ensemble, self.policy_network, self.dynamics, self.config, load_q(directory), config, directory)


def _policy_network(directory: Path, config: dict[str, Any]) -> GaussianPolicy:
    """A fresh policy of the architecture ``config`` records (the published one when it names none)."""
    try:
        return build_policy(config["models"]["policy"].get("architecture", {}))
    except ValueError as error:
        raise CheckpointError(f"{directory / 'config.json'}: {error}", "update t2m, or retrain the policy") from None


def _tensor(values: Batch) -> torch.Tensor:
    if isinstance(values, torch.Tensor):
        return values.float()
    return torch.from_numpy(np.ascontiguousarray(values, dtype=np.float32))


def _same_kind(like: Batch, result: torch.Tensor) -> Batch:
    return result if isinstance(like, torch.Tensor) else result.numpy()


def load_library(options: TableEnvSkillsOptions | None = None) -> dict[str, TableEnvSkill]:
    """The four skills from ``options.checkpoints`` (the shipped checkpoints by default), each with
    its separate OOD detector when ``options`` name or the checkpoints directory holds one
    (:attr:`~t2m_skills_tableenv.options.TableEnvSkillsOptions.detector_directory`).

    Raises:
        CheckpointError: a skill's checkpoint is missing or broken.
    """
    options = options or TableEnvSkillsOptions()
    library = {}
    for name in DATA_SKILLS:
        directory = options.checkpoint_directory / name
        skill = library[name] = TableEnvSkill.load(directory)
        if skill.name != name:
            raise CheckpointError(f"{directory / 'config.json'} holds a {skill.name!r} skill, not {name!r}", f"put the {name} checkpoint in {directory}")
        if options.detector_directory is not None:
            library[name] = skill.with_detector(options.detector_directory / name)
    return library
